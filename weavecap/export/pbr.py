"""PBR maps for Blender, Substance, Unreal, Unity: one image per map and the physical size.

Writes ``<name>_base_color``, ``_transmission``, ``_normal``, ``_roughness``, ``_opacity`` and
``_height`` as 8- or 16-bit PNG or as EXR, and ``<name>_material.json``: the tile's size in
millimetres, the height map's amplitude, the conventions (sRGB colour maps, OpenGL or DirectX
normals, GGX roughness with α = roughness², metalness 0) and the specular reflectance. The
base colour is for a material that only reflects; the transmission map is the light the yarns
let through from behind, for a renderer that mixes in a diffuse translucency.
"""

from __future__ import annotations

import json
from pathlib import Path

from .maps import MAP_KINDS, PbrMaps, map_image, write_map

FORMAT = "weavecap.pbr/1"


def pbr_files(name: str, *, ext: str = ".png") -> dict[str, str]:
    """The file name of each map and of the material description."""
    files = {key: f"{name}_{key}{ext}" for key in MAP_KINDS}
    files["material"] = f"{name}_material.json"
    return files


def material_description(maps: PbrMaps, files: dict[str, str], *, normal_convention: str, bits: int | None,
                         about: dict) -> dict:
    """The JSON beside the maps: what each file holds, the physical size and the conventions."""
    h, w = maps.shape
    return {
        "format": FORMAT,
        "about": about,
        "size_mm": [round(maps.size_mm[0], 6), round(maps.size_mm[1], 6)],
        "texels": [w, h],
        "repeats": list(maps.repeats),
        "height_mm": round(maps.height_mm, 6),
        "ior": round(maps.ior, 4),
        "f0": round(maps.f0, 5),
        "metalness": 0.0,
        "maps": {
            "base_color": {"file": files["base_color"], "encoding": "sRGB" if bits else "linear"},
            "transmission": {"file": files["transmission"], "encoding": "sRGB" if bits else "linear",
                             "meaning": "light through the yarns from behind (diffuse transmission colour x amount)"},
            "normal": {"file": files["normal"], "convention": normal_convention, "encoding": "(n + 1) / 2"},
            "roughness": {"file": files["roughness"], "encoding": "GGX alpha = value^2"},
            "opacity": {"file": files["opacity"], "encoding": "coverage: 0 gap, 1 yarn"},
            "height": {"file": files["height"], "encoding": "0 lowest, 1 highest = height_mm"},
        },
        "bits": bits,
        "tiles": "seamless: opposite edges continue each other",
    }


def save_pbr(maps: PbrMaps, folder: Path, *, name: str, fmt: str = "png", bits: int = 8,
             normal_convention: str = "opengl", about: dict | None = None) -> list[Path]:
    """Write the maps and their description into ``folder``; returns the paths written.

    Parameters
    ----------
    maps : the material
    folder : where to write (created)
    name : file name stem
    fmt : ``"png"`` (``bits`` 8 or 16) or ``"exr"`` (float32, linear, every map)
    normal_convention : ``"opengl"`` or ``"directx"``
    about : what the maps were made from (fabric, weave, command), stored in the JSON
    """
    from ..io import atomic_write_text

    ext = ".exr" if fmt == "exr" else ".png"
    files = pbr_files(name, ext=ext)
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    for key, kind in MAP_KINDS.items():
        path = folder / files[key]
        write_map(path, map_image(maps, key, normal_convention=normal_convention), kind=kind, bits=bits)
        written.append(path)
    doc = material_description(maps, files, normal_convention=normal_convention, bits=None if fmt == "exr" else bits,
                               about=about or {})
    path = folder / files["material"]
    atomic_write_text(path, json.dumps(doc, indent=1) + "\n")
    return written + [path]
