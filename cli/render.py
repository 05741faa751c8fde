"""``weavecap render``: the captured fabric on a garment mesh (DESIGN.md, the render contract)."""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import click

from .options import (check_batch_options, force_option, jobs_option, pattern_option, quiet_option, scheduler_option,
                      seed_option, verbose_option)

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
@click.argument("inputs", nargs=-1, required=True, type=click.Path(readable=False, path_type=Path),
                metavar="PARAMS.json... MESH")
@click.option("-o", "--output", "out", required=True, type=click.Path(path_type=Path),
              help="Image to write (.png sRGB, .exr linear, .tif 16-bit); with several PARAMS, a folder "
                   "(OUT/<name>/render.png per params file, named after it, and OUT/summary.jsonl).")
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
@click.option("--fabric-offset", "offset", default="0,0", show_default=True, callback=_offset,
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
@click.option("--json", "as_json", is_flag=True, help="Print what was rendered and the timings as JSON.")
@pattern_option
@seed_option
@force_option
@verbose_option
@quiet_option
def render(inputs, out, mode, spp, size, view, camera, fov_deg, margin, light, ground, units, object_name,
           pitch_mm, angle_deg, offset, max_depth, fold, noise, sheet, jobs, scheduler, as_json, pattern_file, seed,
           force, verbose, quiet):
    """Render captured fabrics (PARAMS.json from `weavecap fit`) on a garment MESH (OBJ or PLY).

    The fabric is tiled over the mesh's UVs at its physical size (the yarn pitch), as the
    surface model of its yarns: per-repeat maps baked from the capture's yarn geometry, shaded
    with its yarn scattering function, gaps letting light through. A mesh without UVs gets
    them (xatlas), and UVs that stretch are corrected so the weave keeps its size. The camera
    frames the mesh's bounding box. The same inputs, options and --seed give the same image,
    bit for bit.

    Several PARAMS are a batch, like `weavecap fit`'s: OUT/<name>/render.png and render.json
    for each, OUT/summary.jsonl one line per params file as each finishes, --jobs or --scheduler
    to render several at once. A bad params file does not stop the others; the batch exits with
    the worst status. Run it again to resume: finished renders are skipped (unless --force).

    \b
    Examples:
      weavecap render swatch/params.json dress.obj -o dress.png
      weavecap render swatch/params.json towel.obj -o towel.exr --view 30,20 --light sun --spp 256
      weavecap render a.json b.json c.json skirt.obj -o looks/ --sheet --pitch-mm 0.25
      weavecap render catalogue/*/params.json skirt.obj -o looks/ --jobs 2
      weavecap render swatch/params.json swatch.obj -o check.png --light both --camera orthographic --margin 0
      weavecap render fabric.json scan.ply -o scan.png --units mm --object Shirt --json
    """
    from weavecap.errors import InputError
    from weavecap.io import check_writable, folder_lock, refuse_overwrite
    from weavecap.photo import supported_output

    if len(inputs) < 2:
        raise click.UsageError("give at least one PARAMS.json and a MESH")
    *params_files, mesh_file = inputs
    many = len(params_files) > 1
    if many:
        if out.suffix.lower() in IMAGE_SUFFIXES or out.is_file():
            raise InputError(f"{out}: with several PARAMS files, -o names a folder (one image each)")
        check_batch_options(jobs, scheduler)
        check_writable(out, folder=True)
        click.get_current_context().with_resource(folder_lock(out))  # before the mesh: held to the end
    else:
        for name, given in (("--sheet", sheet), ("--jobs", jobs > 1), ("--scheduler", scheduler)):
            if given:
                raise InputError(f"{name} needs several PARAMS files")
        supported_output(out)
        check_writable(out, folder=False)
        refuse_overwrite(out, force=force)

    from weavecap.render.job import load_fabric
    from weavecap.render.modes import mode as find_mode
    from weavecap.render.run import RenderOptions
    from weavecap.render.scene import parse_view

    pattern = None
    if pattern_file is not None:
        from weavecap.patterns import load_pattern

        pattern = load_pattern(pattern_file)
    fabric = None if many else load_fabric(params_files[0], pattern)  # checked before any work
    spp = spp or find_mode(mode).spp
    options = RenderOptions(mode=mode, spp=spp, size=size, view=parse_view(view), camera=camera, fov_deg=fov_deg,
                            margin=margin, light=light, pitch_mm=pitch_mm, angle_deg=angle_deg, offset=offset,
                            max_depth=max_depth, seed=seed, ground=ground, noise=noise, fold=fold)

    def say(message: str, level: int = 0, error: bool = False) -> None:
        if error or (not quiet and verbose >= level):
            click.echo(f"weavecap render: {message}", err=True)

    from weavecap.render.mesh import load_mesh

    t0 = time.perf_counter()
    mesh = load_mesh(mesh_file, units=units, object_name=object_name,
                     progress=lambda step: say(f"{mesh_file}: {step}"))
    mesh_s = time.perf_counter() - t0
    say(f"{mesh_file}: {len(mesh.faces)} triangles, {', '.join(mesh.objects)}, UVs from the {mesh.uv_source}, "
        f"stretch {mesh.stretch['before']:.3f} -> {mesh.stretch['after']:.3f}, read in {mesh_s:.1f} s", level=1)
    for note in mesh.notes:
        say(f"{mesh_file}: {note}")
    mesh_info = {"path": str(mesh_file), "triangles": int(len(mesh.faces)), "objects": mesh.objects,
                 "uv_source": mesh.uv_source, "stretch": mesh.stretch, "area_m2": mesh.area,
                 "bounds_m": mesh.bounds.tolist(), "notes": mesh.notes, "seconds": round(mesh_s, 3)}
    if many:
        doc, status = _render_batch(params_files, mesh, options, pattern, out, sheet=sheet, jobs=jobs,
                                    scheduler=scheduler, force=force, say=say)
    else:
        doc, status = _render_one(params_files[0], fabric, mesh, options, out, mesh_s=mesh_s, force=force,
                                  progress=not quiet and (sys.stderr.isatty() or verbose > 0), say=say)
    if as_json:
        click.echo(json.dumps({"mesh": mesh_info, **doc}, indent=1))
    if status:
        raise click.exceptions.Exit(status)


def _wrote(output, info: dict, timings: dict) -> str:
    """The line that says an image was written: what, how and how long (with the mesh's
    reading, where the image is the command's only one)."""
    w, h = info["size"]
    mesh = f"mesh {timings['mesh']:.1f} s, " if "mesh" in timings else ""
    return (f"wrote {output} ({w}x{h}, {info['mode']}, {info['spp']} spp, pitch {info['pitch_mm']:g} mm, "
            f"{timings['total']:.1f} s: {mesh}bake {timings['bake']:.1f} s, render {timings['render']:.1f} s)")


def _fold_summary(detail: dict) -> str:
    """One line of what the fold term modelled (for -v)."""
    vertices = detail["vertices"]
    return (f"r = {detail['radius_m'] * 1000:.1f} mm, computed at {vertices['computed']} of {vertices['of']} vertices "
            f"(valleys: {vertices['valleys']['front']} front, {vertices['valleys']['back']} back), "
            f"{detail['lights']} lights + {detail['sky_directions']} sky directions, "
            f"{detail['neighbours']} neighbour samples a vertex, {sum(detail['timings'].values()):.2f} s"
            + "".join(f"; {note}" for note in detail["notes"]))


def _render_one(params_file, fabric, mesh, options, out, *, mesh_s: float, force: bool, progress: bool,
                say) -> tuple[dict, int]:
    """One params file straight to the image ``out`` (no record, no summary); ``mesh_s``: the
    seconds the mesh took to read, counted in the total."""
    from weavecap.photo import save_image
    from weavecap.render.run import render_fabric

    def show(done, total):
        if progress:
            click.echo(f"\rweavecap render: {params_file.name}: {done}/{total} samples per pixel", err=True, nl=False)
            if done == total:
                click.echo("", err=True)

    result = render_fabric(fabric, mesh, options, progress=show)
    result.info["timings"]["mesh"] = mesh_s
    result.info["timings"]["total"] += mesh_s
    save_image(out, result.image, overwrite=force)
    for note in result.info["notes"]:
        say(f"{params_file}: {note}")
    if result.info.get("fold_detail"):
        say(f"fold term {result.info['fold']}: {_fold_summary(result.info['fold_detail'])}", level=1)
    say(_wrote(out, result.info, result.info["timings"]))
    return {"images": [{"params": str(params_file), "output": str(out), **result.info}], "sheet": None}, 0


def _render_batch(params_files, mesh, options, pattern, out, *, sheet: bool, jobs: int, scheduler, force: bool,
                  say) -> tuple[dict, int]:
    """Several params files as a batch (:mod:`weavecap.batch`, :class:`weavecap.render.job.RenderJob`)."""
    from weavecap import batch as wbatch
    from weavecap.render.job import SHEET, RenderJob, folder_names, write_sheet

    def report(event: wbatch.Event) -> None:
        params_file, record, where = event.item.source, event.record, f"[{event.index}/{event.total}]"
        if event.kind == "skipped":
            say(f"{params_file}: already done ({record['status']}), skipped; --force redoes it")
        elif event.kind == "started":
            say(f"{where} {params_file}: rendering ({options.mode}, {options.spp} spp)", level=1)
        elif record.get("status") == "ok":
            for note in record["notes"]:
                say(f"{params_file}: {note}")
            if record.get("fold_detail"):
                say(f"{where} fold term {record['fold']}: {_fold_summary(record['fold_detail'])}", level=1)
            say(f"{where} {_wrote(record['output'], record, record['timings_s'])}")
        else:
            say(f"{where} {params_file}: {event.line['status']}: {record.get('reason')}", error=True)

    job = RenderJob(mesh=mesh, options=options, pattern=pattern)
    batch = wbatch.plan(job, params_files, out, force=force, names=folder_names(params_files), reserved=(SHEET,))
    result = wbatch.run(batch, jobs=jobs, scheduler=scheduler, on_event=report)
    on_sheet = write_sheet(batch, out / SHEET) if sheet else []
    if on_sheet:
        say(f"wrote {out / SHEET} ({len(on_sheet)} of {len(params_files)} images)")
    return {"images": result.lines, "sheet": str(out / SHEET) if on_sheet else None}, result.exit
