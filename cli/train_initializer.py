"""``weavecap train-initializer``: regenerate the initializer's training data and weights (§5.3)."""

from __future__ import annotations

import time
from pathlib import Path

import click

from .options import force_option, quiet_option, seed_option
from .report import Reporter


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
    from weavecap.training.initializer import TrainConfig, train_initializer as make_weights

    out_dir = out_dir or weights_dir()
    try:
        config = TrainConfig(seed=seed, geometries=geometries, per_geometry=per_geometry,
                             shard_geometries=shard_size, epochs=epochs)
    except ValueError as exc:
        raise InputError(f"--geometries/--shard-size: {exc}") from None
    tell = Reporter("train-initializer", quiet=quiet)
    t0 = time.perf_counter()
    record = make_weights(work, out_dir, config, force=force, progress=tell.say)
    tell.say(f"wrote {out_dir / WEIGHTS_FILE} and {out_dir / RECORD_FILE} (data {record['seconds']['data']:.0f} s, "
             f"training {record['seconds']['train']:.0f} s, this run {time.perf_counter() - t0:.0f} s)")
