"""``weavecap export``: the fabric for other tools (WIF drafts; DESIGN.md, "Commands")."""

from __future__ import annotations

import json
from pathlib import Path

import click

from .options import force_option, pattern_option, quiet_option, verbose_option


def _formats(ctx, param, value: str) -> tuple[str, ...]:
    from weavecap.export import FORMATS

    names = tuple(v.strip().lower() for v in value.split(",") if v.strip())
    bad = [n for n in names if n not in FORMATS]
    if bad or not names:
        raise click.BadParameter(f"{bad[0] if bad else value!r} is not a format; give a comma-separated list of "
                                 f"{', '.join(FORMATS)}")
    return names


@click.command(context_settings={"max_content_width": 100})
@click.argument("params_file", metavar="PARAMS.json", type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", "out", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Folder to write into (created).")
@click.option("--format", "formats", default="wif", show_default=True, callback=_formats,
              help="What to write, comma-separated: wif (the weave as a weaving draft).")
@click.option("--name", default=None, help="File name stem of the outputs [default: the params file's name, or "
                                           "its folder's for params.json].")
@pattern_option
@click.option("--json", "as_json", is_flag=True, help="Print the files written as JSON on standard output.")
@force_option
@verbose_option
@quiet_option
def export(params_file, out, formats, name, pattern_file, as_json, force, verbose, quiet):
    """Write the fabric in PARAMS.json for other tools.

    wif: the weave as a WIF 1.1 draft for weaving software (Fiberworks, WeaveIt, AdaCAD,
    ThunderLoom) and loom controllers: the liftplan, and threading + tie-up + treadling when the
    weave needs at most 16 shafts and treadles; warp and weft colours; thread spacing when the
    params know the yarn pitch (scale.pitch_mm).

    Nothing is overwritten without --force: every output is checked before anything is written.

    \b
    Examples:
      weavecap export swatch/params.json -o swatch/export
      weavecap export fabric.json -o out/ --format wif --name twill --force
      weavecap export fabric.json -o out/ --pattern draft.wif
    """
    from weavecap import params as wparams
    from weavecap.export import ExportOptions, default_name
    from weavecap.export import export as run_export

    fabric = wparams.load(params_file)
    if pattern_file is not None:
        from weavecap.patterns import load_pattern

        fabric = fabric.replace({"pattern": load_pattern(pattern_file)})
    written = run_export(fabric, out, ExportOptions(formats=formats, name=name or default_name(params_file),
                                                    force=force))
    if as_json:
        click.echo(json.dumps({"files": [str(p) for p in written]}, indent=1))
    if not quiet:
        for path in written:
            if verbose or not as_json:
                click.echo(f"wrote {path}", err=True)
