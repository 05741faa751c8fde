"""``weavecap export``: the fabric for other tools (DESIGN.md, "Commands")."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import click

from .options import FiniteFloat, force_option, pattern_option, quiet_option, seed_option, verbose_option


def _formats(ctx, param, value: str) -> tuple[str, ...]:
    from weavecap.export import FORMATS

    names = tuple(v.strip().lower() for v in value.split(",") if v.strip())
    bad = [n for n in names if n not in FORMATS]
    if bad or not names:
        raise click.BadParameter(f"{bad[0] if bad else value!r} is not a format; give a comma-separated list of "
                                 f"{', '.join(FORMATS)}")
    return names


@click.command(context_settings={"max_content_width": 100})
@click.argument("params_file", metavar="PARAMS.json", type=click.Path(readable=False, path_type=Path))
@click.option("-o", "--output", "out", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Folder to write into (created).")
@click.option("--format", "formats", default="wif,pbr,u3m,gltf,mitsuba", show_default=True, callback=_formats,
              help="What to write, comma-separated: wif, pbr, u3m, gltf, mitsuba.")
@click.option("--pitch-mm", type=FiniteFloat(0.001, 1000.0), default=None,
              help="Yarn spacing in millimetres [default: the params' scale.pitch_mm].")
@click.option("--texels-per-yarn", type=click.IntRange(4, 64), default=16, show_default=True,
              help="Map resolution across one yarn.")
@click.option("--repeats", type=click.IntRange(1, 16), default=1, show_default=True,
              help="Weave repeats per side of the map tile.")
@click.option("--bits", type=click.Choice(["8", "16"]), default="8", show_default=True,
              help="Bits per channel of the PNG maps (pbr, u3m).")
@click.option("--maps", "map_format", type=click.Choice(["png", "exr"]), default="png", show_default=True,
              help="File type of the pbr maps (EXR: linear float).")
@click.option("--normal-convention", type=click.Choice(["opengl", "directx"]), default="opengl", show_default=True,
              help="Green channel of the pbr normal map: opengl (Blender, glTF) or directx (Substance, Unreal).")
@click.option("--swatch-mm", type=FiniteFloat(1.0, 10000.0), default=100.0, show_default=True,
              help="Side of the glTF and Mitsuba swatches, millimetres (rounded to whole tiles).")
@seed_option
@click.option("--name", default=None, help="File name stem of the outputs, a plain name (no folders) [default: the "
                                           "params file's name, or its folder's for params.json].")
@pattern_option
@click.option("--json", "as_json", is_flag=True, help="Print the files written as JSON on standard output.")
@force_option
@verbose_option
@quiet_option
def export(params_file, out, formats, pitch_mm, texels_per_yarn, repeats, bits, map_format, normal_convention,
           swatch_mm, seed, name, pattern_file, as_json, force, verbose, quiet):
    """Write the fabric in PARAMS.json for other tools.

    \b
    wif      the weave as a WIF 1.1 draft for weaving software and looms (NAME.wif)
    pbr      PBR maps for Blender, Substance, Unreal, Unity: base colour, transmission,
             normal, roughness, opacity, height + their size in mm (pbr/)
    u3m      U3M 1.1 material for CLO 3D and Browzwear (u3m/NAME.u3m + textures/)
    gltf     a glTF 2.0 swatch with the material, for web viewers (NAME.glb)
    mitsuba  Mitsuba 3 scenes of a swatch: plain principled BSDF, and weavecap's own
             surface BSDF (mitsuba/)

    The maps are one seamless tile baked from the surface model of `weavecap render` and
    fitted to it (docs/export.md). Their physical size needs the yarn pitch: the params'
    scale.pitch_mm (written by `weavecap fit` when the photo's scale is known) or --pitch-mm.
    Nothing is overwritten without --force: every output is checked before anything is
    written.

    \b
    Examples:
      weavecap export swatch/params.json -o swatch/export
      weavecap export fabric.json -o out/ --format pbr --pitch-mm 0.3 --bits 16
      weavecap export fabric.json -o out/ --format pbr --maps exr --normal-convention directx
      weavecap export fabric.json -o out/ --format wif,u3m --pattern draft.wif --force
    """
    from datetime import datetime, timezone

    from weavecap import params as wparams
    from weavecap.export import MATERIAL_FORMATS, ExportOptions, default_name
    from weavecap.export import export as run_export
    from weavecap.io import check_writable, folder_lock, plain_name

    if name is not None:
        plain_name(name, what="--name")
    check_writable(out, folder=True)
    fabric = wparams.load(params_file)
    if pattern_file is not None:
        from weavecap.patterns import load_pattern

        fabric = fabric.replace({"pattern": load_pattern(pattern_file)})
    options = ExportOptions(
        formats=formats, name=name or default_name(params_file), force=force, pitch_mm=pitch_mm,
        texels_per_yarn=texels_per_yarn, repeats=repeats, bits=int(bits), map_format=map_format,
        normal_convention=normal_convention, swatch_mm=swatch_mm, seed=seed,
        created=datetime.fromtimestamp(params_file.stat().st_mtime, timezone.utc),
        source=wparams.dumps(fabric).encode())
    if not quiet and (verbose or sys.stderr.isatty()):
        work = " (baking the surface model and fitting the material)" if set(formats) & set(MATERIAL_FORMATS) else ""
        click.echo(f"weavecap export: {', '.join(formats)} of {params_file} into {out}{work}", err=True)
    with folder_lock(out):
        written = run_export(fabric, out, options)
    if as_json:
        click.echo(json.dumps({"files": [str(p) for p in written]}, indent=1))
    if not quiet:
        for path in written:
            if verbose or not as_json:
                click.echo(f"wrote {path}", err=True)
