"""``weavecap train-renderer``: regenerate the output renderers' networks (``--fold``: the BLIDF)."""

from __future__ import annotations

import time
from pathlib import Path

import click

from .options import claim_work_folder, force_option, quiet_option, seed_option


@click.command(context_settings={"max_content_width": 100})
@click.option("--fold", "fold", is_flag=True, help="Train the fold renderer's BLIDF (Son et al.) on the procedural "
                                                   "fold suite, with LocalPT as ground truth.")
@click.option("--work", "work", default="renderer-work", show_default=True,
              type=click.Path(file_okay=False, path_type=Path),
              help="Folder for the training data shards and checkpoint; an interrupted run resumes from it.")
@click.option("-o", "--output", "out", default=None, type=click.Path(dir_okay=False, path_type=Path),
              help="Weights file to write  [default: the package's weavecap/render/fold/weights/blidf.json]")
@click.option("--lights", default=48, show_default=True, type=click.IntRange(2, 10000),
              help="Directional lights per mesh (each with a random fabric); the last block is held out.")
@click.option("--per-light", default=300, show_default=True, type=click.IntRange(1, 100000),
              help="Vertices (both sides each) per light.")
@click.option("--epochs", default=160, show_default=True, type=click.IntRange(1, 10000), help="Training epochs.")
@seed_option
@force_option
@quiet_option
def train_renderer(fold: bool, work: Path, out: Path | None, lights: int, per_light: int, epochs: int, seed: int,
                   force: bool, quiet: bool) -> None:
    """Make the training data of an output renderer and train its network.

    --fold: for every mesh of the fold suite (weavecap/render/shapes.py: sines of three
    amplitudes and a finer one, waves, horseshoes wide and narrow, a skirt, a drape), LocalPT
    renders the local inter-reflection at vertices under directional lights from all around,
    in the surface model of four fixture fabrics (plain, twill_2_1, satin_5, custom_4x6); the
    BLIDF (1.4K parameters) is fitted to it. The weights file
    records the settings, the data and training times and the held-out errors. The same --seed
    gives the same data. About half an hour on two busy cores.

    \b
    Examples:
      weavecap train-renderer --fold                              # the shipped weights
      weavecap train-renderer --fold --work /tmp/w -o /tmp/blidf.json --lights 8 --per-light 50 --epochs 2
    """
    from weavecap.errors import InputError
    from weavecap.io import refuse_overwrite

    if not fold:
        raise click.UsageError("say which renderer to train: --fold (the fold renderer's BLIDF)")
    from weavecap.render.fold import blidf, training

    target = out or blidf.weights_path()
    refuse_overwrite(target, force=force)
    try:
        config = training.TrainConfig(seed=seed, lights=lights, per_light=per_light, epochs=epochs,
                                      block=min(8, max(1, lights // 2)))
    except ValueError as exc:
        raise InputError(str(exc)) from None
    claim_work_folder(work, config.data_settings())

    def progress(message: str) -> None:
        if not quiet:
            click.echo(f"weavecap train-renderer: {message}", err=True)

    t0 = time.perf_counter()
    meshes = training.fold_suite()
    data_seconds = training.generate_data(work, meshes, config, progress=progress)
    net, train_seconds, errors = training.train(work, meshes, config, progress=progress)
    radii = training.mesh_radii(work, meshes, config)
    training.write_weights(target, net, meshes, config, data_seconds=data_seconds, train_seconds=train_seconds,
                           errors=errors, radii=radii)
    progress(f"wrote {target} (held-out RMSE {errors['heldout']['rmse']:.5f}, without the fold term "
             f"{errors['heldout']['rmse_without']:.5f}; data {data_seconds:.0f} s, training {train_seconds:.0f} s, "
             f"this run {time.perf_counter() - t0:.0f} s)")
