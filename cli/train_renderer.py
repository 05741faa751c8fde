"""``weavecap train-renderer``: regenerate the output renderers' training data and weights."""

from __future__ import annotations

import time
from pathlib import Path

import click

from .options import claim_work_folder, force_option, quiet_option, seed_option, verbose_option


def _woven_targets(out_dir: Path | None) -> list[Path]:
    """The woven renderer's weights and their record."""
    from weavecap.render.woven.infer import WEIGHTS, weights_path

    out = (out_dir / WEIGHTS) if out_dir is not None else weights_path()
    return [out, out.with_suffix(".json")]


def _woven(work: Path, out: Path, fabrics: int, steps: int, seed: int, say, progress) -> None:
    """The woven neural renderer's part (Chen et al. 2024): data, training, held-out errors."""
    from dataclasses import asdict

    from weavecap.training import woven as woven_train

    data_config = woven_train.DataConfig(fabrics=fabrics, seed=seed)
    train_config = woven_train.TrainConfig(steps=steps, seed=seed)
    folder = work / "woven"
    claim_work_folder(folder, {"data": asdict(data_config), "train": asdict(train_config)}, name="plan.json")
    say(f"woven: data for {fabrics} fabrics ({data_config.shards} shards) in {folder / 'data'}")
    # the time spent making the data, over every run that made some of it (each shard keeps its own)
    data_seconds = woven_train.generate(folder / "data", data_config, progress=lambda m: progress(f"woven: {m}"))
    dataset = woven_train.Dataset(folder / "data", data_config)
    say(f"woven: training {steps} steps on {len(dataset.inputs)} queries of {len(dataset.train_materials)} "
        f"materials ({len(dataset.held_materials)} held out)")
    model, train_summary = woven_train.train(dataset, folder / "train", train_config,
                                             log=lambda m: progress(f"woven: {m}"))
    held = woven_train.evaluate(model, dataset, dataset.held_materials)
    seen = woven_train.evaluate(model, dataset, dataset.train_materials[:len(dataset.held_materials)])
    baseline = woven_train.evaluate(None, dataset, dataset.held_materials, baseline_only=True)
    record = woven_train.record(data_config, train_config, data_seconds=data_seconds, train_summary=train_summary,
                                held_out=held, seen=seen, dataset=dataset)
    record["held_out_errors_prefilter_only"] = baseline
    woven_train.export(model, out, record)
    say(f"woven: wrote {out} ({out.stat().st_size / 1e6:.2f} MB) and its record; held-out RGB error: relative MSE "
        f"{held['all']['rel_mse']:.4f}, relative MAE {held['all']['rel_mae']:.3f} "
        f"(data {data_seconds:.0f} s, training {train_summary['seconds']:.0f} s)")


def _fold_targets(out_dir: Path | None) -> list[Path]:
    """The fold renderer's weights (their record inside)."""
    from weavecap.render.fold import blidf

    return [(out_dir / blidf.WEIGHTS_FILE) if out_dir is not None else blidf.weights_path()]


def _fold(work: Path, out: Path, lights: int, per_light: int, epochs: int, seed: int, say, progress) -> None:
    """The fold renderer's part (Son et al.): LocalPT data on the fold suite, the BLIDF, held-out errors."""
    from weavecap.training import fold as training

    # blocks of 8 lights (at most half of them, so that one block is held out and one trained on)
    config = training.TrainConfig(seed=seed, lights=lights, per_light=per_light, epochs=epochs,
                                  block=min(8, lights // 2))
    folder = work / "fold"
    claim_work_folder(folder, config.data_settings())
    meshes = training.fold_suite()
    say(f"fold: LocalPT data of {len(meshes)} meshes x {lights} lights x {per_light} vertices in {folder / 'data'}")
    data_seconds = training.generate_data(folder, meshes, config, progress=lambda m: progress(f"fold: {m}"))
    net, train_seconds, errors = training.train(folder, meshes, config, progress=lambda m: progress(f"fold: {m}"))
    training.write_weights(out, net, meshes, config, data_seconds=data_seconds, train_seconds=train_seconds,
                           errors=errors, radii=training.mesh_radii(folder, meshes, config))
    say(f"fold: wrote {out}; held-out RMSE {errors['heldout']['rmse']:.6f}, without the fold term "
        f"{errors['heldout']['rmse_without']:.6f} (data {data_seconds:.0f} s, training {train_seconds:.0f} s)")


@click.command(context_settings={"max_content_width": 100})
@click.option("--work", "work", default="renderer-work", show_default=True,
              type=click.Path(file_okay=False, path_type=Path),
              help="Folder for the data shards and training checkpoints (WORK/woven, WORK/fold); an interrupted "
                   "run resumes from what is there (same settings only).")
@click.option("-o", "--output", "out_dir", default=None, type=click.Path(file_okay=False, path_type=Path),
              help="Folder for the weights and their records  [default: the package's weights folders]")
@click.option("--woven/--no-woven", "do_woven", default=True, show_default=True,
              help="The woven neural renderer (Chen et al. 2024): footprint-filtered BSDF data and its network.")
@click.option("--fold/--no-fold", "do_fold", default=True, show_default=True,
              help="The fold renderer (Son et al.): LocalPT on the procedural fold suite and the BLIDF.")
@click.option("--fabrics", default=320, show_default=True, type=click.IntRange(2, 100000),
              help="Woven: random fabrics to make data of (both sides of each; every 16th is held out).")
@click.option("--steps", default=8000, show_default=True, type=click.IntRange(1, 10 ** 7),
              help="Woven: training steps (4 materials x 1024 queries each).")
@click.option("--lights", default=48, show_default=True, type=click.IntRange(2, 10000),
              help="Fold: directional lights per mesh (the fabrics in turn); the last block of 8 is held out.")
@click.option("--per-light", default=300, show_default=True, type=click.IntRange(1, 100000),
              help="Fold: vertices (both sides each) per light.")
@click.option("--epochs", default=160, show_default=True, type=click.IntRange(1, 10000),
              help="Fold: training epochs.")
@seed_option
@force_option
@verbose_option
@quiet_option
def train_renderer(work: Path, out_dir: Path | None, do_woven: bool, do_fold: bool, fabrics: int, steps: int,
                   lights: int, per_light: int, epochs: int, seed: int, force: bool, verbose: int, quiet: bool) -> None:
    """Make the training data of the output renderers and train their networks.

    Woven: random fabrics (plain, twills, satins, baskets, ribs, random patterns up to 8x8,
    square or not; every parameter over Table 1's ranges) are baked to surface maps; for
    stratified light and view directions the surface BSDF is evaluated at every texel and
    every footprint (a fraction of a yarn to 5 repeats) is read from summed-area tables. The
    network is trained on them; the record beside the weights gives the data and training
    times and the errors on held-out fabrics.

    Fold: for every mesh of the fold suite (weavecap/render/shapes.py: sines of three
    amplitudes and a finer one, waves, horseshoes wide and narrow, a skirt, a drape), LocalPT
    renders the local inter-reflection at vertices under directional lights from all around,
    in the surface model of four fixture fabrics (plain, twill_2_1, satin_5, custom_4x6); the
    BLIDF (1.5K parameters) is fitted to it; its record gives the settings, the data and
    training times and the errors on held-out lights.

    The same --seed gives the same data and weights.

    \b
    Examples:
      weavecap train-renderer                  # both shipped networks (woven about 65 min, fold 11)
      weavecap train-renderer --no-woven       # the fold renderer's BLIDF alone
      weavecap train-renderer --work /tmp/r -o /tmp/weights --no-fold --fabrics 4 --steps 20
      weavecap train-renderer --work /tmp/r -o /tmp/weights --no-woven --lights 4 --per-light 20 --epochs 2
    """
    import sys

    if not (do_woven or do_fold):
        raise click.UsageError("nothing to train: --no-woven and --no-fold leave no renderer")

    def say(message: str) -> None:
        if not quiet:
            click.echo(f"weavecap train-renderer: {message}", err=True)

    def progress(message: str) -> None:  # on a terminal, or with -v
        if not quiet and (sys.stderr.isatty() or verbose > 0):
            say(message)

    from weavecap.io import refuse_overwrite

    woven_out = _woven_targets(out_dir) if do_woven else []
    fold_out = _fold_targets(out_dir) if do_fold else []
    for path in woven_out + fold_out:  # before any work: nothing is overwritten without --force
        refuse_overwrite(path, force=force)
    t0 = time.perf_counter()
    if do_woven:
        _woven(work, woven_out[0], fabrics, steps, seed, say, progress)
    if do_fold:
        _fold(work, fold_out[0], lights, per_light, epochs, seed, say, progress)
    say(f"done in {time.perf_counter() - t0:.0f} s")
