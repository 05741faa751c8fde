"""``weavecap fit``: photos in, fabrics out (the main job; docs/design.md, Wu et al. 2025 §4–6)."""

from __future__ import annotations

from pathlib import Path

import click

from .lines import fitted
from .options import (FiniteFloat, force_option, jobs_option, json_option, quiet_option, scheduler_option, seed_option,
                      verbose_option)
from .report import Reporter


@click.command(context_settings={"max_content_width": 100})
@click.argument("photos", nargs=-1, required=True, type=click.Path(readable=False, path_type=Path), metavar="PHOTO...")
@click.option("-o", "--output", "out", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Output folder (one photo: its files; several: one sub-folder each + summary.jsonl).")
@click.option("--quality", type=click.Choice(["draft", "normal", "high"]), default="normal", show_default=True,
              help="Speed against accuracy (docs/capture.md's fit bench).")
@click.option("--light", type=click.Choice(["auto", "best", "both", "front", "back", "lamp"]), default="auto",
              show_default=True,
              help="How the photo was lit: room light (front, back and sides), front-only, back-only, or one lamp "
                   "in front and the back light (no side lights); auto takes the one of room light and front-only "
                   "that explains the photo better before the fit and, at normal and high quality, captures the "
                   "photo again under the other rigs when the render comes out blurred or off-colour (sharpness "
                   "under 0.8 of the photo's, a yarn family beyond ΔE 10); best always does (three times as long); "
                   "either keeps the lowest loss of the faithful captures.")
@click.option("--budget", "budget_s", type=FiniteFloat(min=1), default=None,
              help="Stop each photo's fit after this many seconds (the best result so far is kept); a photo "
                   "captured under several rigs (--light) gets this for each.")
@jobs_option("Photos fitted")
@scheduler_option("photo")
@click.option("--start-from", "start_from", type=click.Path(dir_okay=False, readable=False, path_type=Path),
              help="Warm start: begin the fit at this params.json instead of the pre-estimate (on its repeat).")
@click.option("--pattern", "pattern_file", type=click.Path(dir_okay=False, readable=False, path_type=Path),
              help="A known weave pattern (params .json, .wif weaving draft, or a text file of 0/1 rows), kept fixed; "
                   "its repeat is used where the photo shows a shorter one.")
@click.option("--exposure", type=click.Choice(["rig", "photo"]), default="rig", show_default=True,
              help="Colours against the light rig (photos exposed like the rig), or against each photo's own "
                   "exposure: the same fabric shot darker or brighter gets the same colours (a catalogue shot "
                   "at varying exposure).")
@click.option("--no-network", is_flag=True, help="Start from Table 1 defaults instead of the initializer network.")
@json_option("the summary")
@seed_option
@force_option
@verbose_option
@quiet_option
def fit(photos, out, quality, light, budget_s, jobs, scheduler, start_from, pattern_file, exposure, no_network, as_json,
        seed, force, verbose, quiet):
    """Capture woven fabrics from close-up photos: pattern, yarn geometry and appearance.

    For each PHOTO: rectify and find the yarn grid (§4), pre-estimate pattern, colours and
    parameters (§5), fit them jointly by annealing and gradients through the renderer (§6),
    and estimate the irregularity noise (§6.3). Writes params.json (the fabric; render it with
    `weavecap synth`; a yarn-dyed fabric's colour per thread included), report.json (what was
    found, how long each stage took, how the fit looks against the photo), compare.png (the
    photo over several repeats | the fit over the same area | the difference, the median
    repeat beside them), rectified.png, grid.png (check the yarn grid by eye) and loss.png.

    A photo that is not a resolvable woven fabric gets a report.json saying why, a
    diagnosis.png (the photo as the grid search saw it, its spectrum, the projections along the
    yarns and the reason: what to reshoot) and no params.json. A batch goes on past bad photos, writes OUT/summary.jsonl one line per photo
    as each finishes, and exits with the worst status. Run it again to resume: finished photos
    are skipped (unless --force); results are never overwritten without --force. With
    --scheduler the photos are fitted on a Dask cluster (the same outputs and summary lines;
    photos and OUT on a file system every worker sees).

    \b
    Examples:
      weavecap fit swatch.jpg -o swatch/
      weavecap fit photos/*.jpg -o catalogue/ --jobs 2 --quality draft
      weavecap fit /shared/photos/*.jpg -o /shared/catalogue/ --scheduler tcp://head:8786
      weavecap fit swatch.dng -o swatch/ --light back --budget 30 --force
      weavecap fit swatch.jpg -o swatch-best/ --light best
      weavecap fit swatch.jpg -o refit/ --start-from swatch/params.json --pattern twill.txt
      weavecap fit shoot/*.jpg -o catalogue/ --exposure photo
    """
    from weavecap import params as wparams
    from weavecap.batch import run_folder
    from weavecap.patterns import load_pattern
    from weavecap.pipeline import CaptureOptions, FitJob

    tell = Reporter("fit", verbose, quiet)
    job = FitJob(CaptureOptions(quality=quality, light=light, seed=seed, budget_s=budget_s,
                                start_from=wparams.load(start_from) if start_from else None,
                                pattern=load_pattern(pattern_file) if pattern_file else None,
                                use_network=not no_network, exposure=exposure))
    with tell.stages():
        result = run_folder(job, photos, out, jobs=jobs, scheduler=scheduler, force=force, on_event=tell.batch(
            f"fitting ({quality})", lambda event, where: tell.say(f"{where} {event.item.source}: "
                                                                 f"{fitted(event.record, event.item.folder)}")))
    if as_json:
        tell.json(result.lines if len(photos) > 1 else result.lines[0])
    tell.exit(result.exit)
