"""``weavecap render``: the captured fabric on a garment mesh (DESIGN.md, the render contract)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import click

from .options import force_option, pattern_option, quiet_option, seed_option, verbose_option

IMAGE_SUFFIXES = (".png", ".exr", ".tif", ".tiff")


def _size(ctx, param, value: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in value.lower().split("x"))
    except ValueError:
        raise click.BadParameter(f"{value!r} is not of the form WxH, e.g. 1280x720") from None
    if not (1 <= w <= 16384 and 1 <= h <= 16384):
        raise click.BadParameter(f"{value!r}: width and height must be in [1, 16384]")
    return w, h


def _offset(ctx, param, value: str) -> tuple[float, float]:
    try:
        u, v = (float(x) for x in value.split(","))
    except ValueError:
        raise click.BadParameter(f"{value!r} is not of the form U,V (in repeats), e.g. 0.5,0") from None
    return u, v


def _mode_help() -> str:
    return ("neural: the woven neural BSDF at each pixel's footprint, direct light, 1 spp by default "
            "(Chen et al. 2024); reference: path tracing of the surface model; direct: direct lighting only "
            "(one bounce).")


@click.command(context_settings={"max_content_width": 100})
@click.argument("inputs", nargs=-1, required=True, type=click.Path(dir_okay=False, path_type=Path),
                metavar="PARAMS.json... MESH")
@click.option("-o", "--output", "out", required=True, type=click.Path(path_type=Path),
              help="Image to write (.png sRGB, .exr linear, .tif 16-bit); with several PARAMS, a folder "
                   "(one PNG per params file, named after it).")
@click.option("--mode", default="neural", show_default=True, help=_mode_help())
@click.option("--spp", type=click.IntRange(1, 65536), default=None,
              help="Samples per pixel  [default: 1 for neural (pixel centres), 64 for the others]")
@click.option("--size", default="1280x720", show_default=True, callback=_size, help="Image size WxH in pixels.")
@click.option("--view", default="front", show_default=True,
              help="front (camera on +z looking at -z, y up), back, left, right, top, or AZ,EL in degrees.")
@click.option("--camera", type=click.Choice(["perspective", "orthographic"]), default="perspective",
              show_default=True, help="Camera model.")
@click.option("--fov", "fov_deg", type=float, default=35.0, show_default=True,
              help="Horizontal field of view of the perspective camera, degrees.")
@click.option("--margin", type=float, default=0.05, show_default=True,
              help="Space around the mesh's bounding box, as a fraction of it (0 frames the box exactly).")
@click.option("--light", default="studio", show_default=True,
              help="studio (key, fill, rim), sun (sun and sky), both|front|back (the capture rigs of synth and "
                   "fit), or an environment map (.exr, .hdr).")
@click.option("--ground", is_flag=True, help="Add a grey floor under the mesh.")
@click.option("--units", type=click.Choice(["m", "cm", "mm"]), default="m", show_default=True,
              help="Length unit of the mesh file.")
@click.option("--object", "object_name", help="Render the fabric on this object of a multi-object OBJ only.")
@click.option("--pitch-mm", "pitch_mm", type=float,
              help="Yarn pitch in mm (default: the params' scale.pitch_mm, else 0.3 mm with a warning).")
@click.option("--fabric-angle", "angle_deg", type=float, default=0.0, show_default=True,
              help="Turn the weave on the surface, degrees counter-clockwise.")
@click.option("--fabric-offset", "offset", default="0,0", show_default=True, callback=_offset,
              help="Shift the weave by U,V repeats.")
@click.option("--max-depth", type=click.IntRange(1, 1024), default=8, show_default=True,
              help="Longest path, in vertices (reference mode; 2 is direct lighting).")
@click.option("--fold", type=click.Choice(["auto", "on", "off"]), default="auto", show_default=True,
              help="The fold renderer's local inter-reflection term: where the mesh has folds and the mode "
                   "needs it (auto), always, or never.")
@click.option("--noise/--no-noise", default=True, show_default=True,
              help="Show the irregularity noise stored in the params (§6.3), if any.")
@click.option("--sheet", is_flag=True, help="With several PARAMS: also write OUT/sheet.png, all images side by side.")
@click.option("--json", "as_json", is_flag=True, help="Print what was rendered and the timings as JSON.")
@pattern_option
@seed_option
@force_option
@verbose_option
@quiet_option
def render(inputs, out, mode, spp, size, view, camera, fov_deg, margin, light, ground, units, object_name,
           pitch_mm, angle_deg, offset, max_depth, fold, noise, sheet, as_json, pattern_file, seed, force, verbose,
           quiet):
    """Render captured fabrics (PARAMS.json from `weavecap fit`) on a garment MESH (OBJ or PLY).

    The fabric is tiled over the mesh's UVs at its physical size (the yarn pitch), as the
    surface model of its yarns: per-repeat maps baked from the capture's yarn geometry, shaded
    with its yarn scattering function, gaps letting light through. A mesh without UVs gets
    them (xatlas), and UVs that stretch are corrected so the weave keeps its size. The camera
    frames the mesh's bounding box. The same inputs, options and --seed give the same image,
    bit for bit.

    \b
    Examples:
      weavecap render swatch/params.json dress.obj -o dress.png
      weavecap render swatch/params.json towel.obj -o towel.exr --view 30,20 --light sun --spp 256
      weavecap render a.json b.json c.json skirt.obj -o looks/ --sheet --pitch-mm 0.25
      weavecap render swatch/params.json swatch.obj -o check.png --light both --camera orthographic --margin 0
      weavecap render fabric.json scan.ply -o scan.png --units mm --object Shirt --json
    """
    from weavecap import params as wparams
    from weavecap.errors import InputError
    from weavecap.io import refuse_overwrite
    from weavecap.photo import save_image, supported_output

    if len(inputs) < 2:
        raise click.UsageError("give at least one PARAMS.json and a MESH")
    *params_files, mesh_file = inputs
    many = len(params_files) > 1
    if many:
        if out.suffix.lower() in IMAGE_SUFFIXES or out.is_file():
            raise InputError(f"{out}: with several PARAMS files, -o names a folder (one image each)")
        targets = _targets(params_files, out)
    else:
        supported_output(out)
        targets = [out]
    if sheet and not many:
        raise InputError("--sheet needs several PARAMS files")
    for target in targets + ([out / "sheet.png"] if sheet else []):
        refuse_overwrite(target, force=force)
    fabrics = [wparams.load(p) for p in params_files]  # every input checked before any work
    if pattern_file is not None:
        from weavecap.patterns import load_pattern

        pattern = load_pattern(pattern_file)
        fabrics = [f.replace({"pattern": pattern}) for f in fabrics]

    from weavecap.render.mesh import load_mesh
    from weavecap.render.run import RenderOptions, render_fabric
    from weavecap.render.scene import parse_view

    from weavecap.render.modes import mode as find_mode

    spp = spp or find_mode(mode).spp
    options = RenderOptions(mode=mode, spp=spp, size=size, view=parse_view(view), camera=camera, fov_deg=fov_deg,
                            margin=margin, light=light, pitch_mm=pitch_mm, angle_deg=angle_deg, offset=offset,
                            max_depth=max_depth, seed=seed, ground=ground, noise=noise, fold=fold)
    show_progress = not quiet and (sys.stderr.isatty() or verbose > 0)

    def say(message: str, level: int = 0) -> None:
        if not quiet and verbose >= level:
            click.echo(f"weavecap render: {message}", err=True)

    mesh = load_mesh(mesh_file, units=units, object_name=object_name)
    say(f"{mesh_file}: {len(mesh.faces)} triangles, {', '.join(mesh.objects)}, UVs from the {mesh.uv_source}, "
        f"stretch {mesh.stretch['before']:.3f} -> {mesh.stretch['after']:.3f}", level=1)
    for note in mesh.notes:
        say(f"{mesh_file}: {note}")
    rendered, images = [], []
    for index, (params_file, fabric, target) in enumerate(zip(params_files, fabrics, targets), 1):
        where = f"[{index}/{len(targets)}] " if many else ""

        def progress(done, total, where=where, name=params_file.name):
            if show_progress:
                end = "\n" if done == total else ""
                click.echo(f"\rweavecap render: {where}{name}: {done}/{total} samples per pixel", err=True, nl=False)
                if end:
                    click.echo("", err=True)

        result = render_fabric(fabric, mesh, options, progress=progress)
        save_image(target, result.image)
        images.append(result.image)
        for note in result.info["notes"]:
            say(f"{params_file}: {note}")
        t = result.info["timings"]
        say(f"{where}wrote {target} ({size[0]}x{size[1]}, {mode}, {spp} spp, pitch {result.info['pitch_mm']:g} mm, "
            f"{t['total']:.1f} s: bake {t['bake']:.1f} s, render {t['render']:.1f} s)")
        rendered.append({"params": str(params_file), "output": str(target), **result.info})
    if sheet:
        from weavecap.io import atomic_path
        from weavecap.render.sheet import contact_sheet

        with atomic_path(out / "sheet.png") as tmp:
            contact_sheet(images, [p.stem if p.stem != "params" else p.resolve().parent.name
                                   for p in params_files]).save(tmp, format="PNG")
        say(f"wrote {out / 'sheet.png'}")
    if as_json:
        mesh_info = {"path": str(mesh_file), "triangles": int(len(mesh.faces)), "objects": mesh.objects,
                     "uv_source": mesh.uv_source, "stretch": mesh.stretch, "area_m2": mesh.area,
                     "bounds_m": mesh.bounds.tolist(), "notes": mesh.notes}
        click.echo(json.dumps({"mesh": mesh_info, "images": rendered,
                               "sheet": str(out / "sheet.png") if sheet else None}, indent=1))


def _targets(params_files: list[Path], out: Path) -> list[Path]:
    """One PNG per params file in ``out``: named after the file, or after its folder when the
    stems repeat (``a/params.json``, ``b/params.json`` → ``a.png``, ``b.png``)."""
    stems = [p.stem for p in params_files]
    if len(set(stems)) < len(stems):
        stems = [p.resolve().parent.name + ("" if p.stem == "params" else f"_{p.stem}") for p in params_files]
    if len(set(stems)) < len(stems):
        stems = [f"{i:03d}_{s}" for i, s in enumerate(stems, 1)]
    return [out / f"{s}.png" for s in stems]
