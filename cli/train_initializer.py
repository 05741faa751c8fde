"""``weavecap train-initializer``: regenerate the initializer's training data and weights (§5.3)."""

from __future__ import annotations

import time
from pathlib import Path

import click

from .options import claim_work_folder, force_option, quiet_option, seed_option


@click.command(context_settings={"max_content_width": 100})
@click.option("--work", "work", default="initializer-work", show_default=True,
              type=click.Path(file_okay=False, path_type=Path),
              help="Folder for the rendered data shards and the training checkpoint; a run that was "
                   "interrupted resumes from what is there.")
@click.option("-o", "--output", "out_dir", default=None, type=click.Path(file_okay=False, path_type=Path),
              help="Folder for initializer.pt and initializer.json  [default: the package's weights folder]")
@click.option("--geometries", default=600, show_default=True, type=click.IntRange(2, 100000),
              help="Random patterns and radii to render (the rays are cast once per geometry).")
@click.option("--per-geometry", default=8, show_default=True, type=click.IntRange(1, 64),
              help="Random appearances rendered per geometry (images = geometries x this).")
@click.option("--shard-size", default=50, show_default=True, type=click.IntRange(1, 10000),
              help="Geometries per data shard (the unit of resuming); the last shard is held out.")
@click.option("--epochs", default=12, show_default=True, type=click.IntRange(1, 1000), help="Training epochs.")
@seed_option
@force_option
@quiet_option
def train_initializer(work: Path, out_dir: Path | None, geometries: int, per_geometry: int, shard_size: int,
                      epochs: int, seed: int,
                      force: bool, quiet: bool) -> None:
    """Render training data with the forward model and train the parameter initializer.

    Each image is a 4x4-cell window of a random fabric: a pattern (plain, twill, satin, basket,
    rib or random) and parameters drawn over Table 1's ranges, under the default light rig.
    The VGG-style network (§5.3) is trained from scratch on them; the last shards are held out
    and the record beside the weights gives, per parameter, the held-out error next to that of
    always predicting the middle of the range. The same --seed gives the same data.

    \b
    Examples:
      weavecap train-initializer                       # the shipped weights (~25 min on 2 busy cores)
      weavecap train-initializer --work /tmp/w -o /tmp/weights --geometries 8 --shard-size 4 --epochs 1
    """
    from weavecap.errors import InputError
    from weavecap.estimate.initializer import RECORD_FILE, WEIGHTS_FILE, weights_dir
    import numpy as np

    from weavecap.training.initializer import TrainConfig, generate_data, heldout_errors, load_data, train, write_weights
    from weavecap.io import refuse_overwrite

    out_dir = out_dir or weights_dir()
    for name in (WEIGHTS_FILE, RECORD_FILE):
        refuse_overwrite(out_dir / name, force=force)
    try:
        config = TrainConfig(seed=seed, geometries=geometries, per_geometry=per_geometry,
                             shard_geometries=shard_size, epochs=epochs)
    except ValueError as exc:
        raise InputError(f"--geometries/--shard-size: {exc}") from None
    claim_work_folder(work, config.data_settings())

    def progress(message: str) -> None:
        if not quiet:
            click.echo(f"weavecap train-initializer: {message}", err=True)

    t0 = time.perf_counter()
    data_seconds = generate_data(work, config, progress=progress)
    net, train_seconds = train(work, config, progress=progress)
    train_set, held = load_data(work, config)
    errors = heldout_errors(net, held)
    counts = {"images": int(len(train_set["y"]) + len(held["y"])), "train": int(len(train_set["y"])),
              "heldout": int(len(held["y"])), "geometries": geometries,
              "families": {str(f): int(n) for f, n in zip(*np.unique(
                  train_set["family"], return_counts=True))}}
    write_weights(out_dir, net, config, data_seconds=data_seconds, train_seconds=train_seconds, held=errors,
                  counts=counts)
    progress(f"wrote {out_dir / WEIGHTS_FILE} and {out_dir / RECORD_FILE} "
             f"(data {data_seconds:.0f} s, training {train_seconds:.0f} s, this run {time.perf_counter() - t0:.0f} s)")
