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
#: the principled BSDF's "specular" scale: 1 stands for a reflectance of 8 % at normal incidence
SPECULAR_SPAN = 0.08


@dataclass(frozen=True)
class PbrMaps:
    """One tile of a fabric's PBR material (metal-roughness, non-metal).

    Attributes
    ----------
    base_color : (H, W, 3) float32, linear RGB in [0, 1] (written sRGB-encoded in 8/16-bit files),
        for a material that only reflects
    transmission : (H, W, 3) float32, linear RGB in [0, 1]: the light the yarns let through from
        behind (a diffuse transmission's colour × amount; the gaps are the opacity's)
    translucent_base : (H, W, 3) float32, the base colour for a material that blends that
        transmission in (its reflection keeps 1 − :func:`transmission_weight`)
    normal : (H, W, 3) float32, unit tangent-space normals (OpenGL: +y up the image)
    roughness : (H, W) float32 in [0, 1], perceptual roughness (GGX α = roughness²)
    opacity : (H, W) float32 in [0, 1]: the share of the texel covered by yarn (0 in gaps)
    height : (H, W) float32 in [0, 1]: 0 the lowest point of the tile, 1 the highest
    height_mm : float, the height that ``height = 1`` stands for, in millimetres
    size_mm : (width, height) of the tile in millimetres
    repeats : (rows, columns) of weave repeats the tile spans
    ior : float, index of refraction of the yarns' specular reflection (η^S)
    specular : float in [0, 1], the yarns' specular reflection colour R^S (its mean): with
        ``ior`` it gives the reflectance at normal incidence, :attr:`f0`
    """

    base_color: np.ndarray
    transmission: np.ndarray
    translucent_base: np.ndarray
    normal: np.ndarray
    roughness: np.ndarray
    opacity: np.ndarray
    height: np.ndarray
    height_mm: float
    size_mm: tuple[float, float]
    repeats: tuple[int, int]
    ior: float
    specular: float = 1.0

    @property
    def shape(self) -> tuple[int, int]:
        """(H, W) texels."""
        return (int(self.opacity.shape[0]), int(self.opacity.shape[1]))

    @property
    def f0(self) -> float:
        """Specular reflectance at normal incidence (:func:`f0`)."""
        return f0(self.ior, self.specular)

    @property
    def specular_level(self) -> float:
        """The principled BSDF's ``specular`` (:func:`specular_level`)."""
        return specular_level(self.ior, self.specular)


def f0(ior: float, specular: float) -> float:
    """Specular reflectance at normal incidence: Fresnel's ``((η − 1)/(η + 1))²`` × R^S."""
    return ((ior - 1.0) / (ior + 1.0)) ** 2 * specular


def specular_level(ior: float, specular: float) -> float:
    """The principled BSDF's ``specular`` (Mitsuba, Blender; U3M's ``specular_value``): F0 on
    a scale where 1 stands for 8 %."""
    return min(1.0, f0(ior, specular) / SPECULAR_SPAN)


#: the largest blend weight of the transmission (the reflection keeps at least 5 %)
MAX_TRANSMISSION = 0.95

#: map name → kind: "colour" is sRGB-encoded in integer files, "data" is written as it is
#: (normals as (n + 1) / 2); the PBR export writes these
MAP_KINDS = {
    "base_color": "colour",
    "transmission": "colour",
    "normal": "data",
    "roughness": "data",
    "opacity": "data",
    "height": "data",
}


#: the maps of a material that blends reflection and diffuse transmission (Mitsuba's scene)
BLEND_KINDS = {"translucent_base": "colour", "transmission_weight": "data", "transmission_color": "colour"}


def transmission_weight(transmission: np.ndarray) -> np.ndarray:
    """(H, W): the share of a texel's light given to diffuse transmission when reflection and
    transmission are blended (Mitsuba's ``blendbsdf``): the largest channel of the transmission
    albedo (H, W, 3), so that its colour ``transmission / weight`` stays within [0, 1]."""
    return np.clip(np.max(transmission, axis=-1), 0.0, MAX_TRANSMISSION)


def map_image(maps: PbrMaps, name: str, *, normal_convention: str = "opengl") -> np.ndarray:
    """The image a map is stored as: (H, W, 3) or (H, W) float32 in [0, 1], before encoding.

    Colour maps are linear (the writer encodes sRGB); ``normal`` is ``(n + 1) / 2`` with y
    flipped for DirectX; ``transmission_weight`` and ``transmission_color`` split the
    transmission into a blend weight and a colour; the scalar maps are their values.
    """
    if name in ("transmission_weight", "transmission_color"):
        weight = transmission_weight(maps.transmission)
        if name == "transmission_weight":
            return weight.astype(np.float32)
        return np.clip(maps.transmission / np.maximum(weight[..., None], 1e-6), 0.0, 1.0).astype(np.float32)
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
