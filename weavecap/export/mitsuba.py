"""Mitsuba 3 scenes of a swatch: the PBR maps on plain Mitsuba's principled BSDF, and the same
swatch with weavecap's own surface BSDF for Mitsuba where weavecap is installed.

The scene is built as a Mitsuba dictionary (what ``mi.load_dict`` takes) and written as the
XML scene format (``mi.load_file``); Mitsuba 3.9 has no dictionary-to-XML writer, so
:func:`to_xml` serialises the few plugin kinds a swatch uses with ElementTree. The same
dictionary renders in-process (:func:`render_swatch`: the U3M preview, the README's pictures,
the comparison with ``weavecap render --mode reference``).

The swatch is a ``rectangle`` in the z = 0 plane facing +z, ``swatch_mm`` wide (scene units:
metres), the camera on +z looking down at it, y up, in a uniform sky (seen through the gaps,
and through the yarns from behind) with a sun. Its material is, from the outside in:
``mask`` (opacity: the gaps let the light through) → ``blendbsdf`` (transmission weight) of
``twosided`` → ``normalmap`` (OpenGL tangent-space normals) → ``principled`` (translucent base
colour, roughness, metallic 0, the yarns' specular level) and ``principledthin``.
The yarns' translucency is kept: ``blendbsdf`` mixes that with a
``principledthin`` of pure diffuse transmission (``diff_trans`` 2, η 1) of the transmission's
colour, weighted per texel, the reflection's base colour solved for the weight it keeps
(:mod:`weavecap.export.material`). Every bitmap repeats the tile ``k`` times across the swatch
(``to_uv``); Mitsuba puts an
image's first row at v = 0, the bottom of the rectangle, so ``to_uv`` also flips v to show the
maps as they look in the PNG files (row 0 at the top).

With weavecap: :func:`register` adds the BSDF plugin ``weavecap_surface`` (properties:
``params``, a params file relative to the scene; ``repeat_u``, ``repeat_v``, one weave repeat
in texture coordinates; ``texels_per_yarn``) — :class:`weavecap.render.bsdf.SurfaceBSDF` on the
surface model baked from that file, §6.3 noise included — and the path tracer
``weavecap_path`` (:mod:`weavecap.render.integrator`, which lets light through the gaps).
:func:`load_scene` registers them and loads a scene file.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from .maps import BLEND_KINDS, PbrMaps, map_image, write_map

#: plugin type → the XML element it is written as
PLUGIN_TAGS = {
    **dict.fromkeys(("path", "direct", "weavecap_path"), "integrator"),
    **dict.fromkeys(("perspective", "orthographic"), "sensor"),
    "hdrfilm": "film", **dict.fromkeys(("box", "gaussian"), "rfilter"),
    **dict.fromkeys(("independent", "stratified"), "sampler"),
    **dict.fromkeys(("constant", "directional", "envmap", "point"), "emitter"),
    **dict.fromkeys(("rectangle", "obj", "ply"), "shape"),
    **dict.fromkeys(("principled", "principledthin", "normalmap", "mask", "twosided", "blendbsdf", "diffuse",
                     "weavecap_surface"), "bsdf"),
    "bitmap": "texture",
}

#: the fallback light: a uniform sky and a sun over the camera's shoulder (radiance,
#: irradiance, direction towards which the sun shines)
SKY_RADIANCE = 0.6
SUN_IRRADIANCE = 2.0
SUN_DIRECTION = (-0.3, -0.4, -1.0)
FOV_DEG = 30.0
PLUGIN = "weavecap_surface"


def _matrix(transform) -> str:
    m = np.array(transform.matrix, dtype=np.float64).reshape(4, 4)
    return " ".join(f"{v:.9g}" for v in m.ravel())


def _copy_dicts(value):
    """A copy of nested dictionaries (their other values shared: transforms do not deep-copy)."""
    return {k: _copy_dicts(v) for k, v in value.items()} if isinstance(value, dict) else value


class _Default(str):
    """An integer written as a reference to a ``<default>`` parameter."""


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
    elif isinstance(value, _Default):
        ET.SubElement(parent, "integer", attrs, value=f"${value}")
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


#: values of a swatch scene that its XML file declares as defaults, so that a user overrides
#: them when loading it (``mitsuba -D spp=256 scene.xml``, ``mi.load_file(path, resx=1024)``)
DEFAULTS = {"resx": ("sensor", "film", "width"), "resy": ("sensor", "film", "height"),
            "spp": ("sensor", "sampler", "sample_count")}


def to_xml(scene: dict) -> str:
    """The Mitsuba 3 XML text of a scene dictionary (``{"type": "scene", ...}``); the values at
    :data:`DEFAULTS` become ``<default>`` parameters (``$resx``, ``$resy``, ``$spp``)."""
    root = ET.Element("scene", version="3.0.0")
    scene = _copy_dicts(scene)
    for name, keys in DEFAULTS.items():
        node = scene
        for key in keys[:-1]:
            node = node.get(key, {})
        if keys[-1] in node:
            ET.SubElement(root, "default", name=name, value=str(node[keys[-1]]))
            node[keys[-1]] = _Default(name)
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
    maps : the material (tile size, specular level)
    textures : map name → image file (:data:`TEXTURES`)
    swatch_mm : side of the square swatch (whole tiles: ``k = swatch_mm / tile``)
    size : (width, height) pixels; spp : samples per pixel
    lights : emitters by name (default: :data:`SKY_RADIANCE` sky and a sun)
    bsdf : replaces the principled material (e.g. weavecap's own surface BSDF)
    """
    from ..backend import mitsuba

    mi = mitsuba()
    k = (swatch_mm / maps.size_mm[0], swatch_mm / maps.size_mm[1])
    half = swatch_mm / 2000.0
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
        "swatch": {"type": "rectangle", "to_world": mi.ScalarTransform4f().scale([half, half, 1.0]),
                   "bsdf": bsdf or material(maps, textures, (1.0 / k[0], 1.0 / k[1]))},
    }


def material(maps: PbrMaps, textures: dict[str, str], tile_uv: tuple[float, float]) -> dict:
    """The maps on plain Mitsuba BSDFs (module docstring), as a ``load_dict`` dictionary.

    Parameters
    ----------
    maps : the material (its specular level)
    textures : map name → image file (:data:`TEXTURES`)
    tile_uv : (width, height) of one tile in the surface's texture coordinates
    """
    from ..backend import mitsuba

    mi = mitsuba()
    to_uv = mi.ScalarTransform4f().scale([1.0 / tile_uv[0], -1.0 / tile_uv[1], 1.0])

    def bitmap(key: str, raw: bool) -> dict:
        return {"type": "bitmap", "filename": textures[key], "raw": raw, "to_uv": to_uv, "filter_type": "bilinear"}

    reflection = {"type": "twosided", "bsdf": {
        # no shadow-terminator darkening: the maps' normals are the yarns' own relief, the
        # material was fitted without it, and glTF/U3M viewers apply none
        "type": "normalmap", "normalmap": bitmap("normal", True), "use_shadowing_function": False,
        "bsdf": {"type": "principled", "base_color": bitmap("translucent_base", False),
                 "roughness": bitmap("roughness", True), "metallic": 0.0, "specular": float(maps.specular_level)}}}
    transmission = {"type": "principledthin", "base_color": bitmap("transmission_color", False), "diff_trans": 2.0,
                    "eta": 1.0, "roughness": 1.0}
    return {"type": "mask", "opacity": bitmap("opacity", True),
            "bsdf": {"type": "blendbsdf", "weight": bitmap("transmission_weight", True), "bsdf_0": reflection,
                     "bsdf_1": transmission}}


#: the maps the swatch scene reads, and how each is stored
TEXTURES = {"normal": "data", "roughness": "data", "opacity": "data", **BLEND_KINDS}


def maps_mode(maps: PbrMaps, textures: dict[str, str], name: str = "exported-maps"):
    """A ``weavecap render`` mode (:class:`weavecap.render.modes.Mode`) that shades the mesh
    with the maps on plain Mitsuba's BSDFs and integrates with Mitsuba's ``path``: the exported
    material in the reference renderer's very scene (meshes' UVs in metres). Register it with
    :func:`weavecap.render.modes.register_mode` to compare with ``--mode reference``."""
    from ..backend import mitsuba
    from ..render.modes import Mode

    mi = mitsuba()
    tile_m = (maps.size_mm[0] / 1000.0, maps.size_mm[1] / 1000.0)
    return Mode(name, "the exported PBR maps on plain Mitsuba",
                bsdf=lambda *_: mi.load_dict(material(maps, textures, tile_m)),
                integrator=lambda lighting, options: {"type": "path", "max_depth": int(options.max_depth)})


def scene_files(name: str, fabric=None) -> dict[str, str]:
    """The files of the Mitsuba export, relative to its folder: with ``fabric``, also a copy of
    each body-colour texture its params name (``<yarn>_body``), so that the folder is
    self-contained (its params file points at the copies, not back at the source)."""
    files = {key: f"textures/{name}_{key}.png" for key in TEXTURES}
    files.update(scene=f"{name}.xml", weavecap=f"{name}_weavecap.xml", params=f"{name}.json")
    for yarn in ("warp", "weft"):
        colour = getattr(fabric, yarn).body_reflection if fabric is not None else None
        if isinstance(colour, str):
            files[f"{yarn}_body"] = f"textures/{name}_{yarn}_body{Path(colour).suffix.lower()}"
    return files


def write_textures(maps: PbrMaps, folder: Path, files: dict[str, str]) -> None:
    """The maps the swatch scene reads (:data:`TEXTURES`), as 16-bit PNGs at ``files``."""
    for key, kind in TEXTURES.items():
        write_map(Path(folder) / files[key], map_image(maps, key), kind=kind, bits=16)


def save_scenes(maps: PbrMaps, fabric, folder: Path, *, name: str, swatch_mm: float, texels_per_yarn: int) -> list[Path]:
    """Write the swatch scene twice into ``folder``: ``<name>.xml`` with the PBR maps on the
    principled BSDF (plain Mitsuba), and ``<name>_weavecap.xml`` with weavecap's surface BSDF
    and path tracer (:func:`load_scene`), with the fabric's params beside it and copies of its
    body textures under ``textures/`` (the folder moves as a whole)."""
    from ..io import atomic_write_bytes
    from ..params import save

    files = scene_files(name, fabric)
    write_textures(maps, folder, files)
    plain = swatch_scene(maps, files, swatch_mm=swatch_mm)
    save_scene(plain, folder / files["scene"])
    copies = {}
    for yarn in ("warp", "weft"):
        if f"{yarn}_body" in files:
            copy = (folder / files[f"{yarn}_body"]).resolve()
            atomic_write_bytes(copy, Path(getattr(fabric, yarn).body_reflection).read_bytes())
            copies[f"{yarn}.body_reflection"] = str(copy)
    save(fabric.replace(copies) if copies else fabric, folder / files["params"])
    k = (swatch_mm / maps.size_mm[0] * maps.repeats[1], swatch_mm / maps.size_mm[1] * maps.repeats[0])
    surface = {"type": PLUGIN, "params": files["params"], "repeat_u": 1.0 / k[0], "repeat_v": 1.0 / k[1],
               "texels_per_yarn": int(texels_per_yarn)}
    own = swatch_scene(maps, files, swatch_mm=swatch_mm, bsdf=surface)
    own["integrator"] = {"type": "weavecap_path", "max_depth": 8}
    save_scene(own, folder / files["weavecap"])
    return [folder / f for f in files.values()]


def render_scene(scene: dict | str | Path, *, spp: int | None = None, seed: int = 0, **defaults) -> np.ndarray:
    """Render a scene dictionary or file (``defaults`` override a file's ``<default>``s, e.g.
    ``resx=96``); (H, W, 3) float32 linear RGB. weavecap's plugins are registered first, so
    the ``_weavecap.xml`` scenes render too."""
    from ..backend import mitsuba

    mi = mitsuba()
    loaded = load_scene(scene, **defaults) if isinstance(scene, (str, Path)) else mi.load_dict(scene)
    return np.array(mi.render(loaded, spp=spp or 0, seed=seed), dtype=np.float32)[..., :3]


def save_scene(scene: dict, path: Path) -> Path:
    """Write a scene dictionary as Mitsuba XML, atomically."""
    from ..io import atomic_write_text

    atomic_write_text(path, to_xml(scene))
    return path


def _surface_plugin(props):
    """The ``weavecap_surface`` BSDF of a scene (see the module docstring)."""
    from ..backend import mitsuba
    from ..params import load
    from ..render.bsdf import Placement, SurfaceBSDF
    from ..render.surface import TEXELS_PER_YARN, bake, noise_map

    mi = mitsuba()
    path = str(mi.file_resolver().resolve(props["params"]))
    fabric = load(path)
    maps = bake(fabric, texels_per_yarn=int(props.get("texels_per_yarn", TEXELS_PER_YARN)))
    placement = Placement(repeat_size=(float(props["repeat_u"]), float(props["repeat_v"])))
    return SurfaceBSDF(fabric, maps, placement, noise_map(fabric))


def register() -> None:
    """Make ``weavecap_surface`` (BSDF) and ``weavecap_path`` (integrator) loadable by name."""
    from ..backend import mitsuba
    from ..render import integrator

    mitsuba().register_bsdf(PLUGIN, _surface_plugin)
    integrator.register()


def load_scene(path: str | Path, **defaults):
    """Load a scene file, weavecap's plugins registered (``mi.load_file``; ``defaults``
    override its ``<default>`` parameters)."""
    from ..backend import mitsuba

    register()
    return mitsuba().load_file(str(path), **{k: str(v) for k, v in defaults.items()})
