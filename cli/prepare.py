"""``weavecap prepare``: rectify a weave photo and find its yarn grid (Wu et al. 2025 §4)."""

from __future__ import annotations

import json
from pathlib import Path

import click

from .options import force_option, json_option, quiet_option, verbose_option
from .report import Reporter


@click.command()
@click.argument("photo", type=click.Path(readable=False, path_type=Path))
@click.option("-o", "--output", "out_dir", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Folder for rectified.png, regularized.png, grid.png and prepare.json (created if needed).")
@click.option("--pattern", "pattern_file", type=click.Path(dir_okay=False, readable=False, path_type=Path),
              help="A known weave pattern (params .json, .wif weaving draft, or a text file of 0/1 rows): its "
                   "repeat is used where the photo shows a shorter one, as `weavecap fit --pattern` does.")
@json_option("prepare.json (or, for a rejected photo, why)")
@force_option
@verbose_option
@quiet_option
def prepare(photo: Path, out_dir: Path, pattern_file: Path | None, as_json: bool, force: bool, verbose: int,
            quiet: bool) -> None:
    """Rectify PHOTO, regularize it, and find its yarn grid and minimum repeat.

    Writes into the output folder: rectified.png (the photo turned so that warps run
    vertically, perspective undone), regularized.png (whole repeats, denoised by kernel PCA),
    grid.png (the yarn boundaries over the rectified photo, one repeat outlined in magenta:
    check it by eye) and prepare.json (rotation, homography input→rectified pixels, pitch,
    repeat and yarn counts; the "rectification" and "grid" parts of report.json).

    rotation_deg is the counter-clockwise turn (as seen on screen) that makes the warps run
    vertically: a fabric turned counter-clockwise by 10° in the photo gives -10.

    A photo that is not a resolvable woven fabric (uniform, noise, knitted, felt, yarns under
    3 px, no periodic grid) is rejected: the reason is printed, nothing is written, and the
    exit status is 3.

    \b
    Examples:
      weavecap prepare swatch.jpg -o prepared/
      weavecap prepare swatch.dng -o prepared/ --force -v
      weavecap prepare swatch.jpg -o prepared/ --pattern draft.wif
      weavecap prepare swatch.jpg -o prepared/ --json -q > prepared.json
      for f in photos/*.jpg; do weavecap prepare "$f" -o "out/$(basename "$f" .jpg)" -q; done
    """
    from weavecap.errors import PhotoError
    from weavecap.patterns import load_pattern
    from weavecap.prepare.outputs import prepare_into

    tell = Reporter("prepare", verbose, quiet)
    repeat = None if pattern_file is None else load_pattern(pattern_file).shape
    record = prepare_into(photo, out_dir, repeat=repeat, force=force, say=tell.say)
    if as_json:
        tell.json(record)
    if record["status"] == "rejected":
        if verbose:
            click.echo(json.dumps(record["checks"], indent=1), err=True)
        raise PhotoError(f"{photo}: rejected ({record['code']}): {record['reason']}; "
                         f"what the grid search saw: {out_dir / 'diagnosis.png'}")
    rect, g = record["rectification"], record["grid"]
    tell.say(f"turned {rect['rotation_deg']:+.2f}°, pitch {g['pitch_px'][0]:.2f} × {g['pitch_px'][1]:.2f} px, "
             f"repeat {g['yarns'][0]} wefts × {g['yarns'][1]} warps "
             f"({g['repeat_px'][0]:.1f} × {g['repeat_px'][1]:.1f} px), {record['timings_s']['total']:.2f} s"
             + ("" if repeat is None else f"; the given pattern's repeat, the photo showing "
                f"{record['checks']['repeat_in_photo'][0]} × {record['checks']['repeat_in_photo'][1]}"))
