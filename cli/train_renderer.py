"""``weavecap train-renderer``: regenerate the output renderers' training data and weights."""

from __future__ import annotations

import json
import time
from pathlib import Path

import click

from .options import force_option, quiet_option, seed_option, verbose_option


def _woven(work: Path, out_dir: Path | None, fabrics: int, steps: int, seed: int, force: bool, say, progress) -> None:
    """The woven neural renderer's part (Chen et al. 2024): data, training, held-out errors."""
    from dataclasses import asdict

    from weavecap.errors import InputError
    from weavecap.io import refuse_overwrite
    from weavecap.render.woven import data as woven_data
    from weavecap.render.woven import train as woven_train
    from weavecap.render.woven.infer import WEIGHTS, weights_path

    out = (out_dir / WEIGHTS) if out_dir is not None else weights_path()
    for path in (out, out.with_suffix(".json")):
        refuse_overwrite(path, force=force)
    data_config = woven_data.DataConfig(fabrics=fabrics, seed=seed)
    train_config = woven_train.TrainConfig(steps=steps, seed=seed)
    folder = work / "woven"
    plan = {"data": asdict(data_config), "train": asdict(train_config)}
    plan_file = folder / "plan.json"
    if plan_file.is_file() and json.loads(plan_file.read_text()) != json.loads(json.dumps(plan)):
        raise InputError(f"{folder}: holds data or a checkpoint made with other settings ({plan_file}); use another "
                         "--work folder or delete that one")
    folder.mkdir(parents=True, exist_ok=True)
    plan_file.write_text(json.dumps(plan, indent=1) + "\n")
    say(f"woven: data for {fabrics} fabrics ({data_config.shards} shards) in {folder / 'data'}")
    summary = woven_data.generate(folder / "data", data_config, progress=lambda d, t, m: progress(m))
    # the time spent making the data, summed over the runs that made it (a resumed run adds its own)
    timing = folder / "data_seconds.json"
    runs = json.loads(timing.read_text())["runs"] if timing.exists() else []
    if summary["shards_made"] or not runs:
        runs.append({"seconds": summary["seconds"], "shards_made": summary["shards_made"]})
    else:
        runs[-1]["seconds"] += summary["seconds"]  # only the features/baseline pass was left
    data_seconds = float(sum(r["seconds"] for r in runs))
    timing.write_text(json.dumps({"seconds": data_seconds, "runs": runs}, indent=1) + "\n")
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


@click.command(context_settings={"max_content_width": 100})
@click.option("--work", "work", default="renderer-work", show_default=True,
              type=click.Path(file_okay=False, path_type=Path),
              help="Folder for the data shards and training checkpoints; an interrupted run resumes from "
                   "what is there (same settings only).")
@click.option("-o", "--output", "out_dir", default=None, type=click.Path(file_okay=False, path_type=Path),
              help="Folder for the weights and their JSON record  [default: the package's weights folder]")
@click.option("--woven/--no-woven", "do_woven", default=True, show_default=True,
              help="The woven neural renderer (Chen et al. 2024): footprint-filtered BSDF data and its network.")
@click.option("--fabrics", default=320, show_default=True, type=click.IntRange(2, 100000),
              help="Woven: random fabrics to make data of (both sides of each; every 16th is held out).")
@click.option("--steps", default=8000, show_default=True, type=click.IntRange(1, 10 ** 7),
              help="Woven: training steps (4 materials x 1024 queries each).")
@seed_option
@force_option
@verbose_option
@quiet_option
def train_renderer(work: Path, out_dir: Path | None, do_woven: bool, fabrics: int, steps: int, seed: int, force: bool,
                   verbose: int, quiet: bool) -> None:
    """Make the training data of the output renderers and train their networks.

    Woven: random fabrics (plain, twills, satins, baskets, ribs, random patterns up to 8x8,
    square or not; every parameter over Table 1's ranges) are baked to surface maps; for
    stratified light and view directions the surface BSDF is evaluated at every texel and
    every footprint (a fraction of a yarn to 5 repeats) is read from summed-area tables. The
    network is trained on them; the record beside the weights gives the data and training
    times and the errors on held-out fabrics. The same --seed gives the same data and weights.

    \b
    Examples:
      weavecap train-renderer                  # the shipped weights (about 65 min on 2 busy cores)
      weavecap train-renderer --work /tmp/r -o /tmp/weights --fabrics 4 --steps 20
    """
    import sys

    def say(message: str) -> None:
        if not quiet:
            click.echo(f"weavecap train-renderer: {message}", err=True)

    def progress(message: str) -> None:  # on a terminal, or with -v
        if not quiet and (sys.stderr.isatty() or verbose > 0):
            say(message)

    t0 = time.perf_counter()
    if do_woven:
        _woven(work, out_dir, fabrics, steps, seed, force, say, progress)
    say(f"done in {time.perf_counter() - t0:.0f} s")
