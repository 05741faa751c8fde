"""``weavecap prepare``: rectify a weave photo and find its yarn grid (Wu et al. 2025 §4)."""

from __future__ import annotations

import json
import time
from pathlib import Path

import click

from .options import force_option, quiet_option, verbose_option

OUTPUTS = ("rectified.png", "regularized.png", "grid.png", "prepare.json")


@click.command()
@click.argument("photo", type=click.Path(readable=False, path_type=Path))
@click.option("-o", "--output", "out_dir", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Folder for rectified.png, regularized.png, grid.png and prepare.json (created if needed).")
@click.option("--pattern", "pattern_file", type=click.Path(dir_okay=False, readable=False, path_type=Path),
              help="A known weave pattern (params .json, .wif weaving draft, or a text file of 0/1 rows): its "
                   "repeat is used where the photo shows a shorter one, as `weavecap fit --pattern` does.")
@force_option
@verbose_option
@quiet_option
def prepare(photo: Path, out_dir: Path, pattern_file: Path | None, force: bool, verbose: int, quiet: bool) -> None:
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
      for f in photos/*.jpg; do weavecap prepare "$f" -o "out/$(basename "$f" .jpg)" -q; done
    """
    from weavecap.errors import InputError, PhotoError
    from weavecap.io import check_writable, folder_lock, not_an_input, refuse_overwrite, write_result_set
    from weavecap.patterns import load_pattern
    from weavecap.photo import load_photo, save_png
    from weavecap.prepare import PrepareConfig, Rejected, prepare_photo

    def say(message: str, level: int = 0) -> None:
        if not quiet and verbose >= level:
            click.echo(f"weavecap prepare: {message}", err=True)

    if not_an_input(photo, "photo"):
        raise InputError(not_an_input(photo, "photo") + " (nothing was written)")
    check_writable(out_dir, folder=True)
    click.get_current_context().with_resource(folder_lock(out_dir))  # held to the end of the command
    for name in OUTPUTS:
        refuse_overwrite(out_dir / name, force=force)

    repeat = None if pattern_file is None else load_pattern(pattern_file).shape
    t0 = time.perf_counter()
    say(f"reading {photo}")
    loaded = load_photo(photo)
    say(f"{loaded.width}×{loaded.height} {loaded.source_format}, {loaded.bit_depth}-bit", 1)
    result = prepare_photo(loaded.rgb, PrepareConfig(), repeat=repeat, progress=lambda stage: say(stage))
    if isinstance(result, Rejected):
        if verbose:
            click.echo(json.dumps(result.to_json()["checks"], indent=1), err=True)
        raise PhotoError(f"{photo}: rejected ({result.code}): {result.reason}; nothing was written")

    report = {
        "format": "weavecap.prepare/1",
        "input": {"path": str(photo), "sha256": loaded.sha256, "width": loaded.width, "height": loaded.height},
        **result.to_json(),
    }
    say("writing " + ", ".join(OUTPUTS))
    report["timings_s"]["with_io"] = round(time.perf_counter() - t0, 4)
    # one result set, prepare.json last: it is what says the set is complete
    write_result_set(out_dir, {"rectified.png": lambda path: save_png(path, result.rectification.image),
                               "regularized.png": lambda path: save_png(path, result.regularized.image),
                               "grid.png": lambda path: save_png(path, result.grid_overlay())},
                     record=("prepare.json", json.dumps(report, indent=1) + "\n"), outputs=OUTPUTS)
    g = result.grid
    say(f"turned {result.rectification.rotation_deg:+.2f}°, pitch {g.pitch_px[0]:.2f} × {g.pitch_px[1]:.2f} px, "
        f"repeat {g.yarns[0]} wefts × {g.yarns[1]} warps ({g.repeat_px[0]:.1f} × {g.repeat_px[1]:.1f} px), "
        f"{report['timings_s']['total']:.2f} s"
        + ("" if repeat is None else f"; the given pattern's repeat, the photo showing "
           f"{result.checks['repeat_in_photo'][0]} × {result.checks['repeat_in_photo'][1]}"))
