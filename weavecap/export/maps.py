"""The PBR material of a fabric as plain arrays, and how each map is written as an image.

:class:`PbrMaps` is what every export format writes (the PBR maps, U3M, glTF, the Mitsuba
fallback scene): one tileable tile of the fabric, ``repeats`` weave repeats a side, with its
physical size. The maps' layout is the surface model's (:mod:`weavecap.render.surface`): row 0
is the top of the image (``v = 1``), columns run along ``+u`` (across the warps), and vectors
are in the tangent frame ``x`` along ``+u``, ``y`` along ``+v`` (up in the image), ``z`` out of
the face — the OpenGL normal-map convention (U3M's, glTF's, Blender's).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

#: Normal-map conventions: the sign of the green channel's y. OpenGL (glTF, U3M, Blender) has
#: +y up the image; DirectX (Substance's default, Unreal) has +y down.
NORMAL_CONVENTIONS = {"opengl": 1.0, "directx": -1.0}


@dataclass(frozen=True)
class PbrMaps:
    """One tile of a fabric's PBR material (metal-roughness, non-metal).

    Attributes
    ----------
    base_color : (H, W, 3) float32, linear RGB in [0, 1] (written sRGB-encoded in 8/16-bit files)
    normal : (H, W, 3) float32, unit tangent-space normals (OpenGL: +y up the image)
    roughness : (H, W) float32 in [0, 1], perceptual roughness (GGX α = roughness²)
    opacity : (H, W) float32 in [0, 1]: the share of the texel covered by yarn (0 in gaps)
    height : (H, W) float32 in [0, 1]: 0 the lowest point of the tile, 1 the highest
    height_mm : float, the height that ``height = 1`` stands for, in millimetres
    size_mm : (width, height) of the tile in millimetres
    repeats : (rows, columns) of weave repeats the tile spans
    ior : float, index of refraction of the yarns' specular reflection (η^S)
    sheen : (RGB, roughness) of a sheen lobe, or None when the fabric has none to speak of
    """

    base_color: np.ndarray
    normal: np.ndarray
    roughness: np.ndarray
    opacity: np.ndarray
    height: np.ndarray
    height_mm: float
    size_mm: tuple[float, float]
    repeats: tuple[int, int]
    ior: float
    sheen: tuple[tuple[float, float, float], float] | None = None

    @property
    def shape(self) -> tuple[int, int]:
        """(H, W) texels."""
        return (int(self.opacity.shape[0]), int(self.opacity.shape[1]))


#: map name → kind: "colour" is sRGB-encoded in integer files, "data" is written as it is
#: (normals as (n + 1) / 2)
MAP_KINDS = {
    "base_color": "colour",
    "normal": "data",
    "roughness": "data",
    "opacity": "data",
    "height": "data",
}


def map_image(maps: PbrMaps, name: str, *, normal_convention: str = "opengl") -> np.ndarray:
    """The image a map is stored as: (H, W, 3) or (H, W) float32 in [0, 1], before encoding.

    ``base_color`` is linear (the writer encodes sRGB); ``normal`` is ``(n + 1) / 2`` with
    y flipped for DirectX; the scalar maps are their values.
    """
    if name == "normal":
        n = maps.normal.astype(np.float32).copy()
        n[..., 1] *= NORMAL_CONVENTIONS[normal_convention]
        return np.clip((n + 1.0) * 0.5, 0.0, 1.0)
    return np.clip(getattr(maps, name).astype(np.float32), 0.0, 1.0)


def write_map(path: str | os.PathLike, image: np.ndarray, *, kind: str, bits: int = 8) -> None:
    """Write one map image atomically: ``.png`` (8/16 bit) or ``.exr`` (float32, linear).

    Colour maps in PNG are sRGB-encoded (:func:`weavecap.photo.save_png`); data maps in PNG
    keep their values (quantised to ``bits``); EXR keeps every map's values as they are.
    """
    import cv2

    from ..io import atomic_write_bytes
    from ..photo import save_exr, save_png

    ext = Path(path).suffix.lower()
    if ext == ".exr":
        save_exr(path, image)
        return
    if kind == "colour":
        save_png(path, image, bits=bits)
        return
    top = 2**bits - 1
    q = np.rint(np.clip(image, 0.0, 1.0) * top).astype(np.uint8 if bits == 8 else np.uint16)
    if q.ndim == 3:
        q = np.ascontiguousarray(q[..., ::-1])  # OpenCV writes BGR
    ok, buf = cv2.imencode(".png", q)
    if not ok:
        raise RuntimeError(f"{path}: OpenCV could not encode a PNG of shape {q.shape}")
    atomic_write_bytes(path, buf.tobytes())
