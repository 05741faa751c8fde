"""The colour repeat of a rectified weave photo: how the yarns' colours repeat along each axis.

A yarn-dyed stripe or check repeats its colours over its own number of yarns, which is
neither the yarn pitch nor the weave's repeat (a plain weave in a 24-end check). Preparation
keeps the three apart: the grid (§4.4) gives the yarns, the cell DMF (§4.3) the weave's
repeat, and this module the colour repeat — the period of the sequence of the yarns' mean
colours along each axis, with one mean colour per yarn of that period (the thread colours
of a draft, for :mod:`weavecap.export` and the fit's colours).

A yarn's mean colour is taken over its whole strip of the rectified photo (it passes over and
under the other family alike, so the other family's colour is common to all strips of a
regular weave); the drift of the lighting across the photo is removed first. Where the weave
itself sets strips apart (a basket's pairs, a random weave's columns of floats) the colour
repeat is a multiple of the weave's.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: two colours closer than this CIEDE2000 difference count as one: about the smallest
#: difference a person sees between two patches side by side
JUST_NOTICEABLE_DE = 2.0


@dataclass(frozen=True)
class ColourRepeat:
    """How the yarns' colours repeat (Wu et al. 2025 §4.3's repeat, for colour instead of weave).

    Attributes
    ----------
    yarns : (wefts, warps): the colour repeat in yarns along y and along x; 1 where every
        yarn of the family looks alike.
    weft_colours : (yarns[0], 3) linear RGB, the mean colour of each weft of one colour repeat,
        the first being the weft whose strip starts at the grid's origin (``Grid.origin_px``).
    warp_colours : (yarns[1], 3) linear RGB, likewise for the warps.
    spread_de : (wefts, warps): the largest CIEDE2000 difference between two yarns' colours
        of one repeat (0 for a single colour).
    """

    yarns: tuple[int, int]
    weft_colours: np.ndarray
    warp_colours: np.ndarray
    spread_de: tuple[float, float]

    def to_json(self) -> dict:
        return {"yarns": [int(v) for v in self.yarns],
                "weft_rgb": np.round(self.weft_colours, 4).tolist(), "warp_rgb": np.round(self.warp_colours, 4).tolist(),
                "spread_de": [round(float(v), 2) for v in self.spread_de]}


def strip_means(image: np.ndarray, pitch: float, origin: float, *, axis: int) -> np.ndarray:
    """Mean colour of each whole strip of one yarn along ``axis`` (1: warps, strips along x;
    0: wefts, strips along y), with the lighting's drift across the strips (a quadratic)
    divided out per channel.

    Returns
    -------
    (N, 3) linear RGB, N the whole strips from ``origin`` (taken modulo the pitch).
    """
    img = np.asarray(image, np.float64)
    prof = img.mean(axis=0 if axis == 1 else 1)  # (L, 3): mean over the other axis
    start = origin % pitch
    n = int((prof.shape[0] - start) // pitch)
    if n < 1:
        return np.empty((0, 3))
    edges = np.round(start + pitch * np.arange(n + 1)).astype(int)
    means = np.array([prof[a:b].mean(axis=0) for a, b in zip(edges[:-1], edges[1:])])
    if n >= 4:
        t = np.linspace(-1, 1, n)
        basis = np.stack([np.ones(n), t, t * t], axis=1)
        coef, *_ = np.linalg.lstsq(basis, means, rcond=None)
        trend = basis @ coef
        means = means * np.maximum(coef[0], 1e-9) / np.maximum(trend, 1e-9)
    return means


def _lab(rgb: np.ndarray) -> np.ndarray:
    """CIELAB of linear RGB colours (N, 3), the brightest channel of all taken as white."""
    from skimage.color import rgb2lab

    from ..photo import linear_to_srgb

    m = np.asarray(rgb, np.float64)
    return rgb2lab(np.clip(linear_to_srgb(m / max(float(m.max()), 1e-9)), 0, 1)[None])[0]


def colour_period(means: np.ndarray, *, max_period: int | None = None) -> tuple[int, np.ndarray]:
    """The colour repeat of a sequence of yarn colours and one mean colour per position.

    The repeat is the fewest yarns n after which every yarn matches the yarn n on (a stripe
    boundary is two pairs in a whole repeat, so the test is on the pairs that differ most: the
    95th percentile of the CIEDE2000 between yarns n apart), as well as after any shift up to
    half the yarns, within :data:`JUST_NOTICEABLE_DE`: 1 where all yarns look alike.

    Returns
    -------
    (n, colours): colours is (n, 3) linear RGB, the mean of the yarns at each position.
    """
    from skimage.color import deltaE_ciede2000

    m = np.asarray(means, np.float64)
    count = len(m)
    if count < 2:
        return 1, m[:1].copy() if count else np.zeros((1, 3))
    lab = _lab(m)
    limit = max(1, min(max_period or count // 2, count // 2))
    d = np.array([float(np.percentile(deltaE_ciede2000(lab[:-k], lab[k:]), 95)) for k in range(1, limit + 1)])
    n = next(k for k in range(1, limit + 1) if d[k - 1] <= d.min() + JUST_NOTICEABLE_DE)
    colours = np.array([m[i::n].mean(axis=0) for i in range(n)])
    return n, colours


def colour_repeat(image: np.ndarray, pitch_px: tuple[float, float], origin_px: tuple[float, float]) -> ColourRepeat:
    """The colour repeat of a rectified photo on its yarn grid.

    Parameters
    ----------
    image : (H, W, 3) rectified photo, linear RGB.
    pitch_px : (warp pitch along x, weft pitch along y), rectified px.
    origin_px : (y, x) of a cell corner of the grid (``Grid.origin_px``).
    """
    from skimage.color import deltaE_ciede2000

    out, spread = [], []
    for axis, pitch, origin in ((0, pitch_px[1], origin_px[0]), (1, pitch_px[0], origin_px[1])):
        n, colours = colour_period(strip_means(image, pitch, origin, axis=axis))
        out.append((n, colours))
        lab = _lab(colours)
        spread.append(max((float(deltaE_ciede2000(a, b)) for i, a in enumerate(lab) for b in lab[i + 1:]), default=0.0))
    (ne, weft), (na, warp) = out
    return ColourRepeat(yarns=(ne, na), weft_colours=weft, warp_colours=warp, spread_de=(spread[0], spread[1]))
