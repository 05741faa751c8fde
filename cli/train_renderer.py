"""``weavecap train-renderer``: regenerate the output renderers' training data and weights."""

from __future__ import annotations

import time
from pathlib import Path

import click

from .options import force_option, quiet_option, seed_option, verbose_option
from .report import Reporter


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
    from weavecap.training.renderers import FoldPlan, WovenPlan, train_renderers

    if not (do_woven or do_fold):
        raise click.UsageError("nothing to train: --no-woven and --no-fold leave no renderer")
    tell = Reporter("train-renderer", verbose, quiet)
    t0 = time.perf_counter()
    train_renderers(work, out_dir, woven=WovenPlan(fabrics, steps) if do_woven else None,
                    fold=FoldPlan(lights, per_light, epochs) if do_fold else None, seed=seed, force=force,
                    say=tell.say, progress=tell.progress)
    tell.say(f"done in {time.perf_counter() - t0:.0f} s")
