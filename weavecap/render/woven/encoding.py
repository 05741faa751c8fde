"""What the woven network's encoder is given (Chen et al. 2024, §4.2): a fabric's baked maps
as an image of a few repeats, and its non-colour parameters.

:func:`encoder_image` resamples a side's maps (:class:`weavecap.render.surface.SurfaceMaps`) to
ENCODER_TEXELS texels a yarn and tiles the repeat over an ENCODER_SIZE² image, one plane per
ENCODER_CHANNELS; :func:`encoder_params` scales ENCODER_PARAMS to [0, 1] over Table 1's
ranges. Used by the renderer (:mod:`.infer`, once per fabric) and by the training data
(:mod:`weavecap.training.woven`).
"""

from __future__ import annotations

import math

import numpy as np

from ...params import FIT_RANGES, Fabric
from ..surface import HORIZON_AZIMUTHS, SurfaceMaps

ENCODER_TEXELS = 8  # texels per yarn of the encoder's input image
ENCODER_SIZE = 64  # the encoder's input image is ENCODER_SIZE² texels (the repeat tiled)
#: non-colour parameters the encoder is given (normalised over FIT_RANGES), then log2 of the
#: repeat's wefts and warps / 3
ENCODER_PARAMS = ("specular.roughness", "specular.roughness_exit", "specular.ior", "specular.ior_exit",
                  "specular.attenuation", "body_attenuation", "shadowing.ply", "shadowing.fiber", "plies", "fibers")
N_PARAMS = len(ENCODER_PARAMS) + 2
#: the encoder image's channels
ENCODER_CHANNELS = ("coverage", "warp", "normal_x", "normal_y", "height", "groove_p", "groove_f", "horizon",
                    "horizon_cos", "horizon_sin", "through", "through_tilted")




def _to_encoder_resolution(a: np.ndarray, t: int) -> np.ndarray:
    """(H, W, C) at ``t`` texels a yarn → ENCODER_TEXELS a yarn (box mean or periodic
    bilinear resampling)."""
    from scipy import ndimage

    if t % ENCODER_TEXELS == 0:
        k = t // ENCODER_TEXELS
        h, w, c = a.shape
        return a.reshape(h // k, k, w // k, k, c).mean(axis=(1, 3))
    zoom = ENCODER_TEXELS / t
    return np.stack([ndimage.zoom(a[..., i], zoom, order=1, mode="grid-wrap") for i in range(a.shape[-1])], -1)


def encoder_image(maps: SurfaceMaps, side: int) -> np.ndarray:
    """(len(ENCODER_CHANNELS), ENCODER_SIZE, ENCODER_SIZE) float32: the maps of ``side`` at
    ENCODER_TEXELS texels a yarn, the repeat tiled over the image (cropped beyond 8 yarns)."""
    phi = 2.0 * np.pi * np.arange(HORIZON_AZIMUTHS) / HORIZON_AZIMUTHS
    hz, th = maps.horizon[side], maps.through[side]
    planes = np.stack([maps.coverage[side], maps.warp[side], maps.normal[side, ..., 0], maps.normal[side, ..., 1],
                       maps.height[side], maps.grooves[side, ..., 0], maps.grooves[side, ..., 1], hz.mean(axis=-1),
                       2.0 * (hz * np.cos(phi)).mean(axis=-1), 2.0 * (hz * np.sin(phi)).mean(axis=-1), th[..., 0],
                       th[..., 1:].mean(axis=-1)], axis=-1)
    small = _to_encoder_resolution(planes, maps.texels_per_yarn)
    rows = np.arange(ENCODER_SIZE) % small.shape[0]
    cols = np.arange(ENCODER_SIZE) % small.shape[1]
    return np.ascontiguousarray(small[rows][:, cols].transpose(2, 0, 1), dtype=np.float32)


def encoder_params(fabric: Fabric) -> np.ndarray:
    """(N_PARAMS,) float32: ENCODER_PARAMS scaled to [0, 1] over FIT_RANGES, and log2 of the
    repeat's wefts and warps over 3 (8 yarns → 1)."""
    values = []
    for key in ENCODER_PARAMS:
        lo, hi = FIT_RANGES[key]
        values.append((float(fabric.get(key)) - lo) / (hi - lo))
    n_e, n_a = fabric.shape
    values += [math.log2(n_e) / 3.0, math.log2(n_a) / 3.0]
    return np.asarray(values, dtype=np.float32)
