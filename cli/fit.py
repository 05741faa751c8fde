"""``weavecap fit``: photos in, fabrics out (the main job; DESIGN.md, Wu et al. 2025 §4–6)."""

from __future__ import annotations

import json
from pathlib import Path

import click

from .options import (FiniteFloat, check_batch_options, force_option, jobs_option, quiet_option, scheduler_option,
                      seed_option, verbose_option)

#: the share of a yarn family's cell centres the camera clipped (``fit.fidelity.clipped``) from
#: which the fit's line says so. Measured (draft): 0 on the own renders (their clipped gaps are
#: no yarn) and on the exposure check's satin 5 as shot, 16% a stop brighter (whose colours
#: moved by up to ΔE 6.5 against the as-shot's, docs/capture.md Session 21), 60% and 79% on the
#: independent twill 2/1 and random 4×4, 22% and 12% on the real W027 and W103
CLIPPED_NOTE = 0.05


def clipping_note(record: dict) -> str:
    """A line for the fit's summary when the camera clipped a yarn family's colour (at least
    :data:`CLIPPED_NOTE` of its cell centres): how bright it is, the photo does not show."""
    clipped = {k: v for k, v in record["fit"]["fidelity"].get("clipped", {}).items() if v is not None}
    worst = max(clipped, key=clipped.get, default=None)
    if worst is None or clipped[worst] < CLIPPED_NOTE:
        return ""
    return (f"\n  note: the camera clipped {clipped[worst]:.0%} of the {worst} yarns' centres: their colour is a lower "
            "bound; shoot a stop darker")


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
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON on standard output.")
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
    `weavecap synth`), report.json (what was found, how long each stage took), compare.png
    (photo | fit | error), rectified.png, grid.png (check the yarn grid by eye) and loss.png.

    A photo that is not a resolvable woven fabric gets a report.json saying why and no
    params.json. A batch goes on past bad photos, writes OUT/summary.jsonl one line per photo
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
    from weavecap import batch as wbatch
    from weavecap import params as wparams
    from weavecap.io import check_writable, folder_lock
    from weavecap.patterns import load_pattern
    from weavecap.pipeline import CaptureOptions, FitJob

    def say(message: str, level: int = 0, error: bool = False) -> None:
        if error or (not quiet and verbose >= level):
            click.echo(f"weavecap fit: {message}", err=True)

    def report(event: wbatch.Event) -> None:
        photo, record, where = event.item.source, event.record, f"[{event.index}/{event.total}]"
        if event.kind == "skipped":
            say(f"{photo}: already done ({record['status']}), skipped; --force redoes it")
        elif event.kind == "started":
            say(f"{where} {photo}: fitting ({quality})")
        elif record.get("status") == "ok":
            fit = record["fit"]
            rigs = len(record["timings_s"].get("captures", {})) or 1
            light = fit["light"]["rig"] + (f" light ({rigs} rigs tried)" if rigs > 1 else " light")
            say(f"{where} {photo}: {record['weave']}, {record['grid']['yarns'][0]}x{record['grid']['yarns'][1]} "
                f"repeat, PSNR {fit['psnr_db']:.1f} dB, sharpness {fit['fidelity']['sharpness']}, {light}, "
                f"{record['timings_s']['total']:.1f} s -> {event.item.folder}{clipping_note(record)}")
        else:
            say(f"{where} {photo}: {event.line['status']}: {record.get('reason')}", error=True)

    check_batch_options(jobs, scheduler)
    check_writable(out, folder=True)
    job = FitJob(CaptureOptions(quality=quality, light=light, seed=seed, budget_s=budget_s,
                                start_from=wparams.load(start_from) if start_from else None,
                                pattern=load_pattern(pattern_file) if pattern_file else None,
                                use_network=not no_network, exposure=exposure))
    with folder_lock(out):
        batch = wbatch.plan(job, photos, out, force=force)
        result = wbatch.run(batch, jobs=jobs, scheduler=scheduler, on_event=report)
    if as_json:
        click.echo(json.dumps(result.lines if batch.several else result.lines[0], indent=1))
    if result.exit:
        raise click.exceptions.Exit(result.exit)
