"""Mitsuba 3 scene of a swatch: the fabric's maps on plain Mitsuba's principled BSDF.

The scene is built as a Mitsuba dictionary (what ``mi.load_dict`` takes) and written as the
XML scene format (``mi.load_file``); Mitsuba 3.9 has no dictionary-to-XML writer, so
:func:`to_xml` serialises the few plugin kinds a swatch uses with ElementTree. The same
dictionary renders in-process (:func:`render_swatch`: the U3M preview, the README's pictures,
the comparison with ``weavecap render --mode reference``).

The swatch is a ``rectangle`` in the z = 0 plane facing +z, ``swatch_mm`` wide (scene units:
metres), the camera on +z looking down at it, y up. Its material is, from the outside in:
``mask`` (opacity: the gaps let the light through) → ``twosided`` → ``normalmap`` (OpenGL
tangent-space normals) → ``principled`` (base colour, roughness, metallic 0, the yarns' η).
Every bitmap repeats the tile ``k`` times across the swatch (``to_uv``); Mitsuba puts an
image's first row at v = 0, the bottom of the rectangle, so ``to_uv`` also flips v to show the
maps as they look in the PNG files (row 0 at the top).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from .maps import PbrMaps

#: plugin type → the XML element it is written as
PLUGIN_TAGS = {
    **dict.fromkeys(("path", "direct"), "integrator"),
    **dict.fromkeys(("perspective", "orthographic"), "sensor"),
    "hdrfilm": "film", **dict.fromkeys(("box", "gaussian"), "rfilter"),
    **dict.fromkeys(("independent", "stratified"), "sampler"),
    **dict.fromkeys(("constant", "directional", "envmap", "point"), "emitter"),
    **dict.fromkeys(("rectangle", "obj", "ply"), "shape"),
    **dict.fromkeys(("principled", "normalmap", "mask", "twosided", "diffuse"), "bsdf"),
    "bitmap": "texture",
}

#: the fallback light: a uniform sky and a sun over the camera's shoulder (radiance,
#: irradiance, direction towards which the sun shines)
SKY_RADIANCE = 0.6
SUN_IRRADIANCE = 2.0
SUN_DIRECTION = (-0.3, -0.4, -1.0)
FOV_DEG = 30.0


def _matrix(transform) -> str:
    m = np.array(transform.matrix, dtype=np.float64).reshape(4, 4)
    return " ".join(f"{v:.9g}" for v in m.ravel())


def _element(name: str | None, value, parent: ET.Element) -> None:
    """Append ``value`` (a plugin dict, an rgb dict, a transform or a scalar) to ``parent``."""
    from ..backend import mitsuba

    mi = mitsuba()

    attrs = {"name": name} if name else {}
    if isinstance(value, dict) and value.get("type") == "rgb":
        v = value["value"]
        v = [v] * 3 if isinstance(v, (int, float)) else v
        ET.SubElement(parent, "rgb", attrs, value=", ".join(f"{c:.9g}" for c in v))
    elif isinstance(value, dict):
        tag = PLUGIN_TAGS[value["type"]]
        el = ET.SubElement(parent, tag, {"type": value["type"], **({"id": value["id"]} if "id" in value else {}),
                                         **attrs})
        for key, item in value.items():
            if key not in ("type", "id"):
                _element(key, item, el)  # a plugin's children keep their dictionary key as name
    elif isinstance(value, mi.ScalarTransform4f):
        ET.SubElement(ET.SubElement(parent, "transform", attrs), "matrix", value=_matrix(value))
    elif isinstance(value, bool):
        ET.SubElement(parent, "boolean", attrs, value="true" if value else "false")
    elif isinstance(value, int):
        ET.SubElement(parent, "integer", attrs, value=str(value))
    elif isinstance(value, float):
        ET.SubElement(parent, "float", attrs, value=f"{value:.9g}")
    elif isinstance(value, str):
        ET.SubElement(parent, "string", attrs, value=value)
    elif isinstance(value, (list, tuple)) and len(value) == 3:
        ET.SubElement(parent, "vector", attrs, value=", ".join(f"{c:.9g}" for c in value))
    else:
        raise TypeError(f"cannot write {name}={value!r} as Mitsuba XML")


def to_xml(scene: dict) -> str:
    """The Mitsuba 3 XML text of a scene dictionary (``{"type": "scene", ...}``)."""
    root = ET.Element("scene", version="3.0.0")
    for key, value in scene.items():
        if key != "type":
            _element(None, value, root)
    ET.indent(root)
    return ET.tostring(root, encoding="unicode") + "\n"


def swatch_scene(maps: PbrMaps, textures: dict[str, str], *, swatch_mm: float, size: tuple[int, int] = (512, 512),
                 spp: int = 64, lights: dict | None = None, bsdf: dict | None = None) -> dict:
    """The scene dictionary of a flat swatch with the maps on the principled BSDF.

    Parameters
    ----------
    maps : the material (tile size; its ior)
    textures : map name → image file (``base_color``, ``normal``, ``roughness``, ``opacity``)
    swatch_mm : side of the square swatch (whole tiles: ``k = swatch_mm / tile``)
    size : (width, height) pixels; spp : samples per pixel
    lights : emitters by name (default: :data:`SKY_RADIANCE` sky and a sun)
    bsdf : replaces the principled material (e.g. weavecap's own surface BSDF)
    """
    from ..backend import mitsuba

    mi = mitsuba()

    k = (swatch_mm / maps.size_mm[0], swatch_mm / maps.size_mm[1])
    half = swatch_mm / 2000.0
    to_uv = mi.ScalarTransform4f().scale([k[0], -k[1], 1.0])

    def bitmap(key: str, raw: bool) -> dict:
        return {"type": "bitmap", "filename": textures[key], "raw": raw, "to_uv": to_uv, "filter_type": "bilinear"}

    material = bsdf or {
        "type": "mask",
        "opacity": bitmap("opacity", True),
        "bsdf": {"type": "twosided", "bsdf": {
            "type": "normalmap", "normalmap": bitmap("normal", True),
            "bsdf": {"type": "principled", "base_color": bitmap("base_color", False),
                     "roughness": bitmap("roughness", True), "metallic": 0.0,
                     "specular": float(min(1.0, ((maps.ior - 1) / (maps.ior + 1)) ** 2 / 0.08)),
                     **({"sheen": float(np.mean(maps.sheen[0]))} if maps.sheen else {})}}},
    }
    distance = half / math.tan(math.radians(FOV_DEG) / 2.0) * 1.02
    return {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 8},
        "sensor": {"type": "perspective", "fov": FOV_DEG, "near_clip": distance / 10.0, "far_clip": distance * 10.0,
                   "to_world": mi.ScalarTransform4f().look_at(origin=[0.0, 0.0, distance], target=[0.0, 0.0, 0.0],
                                                             up=[0.0, 1.0, 0.0]),
                   "film": {"type": "hdrfilm", "width": int(size[0]), "height": int(size[1]),
                            "rfilter": {"type": "box"}},
                   "sampler": {"type": "independent", "sample_count": int(spp)}},
        **(lights or {"sky": {"type": "constant", "radiance": {"type": "rgb", "value": SKY_RADIANCE}},
                      "sun": {"type": "directional", "direction": list(SUN_DIRECTION),
                              "irradiance": {"type": "rgb", "value": SUN_IRRADIANCE}}}),
        "swatch": {"type": "rectangle", "to_world": mi.ScalarTransform4f().scale([half, half, 1.0]), "bsdf": material},
    }


def render_scene(scene: dict | str | Path, *, spp: int | None = None, seed: int = 0) -> np.ndarray:
    """Render a scene dictionary or XML file in plain Mitsuba; (H, W, 3) float32 linear RGB."""
    from ..backend import mitsuba

    mi = mitsuba()
    loaded = mi.load_file(str(scene)) if isinstance(scene, (str, Path)) else mi.load_dict(scene)
    return np.array(mi.render(loaded, spp=spp or 0, seed=seed), dtype=np.float32)[..., :3]


def save_scene(scene: dict, path: Path) -> Path:
    """Write a scene dictionary as Mitsuba XML, atomically."""
    from ..io import atomic_write_text

    atomic_write_text(path, to_xml(scene))
    return path
