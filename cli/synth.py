"""``weavecap synth``: render a synthetic photo of a fabric from its params file."""

from __future__ import annotations

import time
from pathlib import Path

import click

from .options import force_option, parse_tiles, pattern_option, quiet_option, seed_option


@click.command(context_settings={"max_content_width": 100})
@click.argument("params_file", metavar="PARAMS.json", type=click.Path(readable=False, path_type=Path))
@click.option("-o", "--output", "output", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="Photo to write: .png (sRGB, 8 bit), .exr (linear) or .tif/.tiff (16 bit).")
@click.option("--tiles", default="4x4", show_default=True, callback=parse_tiles,
              help="Repeats of the weave pattern in the frame, rows x columns.")
@click.option("--size", default=512, show_default=True, type=int,
              help="Pixels along the longer side of the photo.")
@click.option("--light", type=click.Choice(["both", "front", "back", "lamp"]), default="both", show_default=True,
              help="Light rig (§6.4): ambient + front, back and side lights, front-only / back-only, or one lamp "
                   "in front and the back light (no side lights).")
@click.option("--spp", default=4, show_default=True, type=int,
              help="Samples per pixel (antialiasing; lighting itself is exact).")
@click.option("--rotate", "rotate_deg", default=0.0, show_default=True, type=float,
              help="Turn the fabric counter-clockwise in the photo by this many degrees.")
@click.option("--camera", type=click.Choice(["orthographic", "perspective"]), default="orthographic",
              show_default=True, help="Camera model.")
@click.option("--fov", "fov_deg", default=30.0, show_default=True, type=float,
              help="Field of view of the perspective camera, degrees.")
@click.option("--noise/--no-noise", default=True, show_default=True,
              help="Add the irregularity noise stored in the params file (§6.3), if it has any.")
@pattern_option
@seed_option
@force_option
@quiet_option
def synth(params_file: Path, output: Path, tiles, size, light, spp, rotate_deg, camera, fov_deg, noise, pattern_file,
          seed, force, quiet):
    """Render a synthetic close-up photo of the fabric in PARAMS.json.

    The forward model of weavecap: yarn tubes swept along the weave (Algorithm 1), shaded with
    the bidirectional yarn scattering function (§3.3), under the light rig of §6.4. The same
    params, options and --seed give the same image, bit for bit.

    \b
    Examples:
      weavecap synth fixtures/params/twill_2_1.json -o twill.png
      weavecap synth fabric.json -o close.exr --tiles 1x1 --size 128 --light front
      weavecap synth fabric.json -o turned.png --rotate 20 --camera perspective --seed 3
      weavecap synth fabric.json -o draft.png --pattern draft.wif
    """
    from weavecap import params as wparams
    from weavecap.io import check_writable, refuse_overwrite
    from weavecap.photo import save_image, supported_output

    supported_output(output)  # fail on a bad extension, an unwritable place or an existing output before any work
    check_writable(output, folder=False)
    refuse_overwrite(output, force=force)
    fabric = wparams.load(params_file)
    if pattern_file is not None:
        from weavecap.patterns import load_pattern

        fabric = fabric.replace({"pattern": load_pattern(pattern_file)})

    from weavecap.model.render import render_numpy
    from weavecap.model.scene import View, build_scene

    view = View(tiles=tiles, size=size, camera=camera, fov_deg=fov_deg, rotate_deg=rotate_deg, spp=spp)
    start = time.perf_counter()
    scene = build_scene(fabric, view, light=light)
    image = render_numpy(scene, seed=seed)
    if noise and fabric.noise:
        from weavecap.noise import add_noise

        pitch_px = image.shape[1] / (tiles[1] * fabric.shape[1])  # yarn pitch in the image, px
        image = add_noise(image, fabric.noise, pitch_px=pitch_px, seed=seed)
    save_image(output, image, overwrite=force)
    if not quiet:
        h, w = image.shape[:2]
        click.echo(f"wrote {output} ({w}x{h}, {fabric.shape[0]}x{fabric.shape[1]} pattern, "
                   f"{tiles[0]}x{tiles[1]} repeats, {time.perf_counter() - start:.1f} s)", err=True)
