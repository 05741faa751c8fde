"""Measure ``weavecap export``'s material against the surface model, and make the README's pictures.

For each fixture fabric: the time of an export of every format (the first one in the process
is cold: kernels compile); then the CIEDE2000 difference of mean colours between the PBR maps
on plain Mitsuba (the exported scene's BSDFs, Mitsuba's ``path`` integrator) and weavecap's
reference renderer (its surface BSDF and path tracer), twice:

- ``weavecap render --mode reference`` of the flat swatch mesh (fixtures/meshes/swatch.obj,
  20 cm, seen whole: about four yarns a pixel), with its own lights (studio, sun), against the
  same render with the fabric replaced by the maps (a mode registered here);
- the exported Mitsuba swatch of 20 × 20 tiles (about a yarn a pixel) under three lights;
- the exported swatch seen at 90°, 45° and 25° elevation (sky + sun), with principled
  ``sheen`` 0 and 1 (does a sheen lobe help?), for two fixtures.

``--pictures DIR`` also writes ``export_maps.png`` (the six maps of the 2/1 twill, 2 × 2 tiles
each) and ``export_gltf.png`` (the exported .glb, read back and rendered at an angle in plain
Mitsuba).

Run: ``.venv/bin/python scripts/measure_export.py [--pictures docs/images]``; docs/export.md
quotes its output.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
FIXTURES = ["plain", "twill_2_1", "twill_3_1", "satin_5", "basket_2_2", "custom_4x6"]
PITCH_MM = 0.4
LIGHTS = {
    "sky + sun": {"sky": {"type": "constant", "radiance": {"type": "rgb", "value": 0.6}},
                  "sun": {"type": "directional", "direction": [-0.3, -0.4, -1.0],
                          "irradiance": {"type": "rgb", "value": 2.0}}},
    "sky": {"sky": {"type": "constant", "radiance": {"type": "rgb", "value": 1.0}}},
    "grazing sun": {"sun": {"type": "directional", "direction": [-1.0, 0.0, -0.35],
                            "irradiance": {"type": "rgb", "value": 3.0}}},
}


def mean_lab(image: np.ndarray) -> np.ndarray:
    from skimage.color import rgb2lab

    from weavecap.photo import linear_to_srgb

    h, w = image.shape[:2]
    mean = image[h // 8: -h // 8, w // 8: -w // 8].reshape(-1, 3).mean(axis=0)
    return rgb2lab(np.clip(linear_to_srgb(mean), 0.0, 1.0)[None, None])[0, 0]


def compare(name: str, folder: Path) -> tuple[float, dict[str, float]]:
    """Export time (s) and ΔE per light for one fixture."""
    from skimage.color import deltaE_ciede2000

    from weavecap import params
    from weavecap.export import ExportOptions, Material, export
    from weavecap.export import mitsuba as mx

    fabric = params.load(ROOT / "fixtures" / "params" / f"{name}.json")
    swatch = 20 * fabric.shape[1] * PITCH_MM
    options = ExportOptions(formats=("pbr", "u3m", "gltf", "mitsuba"), name=name, pitch_mm=PITCH_MM, force=True,
                            swatch_mm=swatch)
    t0 = time.perf_counter()
    export(fabric, folder, options)
    seconds = time.perf_counter() - t0
    maps = Material(fabric, options).maps
    files = {k: str(folder / "mitsuba" / v) for k, v in mx.scene_files(name).items()}
    k = (swatch / maps.size_mm[0], swatch / maps.size_mm[1])
    surface = {"type": mx.PLUGIN, "params": files["params"], "repeat_u": 1 / k[0], "repeat_v": 1 / k[1]}
    mx.register()
    out = {}
    for light, emitters in LIGHTS.items():
        plain = mx.render_scene(mx.swatch_scene(maps, files, swatch_mm=swatch, size=(128, 128), spp=64,
                                                lights=emitters))
        ref_scene = mx.swatch_scene(maps, files, swatch_mm=swatch, size=(128, 128), spp=64, lights=emitters,
                                    bsdf=surface)
        ref_scene["integrator"] = {"type": "weavecap_path", "max_depth": 8}
        ref = mx.render_scene(ref_scene)
        out[light] = float(deltaE_ciede2000(mean_lab(plain), mean_lab(ref)))
    return seconds, out


def render_compare(name: str, lights: tuple[str, ...]) -> dict[str, float]:
    """ΔE between ``weavecap render --mode reference`` of the flat swatch and the same render
    with the exported maps on plain Mitsuba, per light."""
    from skimage.color import deltaE_ciede2000

    from weavecap import params
    from weavecap.export import mitsuba as mx
    from weavecap.export.material import pbr_maps
    from weavecap.fixtures import path as fixture_path
    from weavecap.render import modes
    from weavecap.render.mesh import load_mesh
    from weavecap.render.run import RenderOptions, render_fabric

    fabric = params.load(ROOT / "fixtures" / "params" / f"{name}.json")
    maps = pbr_maps(fabric, pitch_mm=PITCH_MM)
    tmp = Path(tempfile.mkdtemp())
    textures = {key: str(tmp / f"{key}.png") for key in mx.TEXTURES}
    mx.write_textures(maps, tmp, textures)
    modes.register_mode(mx.maps_mode(maps, textures))
    mesh = load_mesh(fixture_path("meshes", "swatch.obj"))
    out = {}
    for light in lights:
        images = [render_fabric(fabric, mesh, RenderOptions(mode=m, light=light, size=(128, 128), spp=64,
                                                            pitch_mm=PITCH_MM, margin=0.0, noise=False)).image
                  for m in ("reference", "exported-maps")]
        out[light] = float(deltaE_ciede2000(mean_lab(images[1]), mean_lab(images[0])))
    return out


def view_compare(name: str, elevations=(90, 45, 25), sheens=(0.0, 1.0)) -> dict[tuple[int, float], float]:
    """ΔE between the exported maps and the reference on a swatch of 60 × 60 tiles seen at
    each elevation (degrees above the swatch, 8° field of view), per principled ``sheen``."""
    import math

    from skimage.color import deltaE_ciede2000

    from weavecap import params
    from weavecap.backend import mitsuba
    from weavecap.export import ExportOptions, Material, export
    from weavecap.export import mitsuba as mx

    mi = mitsuba()
    fabric = params.load(ROOT / "fixtures" / "params" / f"{name}.json")
    swatch = 60 * fabric.shape[1] * PITCH_MM
    folder = Path(tempfile.mkdtemp())
    options = ExportOptions(formats=("mitsuba",), name=name, pitch_mm=PITCH_MM, swatch_mm=swatch, force=True)
    export(fabric, folder, options)
    maps = Material(fabric, options).maps
    files = {k: str(folder / "mitsuba" / v) for k, v in mx.scene_files(name).items()}
    k = swatch / maps.size_mm[0]
    surface = {"type": mx.PLUGIN, "params": files["params"], "repeat_u": 1 / k, "repeat_v": 1 / k}
    mx.register()
    out = {}
    for elevation in elevations:
        e, d = math.radians(elevation), swatch / 1000 * 0.9

        def scene(bsdf=None, sheen=0.0):
            s = mx.swatch_scene(maps, files, swatch_mm=swatch, size=(96, 96), spp=64, lights=LIGHTS["sky + sun"],
                                bsdf=bsdf)
            if bsdf is None:
                s["swatch"]["bsdf"]["bsdf"]["bsdf_0"]["bsdf"]["bsdf"]["sheen"] = float(sheen)
            s["sensor"].update(fov=8.0, near_clip=d / 20, far_clip=d * 20, to_world=mi.ScalarTransform4f().look_at(
                origin=[0, -d * math.cos(e), d * math.sin(e)], target=[0, 0, 0],
                up=[0, 0, 1] if elevation < 90 else [0, 1, 0]))
            return s

        reference = scene(surface)
        reference["integrator"] = {"type": "weavecap_path", "max_depth": 8}
        ref = mean_lab(mx.render_scene(reference))
        for sheen in sheens:
            out[(elevation, sheen)] = float(deltaE_ciede2000(mean_lab(mx.render_scene(scene(sheen=sheen))), ref))
    return out


def glb_render(glb: Path, size: int = 320) -> np.ndarray:
    """The .glb's quad and material read back (pygltflib), rendered at 50° in plain Mitsuba."""
    import pygltflib

    from weavecap.backend import mitsuba

    mi = mitsuba()
    doc = pygltflib.GLTF2().load(str(glb))
    blob = doc.binary_blob()

    def view(i):
        v = doc.bufferViews[i]
        return blob[v.byteOffset: v.byteOffset + v.byteLength]

    pos = np.frombuffer(view(doc.accessors[0].bufferView), np.float32).reshape(-1, 3)
    uv = np.frombuffer(view(doc.accessors[3].bufferView), np.float32).reshape(-1, 2)
    faces = np.frombuffer(view(doc.accessors[4].bufferView), np.uint16).reshape(-1, 3)
    material = doc.materials[0]
    pbr = material.pbrMetallicRoughness
    scale = pbr.baseColorTexture.extensions["KHR_texture_transform"]["scale"]
    tmp = Path(tempfile.mkdtemp())
    images = {}
    for key, info in (("base", pbr.baseColorTexture), ("rough", pbr.metallicRoughnessTexture),
                      ("normal", material.normalTexture)):
        images[key] = tmp / f"{key}.png"
        images[key].write_bytes(view(doc.images[doc.textures[info.index].source].bufferView))
    # glTF's uv (0, 0) is the image's top-left, and so is Mitsuba's: the texture as it is
    to_uv = mi.ScalarTransform4f().scale([scale[0], scale[1], 1.0])

    def bitmap(path, raw):
        return {"type": "bitmap", "filename": str(path), "raw": raw, "to_uv": to_uv}

    import cv2

    rgba = cv2.imread(str(images["base"]), cv2.IMREAD_UNCHANGED)
    cv2.imwrite(str(tmp / "alpha.png"), rgba[..., 3])
    cv2.imwrite(str(tmp / "rgb.png"), rgba[..., :3])
    rough = cv2.imread(str(images["rough"]))[..., 1]  # glTF: roughness in green (OpenCV: BGR)
    cv2.imwrite(str(tmp / "r.png"), rough)
    bsdf = {"type": "mask", "opacity": bitmap(tmp / "alpha.png", True), "bsdf": {"type": "twosided", "bsdf": {
        "type": "normalmap", "normalmap": bitmap(images["normal"], True),
        "bsdf": {"type": "principled", "base_color": bitmap(tmp / "rgb.png", False),
                 "roughness": bitmap(tmp / "r.png", True), "metallic": 0.0}}}}
    props = mi.Properties()
    props["bsdf"] = mi.load_dict(bsdf)
    mesh = mi.Mesh("swatch", len(pos), len(faces), props=props, has_vertex_texcoords=True)
    params = mi.traverse(mesh)
    params["vertex_positions"] = mi.Float(pos.ravel())
    params["vertex_texcoords"] = mi.Float(uv.ravel())
    params["faces"] = mi.UInt32(faces.astype(np.uint32).ravel())
    params.update()
    width = float(pos[:, 0].max() - pos[:, 0].min())
    scene = mi.load_dict({
        "type": "scene", "integrator": {"type": "path", "max_depth": 8},
        "sensor": {"type": "perspective", "fov": 28.0, "near_clip": width / 20, "far_clip": width * 20,
                   "to_world": mi.ScalarTransform4f().look_at(origin=[0.0, 1.3 * width, 1.6 * width],
                                                             target=[0.0, 0.0, 0.02 * width], up=[0.0, 1.0, 0.0]),
                   "film": {"type": "hdrfilm", "width": size, "height": size, "rfilter": {"type": "gaussian"}}},
        "sky": {"type": "constant", "radiance": {"type": "rgb", "value": 0.45}},
        "sun": {"type": "directional", "direction": [0.4, -1.0, -0.5], "irradiance": {"type": "rgb", "value": 2.5}},
        "ground": {"type": "rectangle", "to_world": mi.ScalarTransform4f().translate([0.0, -0.0005, 0.0]).rotate(
            [1, 0, 0], -90).scale([width * 3, width * 3, 1.0]),
                   "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": 0.6}}},
        "swatch": mesh})
    return np.array(mi.render(scene, spp=128), dtype=np.float32)[..., :3]


def pictures(folder: Path, work: Path) -> None:
    import cv2

    from weavecap import params
    from weavecap.export import ExportOptions, export
    from weavecap.photo import save_png

    fabric = params.load(ROOT / "fixtures" / "params" / "twill_2_1.json")
    export(fabric, work / "twill", ExportOptions(formats=("pbr", "gltf"), name="twill", pitch_mm=PITCH_MM,
                                                 swatch_mm=12.0, force=True))
    tiles = []
    for key in ("base_color", "transmission", "normal", "roughness", "opacity", "height"):
        image = cv2.imread(str(work / "twill" / "pbr" / f"twill_{key}.png"), cv2.IMREAD_COLOR)
        tiles.append(cv2.resize(np.tile(image, (2, 2, 1)), (128, 128), interpolation=cv2.INTER_NEAREST))
        tiles.append(np.full((128, 4, 3), 255, np.uint8))
    cv2.imwrite(str(folder / "export_maps.png"), np.hstack(tiles[:-1]))
    save_png(folder / "export_gltf.png", glb_render(work / "twill" / "twill.glb"))
    print(f"wrote {folder / 'export_maps.png'} and {folder / 'export_gltf.png'}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pictures", type=Path, help="folder for export_maps.png and export_gltf.png")
    args = parser.parse_args(argv)
    print(f"load average {os.getloadavg()[0]:.1f}; pitch {PITCH_MM} mm, 16 texels a yarn, 128 px, 64 spp")
    render_lights = ("studio", "sun")
    print("| fixture | export s | " + " | ".join(f"render {light}" for light in render_lights) + " | "
          + " | ".join(f"swatch {light}" for light in LIGHTS) + " |")
    print("|---|---|" + "---|" * (len(render_lights) + len(LIGHTS)))
    with tempfile.TemporaryDirectory() as tmp:
        for name in FIXTURES:
            seconds, de = compare(name, Path(tmp) / name)
            rendered = render_compare(name, render_lights)
            print(f"| {name} | {seconds:.1f} | " + " | ".join(f"{rendered[light]:.2f}" for light in render_lights)
                  + " | " + " | ".join(f"{de[light]:.2f}" for light in LIGHTS) + " |")
            sys.stdout.flush()
        print("\n| fixture | elevation | ΔE | ΔE with sheen 1 |\n|---|---|---|---|")
        for name in ("twill_3_1", "plain"):
            de = view_compare(name)
            for elevation in (90, 45, 25):
                print(f"| {name} | {elevation}° | {de[(elevation, 0.0)]:.2f} | {de[(elevation, 1.0)]:.2f} |")
        if args.pictures:
            pictures(args.pictures, Path(tmp))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
