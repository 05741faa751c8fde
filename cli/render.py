"""``weavecap render``: the captured fabric on a garment mesh (docs/render.md)."""

from __future__ import annotations

from functools import partial
from pathlib import Path

import click

from weavecap.render.modes import DEFAULT_MODE, MODE_HELP, SPP_HELP

from . import lines
from .options import (force_option, jobs_option, json_option, parse_offset, parse_size, pattern_option, quiet_option,
                      scheduler_option, seed_option, verbose_option)
from .report import Reporter

@click.command(context_settings={"max_content_width": 100})
@click.argument("inputs", nargs=-1, required=True, type=click.Path(readable=False, path_type=Path),
                metavar="PARAMS.json... MESH")
@click.option("-o", "--output", "out", required=True, type=click.Path(path_type=Path),
              help="Image to write (.png sRGB, .exr linear, .tif 16-bit) and, beside it, its record IMAGE.json; "
                   "with several PARAMS, a folder (OUT/<name>/render.png and render.json per params file, named "
                   "after it, and OUT/summary.jsonl).")
@click.option("--mode", default=DEFAULT_MODE, show_default=True, help=MODE_HELP)
@click.option("--spp", type=click.IntRange(1, 65536), default=None, help=SPP_HELP)
@click.option("--size", default="1280x720", show_default=True, callback=parse_size, help="Image size WxH in pixels.")
@click.option("--view", default="front", show_default=True,
              help="front (camera on +z looking at -z, y up), back, left, right, top, or AZ,EL in degrees.")
@click.option("--camera", type=click.Choice(["perspective", "orthographic"]), default="perspective",
              show_default=True, help="Camera model.")
@click.option("--fov", "fov_deg", type=float, default=35.0, show_default=True,
              help="Horizontal field of view of the perspective camera, degrees.")
@click.option("--margin", type=float, default=0.05, show_default=True,
              help="Space around the mesh's bounding box, as a fraction of it (0 frames the box exactly).")
@click.option("--light", default="studio", show_default=True,
              help="studio (key, fill, rim), sun (sun and sky), both|front|back|lamp (the capture rigs of synth and "
                   "fit), or an environment map (.exr, .hdr).")
@click.option("--ground", is_flag=True, help="Add a grey floor under the mesh.")
@click.option("--units", type=click.Choice(["m", "cm", "mm"]), default="m", show_default=True,
              help="Length unit of the mesh file.")
@click.option("--object", "object_name", help="Render the fabric on this object of a multi-object OBJ only.")
@click.option("--pitch-mm", "pitch_mm", type=float,
              help="Yarn pitch in mm (default: the params' scale.pitch_mm, else 0.3 mm with a warning).")
@click.option("--fabric-angle", "angle_deg", type=float, default=0.0, show_default=True,
              help="Turn the weave on the surface, degrees counter-clockwise.")
@click.option("--fabric-offset", "offset", default="0,0", show_default=True, callback=parse_offset,
              help="Shift the weave by U,V repeats.")
@click.option("--max-depth", type=click.IntRange(1, 1024), default=8, show_default=True,
              help="Longest path, in vertices (reference mode; 2 is direct lighting).")
@click.option("--fold", type=click.Choice(["auto", "on", "off"]), default="auto", show_default=True,
              help="The fold renderer's local inter-reflection term: where the mesh has folds and the mode "
                   "needs it (auto), always, or never.")
@click.option("--noise/--no-noise", default=True, show_default=True,
              help="Show the irregularity noise stored in the params (§6.3), if any.")
@click.option("--sheet", is_flag=True,
              help="With several PARAMS: also write OUT/sheet.png, the images finished so far side by side.")
@jobs_option("With several PARAMS: images rendered")
@scheduler_option("params file")
@json_option("the mesh and a summary line per image (what was rendered, how long)")
@pattern_option
@seed_option
@force_option
@verbose_option
@quiet_option
def render(inputs, out, units, object_name, sheet, jobs, scheduler, as_json, pattern_file, force, verbose, quiet,
           **settings):
    """Render captured fabrics (PARAMS.json from `weavecap fit`) on a garment MESH (OBJ or PLY).

    The fabric is tiled over the mesh's UVs at its physical size (the yarn pitch), as the
    surface model of its yarns: per-repeat maps baked from the capture's yarn geometry, shaded
    with its yarn scattering function, gaps letting light through. A mesh without UVs gets
    them (xatlas), and UVs that stretch are corrected so the weave keeps its size. The camera
    frames the mesh's bounding box. The same inputs, options and --seed give the same image,
    bit for bit.

    One PARAMS renders to the image -o names and its record beside it, IMAGE.json (what was
    rendered, how, and how long; dress.png.json for dress.png); an image that exists is kept
    unless --force. Several PARAMS are a batch, like `weavecap fit`'s: OUT/<name>/render.png
    and render.json for each, OUT/summary.jsonl one line per params file as each finishes,
    --jobs or --scheduler to render several at once. A bad params file does not stop the
    others; the batch exits with the worst status. Run it again to resume: finished renders
    are skipped (unless --force).

    \b
    Examples:
      weavecap render swatch/params.json dress.obj -o dress.png
      weavecap render swatch/params.json towel.obj -o towel.exr --view 30,20 --light sun --spp 256
      weavecap render a.json b.json c.json skirt.obj -o looks/ --sheet --pitch-mm 0.25
      weavecap render catalogue/*/params.json skirt.obj -o looks/ --jobs 2
      weavecap render swatch/params.json swatch.obj -o check.png --light both --camera orthographic --margin 0
      weavecap render fabric.json scan.ply -o scan.png --units mm --object Shirt --json
    """
    from weavecap.patterns import load_pattern
    from weavecap.render.job import render_files
    from weavecap.render.modes import mode as find_mode
    from weavecap.render.run import RenderOptions
    from weavecap.render.scene import parse_view

    if len(inputs) < 2:
        raise click.UsageError("give at least one PARAMS.json and a MESH")
    *params_files, mesh_file = inputs
    tell = Reporter("render", verbose, quiet)
    # the other options are RenderOptions' fields, under their names
    options = RenderOptions(**{**settings, "spp": settings["spp"] or find_mode(settings["mode"]).spp,
                               "view": parse_view(settings["view"])})

    done = render_files(
        params_files, mesh_file, out, options, pattern=load_pattern(pattern_file) if pattern_file else None,
        units=units, object_name=object_name, sheet=sheet, jobs=jobs, scheduler=scheduler, force=force,
        on_step=lambda step: tell.say(f"{mesh_file}: {step}"), on_mesh=lambda mesh: lines.tell_mesh(tell, mesh),
        on_event=tell.batch(f"rendering ({options.mode}, {options.spp or 'adaptive'} spp)",
                            partial(lines.tell_render, tell), started_level=1),
        progress=tell.counter(params_files[0].name, "samples per pixel"))
    if done.sheet:
        tell.say(f"wrote {out / 'sheet.png'} ({len(done.sheet)} of {len(params_files)} images)")
    if as_json:
        tell.json({"mesh": done.mesh, "images": done.lines, "sheet": str(out / "sheet.png") if done.sheet else None})
    tell.exit(done.exit)
