"""U3M 1.1 (Vizoo's Unified 3D Material) for CLO 3D and Browzwear: JSON + PNG textures.

The document follows the published specification, ``vizoogmbh/u3m`` (BSD-3-Clause):
``u3m1.1/spec/u3m_schema.json`` and the notes ``u3m1.1/spec/u3m_additional_spec*.txt`` —
physical sizes in millimetres, OpenGL normals encoded ``(n + 1) / 2``, colour images in sRGB
and data images without colour space, every texture beside a constant that matches its mean
(for software that reads only constants), a ``principled`` shader, ``repeat`` mode ``normal``
(wrap), and a preview that is a rendering of the material on a plane seen from above (the
specification asks for "some kind of rendering"; weavecap's is plain Mitsuba's principled BSDF
with these very maps, :func:`weavecap.export.mitsuba.render_swatch`).

The displacement's unit is not fixed by U3M 1.1 ("a relative distance"); weavecap writes
millimetres (``factor`` = the height map's amplitude), like every other length in the file.
"""

from __future__ import annotations

import hashlib
import json
import uuid
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from .maps import PbrMaps, map_image, write_map

SCHEMA_VERSION = "1.1"
TEXTURES = "textures"  # folder of the images, beside the .u3m


def material_id(key: bytes) -> str:
    """A UUID4-formatted id that is the same for the same input (a hash of ``key``)."""
    return str(uuid.UUID(bytes=hashlib.sha256(key).digest()[:16], version=4))


def _rgb(c) -> dict:
    from ..photo import linear_to_srgb

    s = np.clip(linear_to_srgb(np.clip(np.asarray(c, dtype=np.float64), 0.0, 1.0)), 0.0, 1.0)
    return {"r": round(float(s[0]), 6), "g": round(float(s[1]), 6), "b": round(float(s[2]), 6)}


def _number(constant: float, texture: dict | None = None) -> dict:
    return {"constant": round(float(constant), 6), "texture": texture}


def u3m_files(name: str) -> dict[str, str]:
    """Texture paths (relative, POSIX) by map, and the .u3m file name."""
    files = {key: f"{TEXTURES}/{name}_{key}.png" for key in ("base_color", "normal", "roughness", "opacity", "height",
                                                              "preview")}
    files["u3m"] = f"{name}.u3m"
    return files


def u3m_document(maps: PbrMaps, files: dict[str, str], *, name: str, description: str, material_key: bytes,
                 created: datetime, preview_shape: tuple[int, int], custom: dict | None = None) -> dict:
    """The .u3m JSON document of a material whose textures lie at ``files``.

    Parameters
    ----------
    maps : the material (one tile; ``size_mm`` is every image's width and height)
    files : :func:`u3m_files`
    name, description : shown in the material library
    material_key : bytes the material's id is hashed from (the same input gives the same id)
    created : time stamp of ``created`` and ``modified`` (UTC)
    preview_shape : (h, w) pixels of the preview image (it shows the same tile)
    custom : weavecap's own data, under ``custom.weavecap``
    """
    w_mm, h_mm = maps.size_mm

    def placed(key: str, shape: tuple[int, int]) -> dict:
        # U3M: the dpi must agree with the image's pixels over its width and height
        dpi = {"x": round(shape[1] / (w_mm / 25.4), 6), "y": round(shape[0] / (h_mm / 25.4), 6)}
        return {"width": round(w_mm, 6), "height": round(h_mm, 6), "dpi": dpi, "path": files[key]}

    def image(key: str) -> dict:
        return {**placed(key, maps.shape), "repeat": {"rotation": 0, "mode": "normal"}}

    def scalar(key: str, factor: float = 1.0) -> dict:
        return {"factor": round(float(factor), 6), "offset": 0.0, "image": image(key)}

    mean_colour = maps.base_color.reshape(-1, 3).mean(axis=0)
    visual = {
        "alpha": _number(maps.opacity.mean(), scalar("opacity")),
        "anisotropy_value": _number(0.0),
        "anisotropy_rotation": _number(0.0),
        "clearcoat_value": _number(0.0),
        "clearcoat_normal": {"constant": {"x": 0.0, "y": 0.0, "z": 1.0}, "texture": None},
        "clearcoat_roughness": _number(0.0),
        "ior": _number(maps.ior),
        "metalness": _number(0.0),
        "normal": {"constant": {"x": 0.0, "y": 0.0, "z": 1.0}, "texture": {"scale": 1.0, "image": image("normal")}},
        "displacement": _number(maps.height.mean() * maps.height_mm, scalar("height", maps.height_mm)),
        "roughness": _number(maps.roughness.mean(), scalar("roughness")),
        "sheen_value": _number(0.0),
        "sheen_tint": _number(0.0),
        "specular_value": _number(maps.specular_level),  # U3M: 1.0 stands for 8 %
        "specular_tint": _number(0.0),
        "subsurface_radius": _number(0.0),
        "subsurface_value": _number(0.0),
        "transmission": _number(0.0),
        "basecolor": {"constant": _rgb(mean_colour),
                      "texture": {"mode": "multiply", "factor": {"r": 1.0, "g": 1.0, "b": 1.0},
                                  "image": image("base_color")}},
        "subsurface_color": {"constant": _rgb(mean_colour), "texture": None},
        "shader": "principled",
        "preview": placed("preview", preview_shape),
    }
    stamp = created.astimezone(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
    return {
        "schema": SCHEMA_VERSION,
        "material": {
            "id": material_id(material_key), "name": name, "description": description,
            "created": stamp, "modified": stamp,
            "front": visual, "back": None, "side": None, "physics": None, "metadata": None,
        },
        "custom": {"weavecap": custom} if custom else None,
    }


def save_u3m(maps: PbrMaps, folder: Path, *, name: str, description: str, material_key: bytes, created: datetime,
             preview: np.ndarray, bits: int = 8, custom: dict | None = None) -> list[Path]:
    """Write ``<name>.u3m``, its PNG textures (``bits`` per channel) and ``preview`` (linear
    RGB, (h, w, 3)) into ``folder``."""
    from ..io import atomic_write_text

    files = u3m_files(name)
    (folder / TEXTURES).mkdir(parents=True, exist_ok=True)
    written = []
    for key, kind in (("base_color", "colour"), ("normal", "data"), ("roughness", "data"), ("opacity", "data"),
                      ("height", "data")):
        path = folder / files[key]
        write_map(path, map_image(maps, key), kind=kind, bits=bits)
        written.append(path)
    write_map(folder / files["preview"], preview, kind="colour", bits=8)
    written.append(folder / files["preview"])
    doc = u3m_document(maps, files, name=name, description=description, material_key=material_key, created=created,
                       preview_shape=preview.shape[:2], custom=custom)
    atomic_write_text(folder / files["u3m"], json.dumps(doc, indent=1) + "\n")
    return written + [folder / files["u3m"]]
