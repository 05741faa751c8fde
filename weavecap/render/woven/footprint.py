"""Box footprints on the periodic repeat: summed-area tables (Chen et al. 2024, Eq. 3's kernel).

A pixel sees a patch of the fabric; its value is the mean of the surface BSDF over that patch
(Eq. 3 with a box kernel — the render's film filter is a box). On a periodic map the mean over
*any* axis-aligned box, a fraction of a texel or many repeats wide, follows from one summed-area
table of one repeat: with ``S(x, y) = ∫₀^y ∫₀^x f`` over the repeat (texel units, ``f``
constant per texel, so ``S`` is exactly bilinear between texel corners) and ``x = q_x W + r_x``,

    S(x, y) = S(r_x, r_y) + q_x S(W, r_y) + q_y S(r_x, H) + q_x q_y S(W, H),

and a box's integral is ``S(x₁, y₁) - S(x₀, y₁) - S(x₁, y₀) + S(x₀, y₀)``. The image's mean
is taken out first (the table then stays near zero and float32 keeps its precision;
``S(W, H) = 0``). Coordinates: ``x`` along the map's columns (``u · W``), ``y`` along its rows
(down the image, ``(1 - v) · H``), texel ``(r, c)`` covering ``[c, c+1) × [r, r+1)``.

The training data (:mod:`weavecap.training.woven`) takes every footprint of one (ω_i, ω_o) pair from one table;
the renderer (:mod:`.infer`) looks up the tables of the map statistics (:func:`feature_image`)
the decoder is given.
"""

from __future__ import annotations

import math

import numpy as np

from ..surface import HORIZON_AZIMUTHS, SurfaceMaps

#: map statistics box-filtered over the footprint and given to the decoder (all weighted by
#: the coverage c): c, warp share, normal moments (first, second, warp's first), groove depths,
#: the horizon's mean and first harmonic in azimuth, the through map straight and tilted
MIN_HALF_TEXELS = 0.5  # smaller boxes are points (and float32 tables lose precision below)
FEATURES = ("c", "c_warp", "c_nx", "c_ny", "c_nxx", "c_nyy", "c_nxy", "c_warp_nx", "c_warp_ny", "c_groove_p",
            "c_groove_f", "c_horizon", "c_horizon_cos", "c_horizon_sin", "c_through", "c_through_tilted")


def feature_image(maps: SurfaceMaps, side: int) -> np.ndarray:
    """(H, W, len(FEATURES)) float32: the per-texel statistics of :data:`FEATURES` on ``side``."""
    c = maps.coverage[side].astype(np.float64)
    w = maps.warp[side]
    nx, ny = maps.normal[side, ..., 0], maps.normal[side, ..., 1]
    gp, gf = maps.grooves[side, ..., 0], maps.grooves[side, ..., 1]
    phi = 2.0 * np.pi * np.arange(HORIZON_AZIMUTHS) / HORIZON_AZIMUTHS
    hz = maps.horizon[side]
    th = maps.through[side]
    stats = [np.ones_like(c), w, nx, ny, nx * nx, ny * ny, nx * ny, w * nx, w * ny, gp, gf, hz.mean(axis=-1),
             (hz * np.cos(phi)).mean(axis=-1) * 2.0, (hz * np.sin(phi)).mean(axis=-1) * 2.0, th[..., 0],
             th[..., 1:].mean(axis=-1)]
    return np.stack([c * s for s in stats], axis=-1).astype(np.float32)


def periodic_sat(image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Summed-area table of a periodic image with its mean taken out.

    Parameters
    ----------
    image : (..., H, W, C) values per texel

    Returns
    -------
    sat : (..., H + 1, W + 1, C) float64, ``sat[..., i, j, :] = Σ_{r<i, c<j} (f - mean)``
    mean : (..., C) float64
    """
    f = np.asarray(image, dtype=np.float64)
    mean = f.mean(axis=(-3, -2))
    g = f - mean[..., None, None, :]
    sat = np.zeros(f.shape[:-3] + (f.shape[-3] + 1, f.shape[-2] + 1, f.shape[-1]))
    sat[..., 1:, 1:, :] = g.cumsum(axis=-3).cumsum(axis=-2)
    return sat, mean


def _bilinear(sat: np.ndarray, lead: tuple, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``sat`` (..., H+1, W+1, C) at real (x, y) in [0, W] × [0, H], bilinearly; ``lead``
    indexes the leading dimensions per query."""
    h, w = sat.shape[-3] - 1, sat.shape[-2] - 1
    x0 = np.clip(np.floor(x).astype(np.int64), 0, w - 1)
    y0 = np.clip(np.floor(y).astype(np.int64), 0, h - 1)
    fx = (x - x0)[..., None]
    fy = (y - y0)[..., None]
    s00 = sat[lead + (y0, x0)]
    s01 = sat[lead + (y0, x0 + 1)]
    s10 = sat[lead + (y0 + 1, x0)]
    s11 = sat[lead + (y0 + 1, x0 + 1)]
    return (s00 * (1 - fx) + s01 * fx) * (1 - fy) + (s10 * (1 - fx) + s11 * fx) * fy


def _extended(sat: np.ndarray, lead: tuple, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The periodic extension of the (zero-mean) table at any real (x, y)."""
    h, w = sat.shape[-3] - 1, sat.shape[-2] - 1
    qx, rx = np.floor(x / w), x - np.floor(x / w) * w
    qy, ry = np.floor(y / h), y - np.floor(y / h) * h
    full_x = np.full_like(rx, float(w))
    full_y = np.full_like(ry, float(h))
    return (_bilinear(sat, lead, rx, ry) + qx[..., None] * _bilinear(sat, lead, full_x, ry)
            + qy[..., None] * _bilinear(sat, lead, rx, full_y))


def box_mean(sat: np.ndarray, mean: np.ndarray, x: np.ndarray, y: np.ndarray, half: np.ndarray,
             lead: tuple = ()) -> np.ndarray:
    """Means over square boxes of the periodic image of :func:`periodic_sat`.

    Parameters
    ----------
    sat, mean : from :func:`periodic_sat`
    x, y : (Q,) box centres, texel units (any real values: the image repeats)
    half : (Q,) half the box side, texels (> 0)
    lead : index arrays (Q,) into ``sat``'s leading dimensions (e.g. the direction pair)

    Returns
    -------
    (Q, C) float64
    """
    half = np.maximum(np.asarray(half, dtype=np.float64), 1e-6)
    x0, x1, y0, y1 = x - half, x + half, y - half, y + half
    total = (_extended(sat, lead, x1, y1) - _extended(sat, lead, x0, y1) - _extended(sat, lead, x1, y0)
             + _extended(sat, lead, x0, y0))
    m = mean[lead] if lead else np.broadcast_to(mean, total.shape)
    return m + total / (4.0 * half * half)[..., None]


def periodic_bilinear(image: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """(Q, C) a periodic (H, W, C) image interpolated bilinearly at texel coordinates (x, y)
    (texel centres at half-integers), as a wrapping linear texture lookup does."""
    h, w = image.shape[:2]
    gx, gy = np.asarray(x, dtype=np.float64) - 0.5, np.asarray(y, dtype=np.float64) - 0.5
    x0, y0 = np.floor(gx), np.floor(gy)
    fx, fy = (gx - x0)[:, None], (gy - y0)[:, None]
    c0, r0 = x0.astype(np.int64) % w, y0.astype(np.int64) % h
    c1, r1 = (c0 + 1) % w, (r0 + 1) % h
    img = np.asarray(image, dtype=np.float64)
    return ((img[r0, c0] * (1 - fx) + img[r0, c1] * fx) * (1 - fy) + (img[r1, c0] * (1 - fx) + img[r1, c1] * fx) * fy)


def footprint_features(image: np.ndarray, sat: np.ndarray, mean: np.ndarray, x: np.ndarray, y: np.ndarray,
                       half: np.ndarray) -> np.ndarray:
    """(Q, C) a footprint's map statistics: the box mean (:func:`box_mean`) for boxes at least
    MIN_HALF_TEXELS texels in half-side, the image interpolated at the centre for smaller ones
    (a point: what the reference's linear lookups see there). The renderer does the same."""
    half = np.asarray(half, dtype=np.float64)
    out = box_mean(sat, mean, x, y, np.maximum(half, MIN_HALF_TEXELS))
    small = half < MIN_HALF_TEXELS
    if small.any():
        out[small] = periodic_bilinear(image, np.asarray(x)[small], np.asarray(y)[small])
    return out


def fabric_to_texel(s: np.ndarray, t: np.ndarray, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Fabric coordinates (s along +u, t along +v, in repeats) → texel coordinates (x, y) of
    a map of ``shape`` (H, W) (rows run down from v = 1)."""
    h, w = shape
    return np.asarray(s) * w, -np.asarray(t) * h


def filtered_point(features: list):
    """The surface point (:class:`.terms.ValuesPoint`) of a footprint's mean maps, from its
    :data:`FEATURES` (Dr.Jit Floats): coverage, warp share, normal, grooves as means (the
    c-weighted means over c), horizon from its mean and first harmonic, through straight and
    (the same in every azimuth) tilted; gain 1."""
    from . import terms as _terms

    mi, dr = _terms._backend()
    f = dict(zip(FEATURES, features))
    c = dr.clip(f["c"], 0.0, 1.0)
    inv = dr.select(c > 1e-6, 1.0 / dr.maximum(f["c"], 1e-6), 0.0)
    nx, ny = f["c_nx"] * inv, f["c_ny"] * inv
    normal = dr.normalize(mi.Vector3f(nx, ny, dr.sqrt(dr.maximum(1.0 - nx * nx - ny * ny, 1e-4))))
    k = HORIZON_AZIMUTHS
    hbar, hc, hs = f["c_horizon"] * inv, f["c_horizon_cos"] * inv, f["c_horizon_sin"] * inv
    horizon = [dr.clip(hbar + hc * math.cos(2 * math.pi * j / k) + hs * math.sin(2 * math.pi * j / k), 0.0, 1.0)
               for j in range(k)]
    tilted = dr.clip(f["c_through_tilted"] * inv, 0.0, 1.0)
    through = [dr.clip(f["c_through"] * inv, 0.0, 1.0)] + [tilted] * k
    return _terms.values_point(coverage=c, warp=dr.clip(f["c_warp"] * inv, 0.0, 1.0), normal=normal,
                               groove=(dr.clip(f["c_groove_p"] * inv, 0.0, 1.0),
                                       dr.clip(f["c_groove_f"] * inv, 0.0, 1.0)),
                               occlusion=mi.Float(1.0), through=through, horizon=horizon, gain=mi.Float(1.0))


def baseline_channels(shading, features: list, wi, wo) -> list:
    """The 14 :data:`~.terms.CHANNELS` (Dr.Jit Floats) of the surface model evaluated once at
    the footprint's mean maps (:func:`filtered_point`): exact for a point, a mean-normal
    (prefiltered) guess for a large footprint. The decoder learns the correction to it."""
    from . import terms as _terms

    point = filtered_point(features)
    w = point.warp
    out = []
    for term in _terms.point_terms(shading, point, wi, wo):
        out += [term * w, term * (1.0 - w)]
    return out
