"""Minimum repeat size (Wu et al. 2025 §4.3): superposed distance matching functions.

The distance matching function (DMF) of a row r at shift τ is the mean squared difference
between r(x) and r(x + τ) [ANB12]. Summed over all rows (and, for the other axis, all
columns) it dips to ~0 at every whole number of repeats. The repeat is the shortest deep dip
with a sharp bottom (large second forward difference), refined to sub-pixel precision over
all its multiples. A photo that holds a single repeat has no dip; that is reported as such
rather than as an error.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class AxisPeriod:
    """The repeat along one image axis.

    Attributes
    ----------
    period_px : the repeat in pixels, or None when no repeat shows (a single repeat, or no
        periodic structure).
    depth : 1 - DMF(period) / plateau, in [0, 1]; 1 is a perfect repeat. 0 when None.
    dmf : (L,) the normalised superposed DMF (plateau ≈ 1) for shifts 0..L-1.
    """

    period_px: float | None
    depth: float
    dmf: np.ndarray


@dataclass(frozen=True)
class Period:
    """The minimum repeat: ``y`` (height, along columns) and ``x`` (width, along rows)."""

    y: AxisPeriod
    x: AxisPeriod

    @property
    def repeat_px(self) -> tuple[float | None, float | None]:
        return self.y.period_px, self.x.period_px


def superposed_dmf(img: np.ndarray, *, axis: int = 1, max_shift: int | None = None) -> np.ndarray:
    """The DMF of every row (axis=1) or column (axis=0), summed and normalised.

    Parameters
    ----------
    img : (H, W) float array.
    axis : 1 shifts along x (rows), 0 along y (columns).
    max_shift : largest shift; default half the length.

    Returns
    -------
    (max_shift + 1,) array: mean squared difference at each shift over the overlapping part,
    divided by twice the variance (so uncorrelated shifts give ≈ 1, a perfect repeat 0).
    """
    a = np.asarray(img, np.float64)
    if axis == 0:
        a = a.T
    a = a - a.mean()
    n = a.shape[1]
    m = n // 2 if max_shift is None else min(max_shift, n - 1)
    f = np.fft.rfft(a, n=2 * n, axis=1)
    corr = np.fft.irfft((f * np.conj(f)).sum(axis=0), n=2 * n)[: m + 1]  # Σ_rows Σ_x a(x)a(x+τ)
    sq = (a ** 2).sum(axis=0)
    cs = np.concatenate([[0.0], np.cumsum(sq)])
    tau = np.arange(m + 1)
    left = cs[n - tau] - cs[0]  # Σ a(x)^2 for x in [0, n-τ)
    right = cs[n] - cs[tau]  # Σ a(x+τ)^2
    count = a.shape[0] * (n - tau)
    d = (left + right - 2 * corr) / count
    var = float((a ** 2).mean())
    return d / (2 * var) if var > 0 else np.ones_like(d)


def _parabola_min(d: np.ndarray, i: int) -> float:
    if 0 < i < len(d) - 1:
        a, b, c = d[i - 1], d[i], d[i + 1]
        den = a - 2 * b + c
        if den > 0:
            return i + float(np.clip(0.5 * (a - c) / den, -0.5, 0.5))
    return float(i)


def axis_period(img: np.ndarray, *, axis: int, min_period: float = 3.0, min_depth: float = 0.35,
                tolerance: float = 0.15) -> AxisPeriod:
    """The minimum repeat of ``img`` along one axis (§4.3).

    Parameters
    ----------
    img : (H, W) float array, regularized or smoothed grey.
    axis : 1 for the width (shifts along x), 0 for the height.
    min_period : shortest repeat considered (px).
    min_depth : a dip counts when its depth (1 - DMF) reaches this.
    tolerance : among dips within ``tolerance`` of the deepest, the shortest wins (the others
        are its multiples).

    Returns
    -------
    :class:`AxisPeriod`.
    """
    d = superposed_dmf(img, axis=axis)
    lo = int(np.ceil(min_period))
    if len(d) < lo + 3:
        return AxisPeriod(None, 0.0, d)
    # local minima with their depth and the sharpness of their bottom (2nd forward difference)
    i = np.arange(lo, len(d) - 1)
    is_min = (d[i] <= d[i - 1]) & (d[i] <= d[i + 1])
    mins = i[is_min]
    if len(mins) == 0:
        return AxisPeriod(None, 0.0, d)
    # depth relative to the highest DMF value between the origin and the dip (the plateau)
    depth = np.array([1.0 - d[k] / max(d[1:k + 1].max(), 1e-12) for k in mins])
    ok = depth >= min_depth
    if not np.any(ok):
        return AxisPeriod(None, float(depth.max()), d)
    best = depth[ok].max()
    chosen = int(mins[ok][np.argmax(depth[ok] >= best - tolerance)])
    p0 = _parabola_min(d, chosen)
    # refine over multiples: the m-th dip lies at m·p
    ms, ps = [1.0], [p0]
    m = 2
    while m * p0 < len(d) - 2:
        c = int(round(m * p0))
        w = max(1, int(round(0.15 * p0)))
        seg = np.arange(max(lo, c - w), min(len(d) - 1, c + w + 1))
        k = int(seg[np.argmin(d[seg])])
        if 1.0 - d[k] / max(d[1:k + 1].max(), 1e-12) >= min_depth and 0 < k < len(d) - 1:
            ms.append(float(m))
            ps.append(_parabola_min(d, k))
        m += 1
    ms_, ps_ = np.array(ms), np.array(ps)
    period = float((ms_ * ps_).sum() / (ms_ ** 2).sum())
    return AxisPeriod(period, float(depth[list(mins).index(chosen)]), d)


def find_period(img: np.ndarray, *, min_period: float = 3.0, min_depth: float = 0.35,
                tolerance: float = 0.15) -> Period:
    """The minimum repeat of a rectified weave image along both axes (§4.3).

    Parameters
    ----------
    img : (H, W) float array: the rectified, illumination-flattened, smoothed grey image.

    Returns
    -------
    :class:`Period`; an axis whose ``period_px`` is None shows no repeat.
    """
    kw = dict(min_period=min_period, min_depth=min_depth, tolerance=tolerance)
    return Period(y=axis_period(img, axis=0, **kw), x=axis_period(img, axis=1, **kw))
