"""Yarn grid (Wu et al. 2025 §4.4): integral projections → yarn boundaries, pitch, yarn counts.

The integral projection of the rectified grey image along the warps (its column means, a
function of x) averages the weave pattern away and keeps what every row shares: the dark
gaps between neighbouring warps. Its valleys are the warp boundaries; likewise the row means
give the weft boundaries. The pitch along an axis is the period of that projection; the number
of yarns in the minimum repeat is the repeat (§4.3) divided by the pitch, a whole number.

Conventions: rows of the pattern are wefts, columns are warps; after rectification warps run
vertically, so the *warp* pitch is measured along x and the *weft* pitch along y.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from scipy.ndimage import maximum_filter


@dataclass(frozen=True)
class AxisGrid:
    """The yarns along one axis of the rectified image.

    Attributes
    ----------
    pitch_px : distance between neighbouring yarn centres (rectified px).
    strength : fraction of the projection's variance explained by folding it at the pitch
        (1: a perfectly periodic projection; noise: ≈ bins / length).
    contrast : standard deviation of the projection relative to that of the whole image
        (how much of the image's structure is a straight-yarn grid along this axis).
    bounds_px : (K,) positions of the yarn boundaries (valleys of the projection), ascending.
    """

    pitch_px: float
    strength: float
    contrast: float
    bounds_px: np.ndarray


@dataclass(frozen=True)
class Grid:
    """The yarn grid and the minimum repeat of a rectified weave photo (§4.3–4.4).

    Attributes
    ----------
    x, y : :class:`AxisGrid` of the warps (along x) and of the wefts (along y).
    repeat_px : (height, width) of the minimum repeat in rectified px.
    yarns : (wefts, warps) in the minimum repeat (a 2-yarn one that may be a grey 2/2 twill's
        half is given as 4: :func:`~weavecap.prepare.period.complement_repeats`).
    repeat_found : (along y, along x): whether the repeat showed, as a dip of the DMF or, where
        the photo holds it only once, in the lattice of interlacings; False means all the
        photo's whole yarns along that axis are used.
    origin_px : (y, x) of the top-left corner of one repeat (a pair of yarn boundaries).
    """

    x: AxisGrid
    y: AxisGrid
    repeat_px: tuple[float, float]
    yarns: tuple[int, int]
    repeat_found: tuple[bool, bool]
    origin_px: tuple[float, float]

    @property
    def pitch_px(self) -> tuple[float, float]:
        """(warp pitch along x, weft pitch along y), as in report.json."""
        return self.x.pitch_px, self.y.pitch_px

    def cells(self) -> tuple[np.ndarray, np.ndarray]:
        """Boundaries (rectified px) of the cells of one repeat: (yarns+1,) along y and along x."""
        ny, nx = self.yarns
        oy, ox = self.origin_px
        return oy + self.y.pitch_px * np.arange(ny + 1), ox + self.x.pitch_px * np.arange(nx + 1)

    def to_json(self) -> dict:
        """The ``grid`` part of report.json (plus extra keys the schema allows)."""
        return {
            "repeat_px": [round(float(v), 3) for v in self.repeat_px],
            "pitch_px": [round(float(v), 4) for v in self.pitch_px],
            "yarns": [int(v) for v in self.yarns],
            "repeat_found": [bool(v) for v in self.repeat_found],
            "origin_px": [round(float(v), 2) for v in self.origin_px],
            "strength": [round(self.y.strength, 4), round(self.x.strength, 4)],
            "weft_bounds_px": [round(float(v), 2) for v in self.y.bounds_px],
            "warp_bounds_px": [round(float(v), 2) for v in self.x.bounds_px],
        }


# ----------------------------------------------------------------------------- projections

def projection(grey: np.ndarray, *, axis: int) -> np.ndarray:
    """Integral projection: the mean of ``grey`` over ``axis`` (0: column means, f(x))."""
    return np.asarray(grey, np.float64).mean(axis=axis)


def folded_strength(profile: np.ndarray, period: float) -> float:
    """Fraction of the variance of ``profile`` explained by its mean over one ``period``.

    The profile is folded at the (possibly fractional) period into ``max(4, round(period))``
    phase bins; the result is the between-bin share of the variance, corrected for the share
    that pure noise would reach with that many bins.
    """
    p = np.asarray(profile, np.float64)
    p = p - p.mean()
    n = p.size
    var = float((p ** 2).mean())
    if var <= 0 or period <= 1 or n < 2 * period:
        return 0.0
    bins = int(np.clip(round(period), 4, 64))
    idx = np.floor((np.arange(n) % period) / period * bins).astype(int) % bins
    cnt = np.bincount(idx, minlength=bins)
    mean = np.bincount(idx, p, minlength=bins) / np.maximum(cnt, 1)
    explained = float((cnt * mean ** 2).sum() / n) / var
    chance = (bins - 1) / max(n - 1, 1)
    return float(max(0.0, (explained - chance) / (1 - chance)))


def _spectrum_peak(profile: np.ndarray, *, min_period: float, max_period: float) -> float | None:
    """Period (px) of the strongest spectral peak of a profile, weighted by frequency."""
    p = np.asarray(profile, np.float64)
    n = p.size
    p = (p - p.mean()) * np.hanning(n)
    pad = 1 << int(np.ceil(np.log2(n * 16)))
    power = np.abs(np.fft.rfft(p, pad)) ** 2
    f = np.fft.rfftfreq(pad)
    band = (f >= 1.0 / max_period) & (f <= 1.0 / min_period)
    if not np.any(band):
        return None
    score = np.where(band, power * f, 0.0)
    i = int(np.argmax(score))
    if score[i] <= 0:
        return None
    if 0 < i < len(score) - 1:
        a, b, c = np.log(score[i - 1:i + 2] + 1e-300)
        den = a - 2 * b + c
        if den < 0:
            return float(1.0 / (f[i] + 0.5 * (a - c) / den * (f[1] - f[0])))
    return float(1.0 / f[i])


def axis_pitch(profile: np.ndarray, *, min_period: float, max_period: float,
               octave_gain: float = 0.15) -> tuple[float | None, float]:
    """The yarn pitch of an integral projection, and how periodic the projection is at it.

    The frequency-weighted spectral peak gives a first period; a yarn whose cross-section
    shows two dips (a bright centre line, a split ply) puts its strongest peak at twice its
    frequency, so the period is doubled (or tripled) while that explains at least
    ``octave_gain`` more of the projection.

    Returns
    -------
    (pitch_px or None, strength) — see :func:`folded_strength`.
    """
    per = _spectrum_peak(profile, min_period=min_period, max_period=max_period)
    if per is None:
        return None, 0.0
    s = folded_strength(profile, per)
    for _ in range(2):
        options = [(folded_strength(profile, k * per), k) for k in (2, 3) if k * per <= max_period]
        if not options:
            break
        s2, k = max(options)
        if s2 - s < octave_gain:
            break
        per, s = per * k, s2
    return per, s


def refine_pitch(profile: np.ndarray, pitch: float, *, span: float = 0.04, steps: int = 81) -> float:
    """The period near ``pitch`` that best explains ``profile`` when folded (sub-pixel)."""
    cands = pitch * (1 + np.linspace(-span, span, steps))
    s = np.array([folded_strength(profile, c) for c in cands])
    i = int(np.argmax(s))
    if 0 < i < steps - 1:
        a, b, c = s[i - 1:i + 2]
        den = a - 2 * b + c
        if den < 0:
            return float(cands[i] + 0.5 * (a - c) / den * (cands[1] - cands[0]))
    return float(cands[i])


def boundaries(profile: np.ndarray, pitch: float, *, offset: float = 0.0,
               length: float | None = None) -> np.ndarray:
    """Yarn boundaries: the valleys of ``profile`` (a projection with the given pitch).

    The mean profile over one pitch gives the phase of the gap between yarns; each boundary
    is then moved to the nearest local minimum of the (lightly smoothed) profile within a
    quarter pitch, so that uneven spacing shows (the paper's "cells of varying widths").

    Parameters
    ----------
    profile : (L,) projection.
    pitch : its period (px).
    offset : added to every position (the profile's first sample in the output frame).
    length : extend the regular grid over ``[offset, offset + length)`` instead of the profile.

    Returns
    -------
    (K,) ascending boundary positions in the output frame.
    """
    p = np.asarray(profile, np.float64)
    n = p.size
    bins = int(np.clip(round(pitch * 2), 8, 128))
    idx = np.floor((np.arange(n) % pitch) / pitch * bins).astype(int) % bins
    mean = np.bincount(idx, p, minlength=bins) / np.maximum(np.bincount(idx, minlength=bins), 1)
    # circular smoothing of the mean yarn profile, then its minimum = the gap
    k = np.array([0.25, 0.5, 0.25])
    mean_s = np.convolve(np.concatenate([mean[-1:], mean, mean[:1]]), k, mode="valid")
    phase = (int(np.argmin(mean_s)) + 0.5) / bins * pitch
    ps = cv2.GaussianBlur(p.astype(np.float32)[None], (0, 0), max(0.5, pitch / 12))[0].astype(np.float64)
    total = float(n if length is None else length)
    pos = np.arange(phase - pitch * np.ceil(phase / pitch), total, pitch)
    pos = pos[(pos >= 0) & (pos < total)]
    out = []
    half = pitch / 4
    for x in pos:
        lo, hi = int(np.ceil(x - half)), int(np.floor(x + half))
        lo, hi = max(lo, 1), min(hi, n - 2)
        if lo <= hi and x < n:
            seg = np.arange(lo, hi + 1)
            j = int(seg[np.argmin(ps[seg])])
            if ps[j] <= ps[j - 1] and ps[j] <= ps[j + 1]:
                a, b, c = ps[j - 1:j + 2]
                den = a - 2 * b + c
                x = j + (0.5 * (a - c) / den if den > 0 else 0.0)
        out.append(x)
    return np.asarray(out, float) + offset


def refine_repeat(dmf: np.ndarray, pitch: float, yarns: int) -> float:
    """The repeat in pixels, refined over all its multiples in the superposed pixel DMF (§4.3).

    The m-th dip of a repeat of ``yarns`` yarns lies near ``m·yarns·pitch``; each dip is found
    within a fifth of a pitch and located to sub-pixel precision, and the repeat is the
    least-squares slope of the dips against m (the pitch alone, times ``yarns``, where no whole
    multiple fits in the DMF).

    Parameters
    ----------
    dmf : (L,) normalised superposed DMF (:func:`~weavecap.prepare.period.superposed_dmf`).
    pitch : yarn pitch along that axis (px).
    yarns : the repeat in yarns (:func:`~weavecap.prepare.period.cell_repeat`).
    """
    d = np.asarray(dmf, np.float64)
    L = len(d)
    w = max(1.0, 0.2 * pitch)
    ms, xs = [], []
    m = 1
    while m * yarns * pitch + w < L - 2:
        center = m * yarns * pitch
        lo, hi = max(1, int(np.floor(center - w))), min(L - 2, int(np.ceil(center + w)))
        seg = np.arange(lo, hi + 1)
        j = int(seg[np.argmin(d[seg])])
        a, b, c = d[j - 1:j + 2]
        den = a - 2 * b + c
        ms.append(m)
        xs.append(j + (float(np.clip(0.5 * (a - c) / den, -0.5, 0.5)) if den > 0 else 0.0))
        m += 1
    if not ms:
        return float(yarns * pitch)
    ms_, xs_ = np.array(ms, float), np.array(xs)
    return float((ms_ * xs_).sum() / (ms_ ** 2).sum())


def repeat_along(dmf: np.ndarray, pitch: float, *, max_yarns: int = 64, rel_tol: float = 1.6,
                 abs_tol: float = 0.04, min_depth: float = 0.3) -> tuple[int | None, float]:
    """The minimum repeat along one axis as a whole number of yarns, from the pixel DMF (§4.3).

    Where the cells of the yarn grid show no repeat (:func:`~weavecap.prepare.period.cell_repeat`:
    tiny or wavy yarns the cells do not follow), the superposed pixel DMF still dips at every
    whole number of repeats; only shifts that are whole numbers of yarns are candidates. The
    repeat is the fewest yarns (≥ 2: a weave interlaces) whose dip is about as deep as the
    deepest one (``d ≤ max(rel_tol·d*, d* + abs_tol)``).

    Parameters
    ----------
    dmf : (L,) normalised superposed DMF (≈ 1 for unrelated shifts, 0 for a perfect repeat).
    pitch : yarn pitch along that axis (px).

    Returns
    -------
    (yarns or None, depth): None when no dip reaches ``min_depth`` (the photo holds at most one
    repeat along this axis); :func:`refine_repeat` gives the repeat in pixels.
    """
    d = np.asarray(dmf, np.float64)
    L = len(d)
    nmax = min(max_yarns, int((L - 2) / pitch))
    if nmax < 2:
        return None, 0.0
    w = max(1.0, 0.2 * pitch)
    vals = np.array([d[max(1, int(np.floor(n * pitch - w))):min(L - 2, int(np.ceil(n * pitch + w))) + 1].min()
                     for n in range(1, nmax + 1)])
    best = float(vals[1:].min())
    if 1.0 - best < min_depth:
        return None, float(1.0 - best)
    limit = max(rel_tol * best, best + abs_tol)
    n = next(k for k in range(2, nmax + 1) if vals[k - 1] <= limit)
    return n, float(1.0 - vals[n - 1])


# ----------------------------------------------------------------------------- spectral lattice

def power_spectrum(grey: np.ndarray, *, max_side: int = 512) -> np.ndarray:
    """The power spectrum of the (square, centred, at most ``max_side``) crop of ``grey``,
    mean removed, Hann-windowed and zero-padded to twice its side, origin at the centre.

    Returns
    -------
    (2n, 2n) float64 array, n the crop's side: entry (c + v, c + u), c = n, is the power at
    (fx, fy) = (u, v) / (2n) cycles per pixel.
    """
    h, w = grey.shape
    n = int(min(h, w, max_side))
    g = np.asarray(grey, np.float64)[(h - n) // 2:(h - n) // 2 + n, (w - n) // 2:(w - n) // 2 + n]
    g = (g - g.mean()) * np.outer(np.hanning(n), np.hanning(n))
    return np.fft.fftshift(np.abs(np.fft.fft2(g, s=(2 * n, 2 * n))) ** 2)


def crossing_power(power: np.ndarray, pitch_x: float, pitch_y: float) -> float:
    """The power of the lattice of yarn crossings at its fundamental, (1/pitch_x, ±1/pitch_y).

    The gaps between warps and those between wefts cross once per cell of the yarn grid; each
    crossing is a hole (dark, or lit from behind), and the holes' lattice puts a peak at
    (1/pitch_x, ±1/pitch_y) whatever the weave. The strongest power within one natural bin of
    each of the two points, summed.

    Parameters
    ----------
    power : (2n, 2n) from :func:`power_spectrum`.
    pitch_x, pitch_y : yarn pitches (px) along x and y.
    """
    size = power.shape[0]
    c = size // 2
    total = 0.0
    for sign in (1, -1):
        ix, iy = int(round(c + size / pitch_x)), int(round(c + sign * size / pitch_y))
        win = power[max(0, iy - 2):iy + 3, max(0, ix - 2):ix + 3]
        total += float(win.max()) if win.size else 0.0
    return total


def crossing_pitches(power: np.ndarray, pitches: tuple[float, float], *, divisors: tuple[int, ...],
                     min_pitch: float, gain: float, min_share: float) -> tuple[tuple[int, int], float, float]:
    """Whether the projections' pitches are whole multiples of the yarns (§4.4): the divisor of
    each pitch whose lattice of yarn crossings is the strongest.

    A projection's period is the yarns' only where every yarn looks alike across the photo. A
    weave whose repeat sets the yarns' mean brightness apart makes its projection repeat over
    several yarns: a basket 2/2's pairs (a narrow gap between the yarns of a pair, a weaker
    peak at their pitch than at the pair's), a random weave's columns of floats (a 3×6 whose
    warp projection repeats over its 6 warps). The holes where the gaps cross do not care which
    yarn is on top: their lattice's fundamental (:func:`crossing_power`) is at the yarn pitch
    along both axes. A harmonic of the yarns (a bright centre line or a split ply, a half
    pitch) crosses no gap, so its crossing peak is weak, and a lattice of holes is never stronger
    at its own harmonics than at its fundamental: the divisors are only taken when their
    crossing power is at least ``gain`` times that of the projections' pitches and at least
    ``min_share`` of the spectrum's strongest peak (where floats cover the gaps, a satin, there
    are no holes, and the ratio of two faint points is noise).

    Parameters
    ----------
    power : (2n, 2n) from :func:`power_spectrum` of the rectified, lighting-flattened image.
    pitches : (along x, along y) the projections' pitches (px).
    divisors : divisors tried on each axis (1 is always tried).
    min_pitch : finest pitch (px) a divisor may give.
    gain : how much stronger the crossing peak must be to take a divisor.
    min_share : weakest crossing power taken, as a share of the spectrum's strongest peak.

    Returns
    -------
    ((dx, dy), ratio, share): the divisors (1, 1 when the pitches stand), the crossing power
    at the best divided pitches over that at the projections' pitches, and that power as a
    share of the strongest peak.
    """
    px, py = pitches
    base = crossing_power(power, px, py)
    best, best_c = (1, 1), base
    ds = (1,) + tuple(d for d in divisors if d > 1)
    for dx in ds:
        for dy in ds:
            if (dx, dy) == (1, 1) or px / dx < min_pitch or py / dy < min_pitch:
                continue
            c = crossing_power(power, px / dx, py / dy)
            if c > best_c:
                best, best_c = (dx, dy), c
    ratio = best_c / max(base, 1e-300)
    share = best_c / max(float(power.max()), 1e-300)
    return (best if ratio >= gain and share >= min_share else (1, 1)), ratio, share


def spectrum_peaks(grey: np.ndarray, *, count: int = 16, rel_floor: float = 0.01,
                   max_side: int = 512) -> np.ndarray:
    """The strongest peaks of the power spectrum of a rectified image, in one half-plane.

    Parameters
    ----------
    grey : (H, W) float array, rectified (yarns along the axes), lighting flattened.
    count : most peaks returned.
    rel_floor : weakest peak kept, relative to the strongest.
    max_side : side of the (square, centred) crop analysed.

    Returns
    -------
    (K, 3) array of (fx, fy, power), frequencies in cycles per pixel with fx ≥ 0 (sub-bin: a
    parabola through the log power along each axis), strongest first; peaks within two
    natural bins of the origin (the lighting) are left out.
    """
    power = power_spectrum(grey, max_side=max_side)
    size = power.shape[0]
    c = size // 2
    yy, xx = np.indices(power.shape)
    half = ((xx > c) | ((xx == c) & (yy > c))) & (np.hypot(yy - c, xx - c) > 4)
    # local maxima compared in the power's own precision: a float32 maximum against the float64
    # power drops every peak whose value rounds up, a coin toss that moved with library versions
    mx = maximum_filter(power, size=5, mode="wrap")
    top = float(power[half].max()) if np.any(half) else 0.0
    cand = np.argwhere(half & (power >= mx) & (power > rel_floor * top)) if top > 0 else np.empty((0, 2), int)
    cand = sorted(cand.tolist(), key=lambda p: -power[p[0], p[1]])[:count]
    lp = np.log(power + 1e-300)

    def sub(a: float, b: float, c_: float) -> float:  # parabola through the log power
        den = a - 2 * b + c_
        return float(np.clip(0.5 * (a - c_) / den, -0.5, 0.5)) if den < 0 else 0.0

    out = []
    for iy, ix in cand:
        dy = sub(lp[iy - 1, ix], lp[iy, ix], lp[(iy + 1) % size, ix]) if 0 < iy else 0.0
        dx = sub(lp[iy, ix - 1], lp[iy, ix], lp[iy, (ix + 1) % size]) if 0 < ix else 0.0
        out.append(((ix + dx - c) / size, (iy + dy - c) / size, power[iy, ix]))
    return np.array(out).reshape(-1, 3)


def _lattice_share(values: np.ndarray, weights: np.ndarray, unit: float, tol: float) -> float:
    """Power-weighted share of ``values`` lying within ``tol`` of a whole multiple of ``unit``.

    The tolerance is at most a quarter of the unit: within half a unit of a multiple lies every
    value, so a looser test could not fail (a 7-end repeat's lattice unit in a crop of under
    two repeats is a bin or so, the size of ``tol``; a 5-end count then passed on any peaks).
    """
    t = min(tol, unit / 4)
    off = np.abs(values / unit - np.round(values / unit)) * unit
    return float(weights[off <= t].sum() / max(float(weights.sum()), 1e-300))


def _off_axis(peaks: np.ndarray, tol: float) -> np.ndarray:
    """The peaks off both axes: those on an axis (the yarn frequencies, their harmonics,
    stripes) lie on every coarser lattice too; only the interlacings tell the repeat."""
    return peaks[(np.abs(peaks[:, 0]) > tol) & (np.abs(peaks[:, 1]) > tol)]


def lattice_yarns(peaks: np.ndarray, *, pitch: float, axis: int, max_yarns: int = 12, tol: float,
                  min_share: float = 0.85) -> int | None:
    """The repeat along one axis, in yarns, that the lattice of interlacings implies (§4.3).

    The weave repeats over n yarns along x exactly when its spectrum lies on the lines
    fx = m·k/n (k = 1/pitch, the yarn frequency): a translation by n·pitch then changes no
    Fourier component. The off-axis peaks are the interlacings' reciprocal lattice, whose
    basis vectors are the short steps between neighbouring interlacings (a satin's (1, s)),
    so the spectrum resolves these lines as soon as the crop spans about one repeat, where
    a DMF needs two to dip (:func:`~weavecap.prepare.period.cell_repeat` compares shifts
    up to half the cells).

    Parameters
    ----------
    peaks : (K, 3) from :func:`spectrum_peaks` (rectified image).
    pitch : yarn pitch (px) along ``axis``.
    axis : 0 for x (warps), 1 for y (wefts).
    tol : largest distance (cycles/px) of a peak from a lattice line (the spectral resolution).
    min_share : power share of the off-axis peaks that must lie on the lines.

    Returns
    -------
    The fewest yarns n ≤ ``max_yarns`` whose lines hold ``min_share`` of the off-axis peaks'
    power, or None (fewer than three off-axis peaks, or no such n).
    """
    peaks = _off_axis(peaks, tol)
    if len(peaks) < 3:
        return None
    w, v, k = peaks[:, 2], np.abs(peaks[:, axis]), 1.0 / pitch
    return next((m for m in range(1, max_yarns + 1) if _lattice_share(v, w, k / m, tol) >= min_share), None)


def lattice_pitch(peaks: np.ndarray, *, known_pitch: float, axis: int, max_yarns: int = 12,
                  tol: float, min_share: float = 0.85) -> tuple[float | None, float]:
    """The yarn pitch along an axis whose yarn boundaries do not show, from the weave's lattice.

    A satin's or a twill's floats can hide the boundaries between the yarns they float over
    (§4.4's projections are then flat along that axis), but not the interlacings: the peaks of
    the spectrum lie on the reciprocal lattice of the repeat, (a·u_x, b·u_y) with u = yarn
    frequency / yarns in the repeat. The known axis gives its yarn frequency k and the fewest
    yarns n with all strong peaks at multiples of k/n; the other axis's unit u is the largest
    one with all strong peaks at its multiples. The hidden yarn frequency is m·u, with m read
    off the peaks where the two families' gaps cross (:func:`_hidden_yarns`: a rib's 2 wefts
    over 8 warps has the lattice of a plain weave of warps four times as wide) or, where no
    crossing shows, m = n: a regular n-end satin or twill repeats over n yarns on both axes.

    Parameters
    ----------
    peaks : (K, 3) from :func:`spectrum_peaks` (rectified image).
    known_pitch : yarn pitch (px) along the other axis, measured from its projection.
    axis : the axis sought: 1 for y (wefts, pitch along y), 0 for x (warps).
    max_yarns : most yarns in the repeat tried.
    tol : largest distance (cycles/px) of a peak from a lattice line (the spectral resolution).
    min_share : power share of the off-axis peaks that must lie on the lattice.

    Returns
    -------
    (pitch_px or None, share): the power share of the off-axis peaks on the lattice found.
    """
    n = lattice_yarns(peaks, pitch=known_pitch, axis=1 - axis, max_yarns=max_yarns, tol=tol, min_share=min_share)
    if n is None or n < 2:
        return None, 0.0
    peaks = _off_axis(peaks, tol)
    w = peaks[:, 2]
    known = np.abs(peaks[:, 1 - axis])  # along the known axis: fx when y is sought
    sought = np.abs(peaks[:, axis])
    k = 1.0 / known_pitch
    units = sorted({float(v / m) for v in sought[sought > 2 * tol] for m in range(1, max_yarns + 1)}, reverse=True)
    for u in units:
        if u <= 2 * tol:
            break
        share = _lattice_share(sought, w, u, tol)
        if share >= min_share:
            u = _refine_unit(sought, w, u, tol)
            return 1.0 / (_hidden_yarns(known, sought, w, k=k, u=u, tol=tol, default=n) * u), share
    return None, 0.0


def _refine_unit(values: np.ndarray, weights: np.ndarray, unit: float, tol: float) -> float:
    """The lattice unit that puts the peaks on its multiples best: the power-weighted least
    squares slope of the peaks within ``tol`` of a multiple of ``unit`` against that multiple.

    ``unit`` is one of the peaks divided by a whole number, so it carries that one peak's error
    (a spectral bin of a small photo is a large share of a low frequency); every peak on the
    lattice counts in the slope.
    """
    m = np.round(values / unit)
    on = (m >= 1) & (np.abs(values - m * unit) <= min(tol, unit / 4))
    if not np.any(on):
        return unit
    return float((weights[on] * m[on] * values[on]).sum() / (weights[on] * m[on] ** 2).sum())


def _hidden_yarns(known: np.ndarray, sought: np.ndarray, w: np.ndarray, *, k: float, u: float, tol: float,
                  default: int) -> int:
    """How many yarns of the hidden axis one lattice unit holds (§4.4), from the gaps' crossings.

    Where the hidden yarns' gaps show at all (a rib's warps between its weft floats), they
    cross the known axis's gaps: a peak on the line of the known yarn frequency ``k``, at the
    hidden yarn frequency. The strongest peak on that line gives the count, rounded to whole
    multiples of the lattice unit ``u`` (of peaks within 10 % of its power, the lowest: a yarn
    frequency is a fundamental, its harmonics are no stronger). With no peak on that line, the repeat of a
    regular satin or twill is assumed: ``default`` (the known axis's count).

    Parameters
    ----------
    known, sought, w : (K,) |frequency| along the known and the hidden axis (cycles/px) and
        power of the off-axis peaks.
    k : the known axis's yarn frequency; u : the hidden axis's lattice unit (cycles/px).
    tol : largest distance (cycles/px) of a peak from the line.
    """
    line = (np.abs(known - k) <= tol) & (sought > 2 * tol)
    if not np.any(line):
        return default
    strong = line & (w >= 0.9 * w[line].max())
    return max(1, int(round(float(sought[strong].min()) / u)))


# ----------------------------------------------------------------------------- cells

def cell_features(image: np.ndarray, pitch_px: tuple[float, float], origin_px: tuple[float, float], *,
                  sub: int) -> np.ndarray:
    """What the weave sets in every whole cell of the yarn grid, as a vector (§4.3–4.4).

    Each cell is cut into ``sub × sub`` blocks; a block gives its mean colour and its mean
    absolute gradients along x and along y. The colours tell which yarn is on top where warps
    and wefts differ; the gradients tell it where they look alike: the yarn on top runs on
    through the crossing, so its edges do (a warp on top: edges along y, strong ∂/∂x). The
    first block is centred on the cell's corner: the boundaries are the projections' valleys,
    which are the gaps in a front-lit photo but the yarn centres where the gaps are lit from
    behind, and either way some block then holds a crossing rather than a gap.

    Parameters
    ----------
    image : (H, W, C) or (H, W) float array, rectified, lighting flattened, lightly smoothed.
    pitch_px : (warp pitch along x, weft pitch along y).
    origin_px : (y, x) of a cell corner (a pair of yarn boundaries).
    sub : blocks per cell side.

    Returns
    -------
    (Ny, Nx, sub·sub·(C + 2)) array: row i, column j is the cell of weft i and warp j.
    """
    img = np.asarray(image, np.float32)
    if img.ndim == 2:
        img = img[..., None]
    h, w, ch = img.shape
    px, py = pitch_px
    oy, ox = (origin_px[0] - py / (2 * sub)) % py, (origin_px[1] - px / (2 * sub)) % px
    nx, ny = int((w - ox) // px), int((h - oy) // py)
    y0, x0 = int(round(oy)), int(round(ox))
    y1, x1 = min(h, int(round(oy + ny * py))), min(w, int(round(ox + nx * px)))
    if nx < 1 or ny < 1 or y1 <= y0 or x1 <= x0:
        return np.zeros((max(ny, 0), max(nx, 0), sub * sub * (ch + 2)), np.float32)
    grey = img.mean(axis=2)
    grads = np.stack([np.abs(cv2.Sobel(grey, cv2.CV_32F, 1, 0)), np.abs(cv2.Sobel(grey, cv2.CV_32F, 0, 1))], axis=2)
    parts = []
    for layer in (img, grads):
        small = cv2.resize(np.ascontiguousarray(layer[y0:y1, x0:x1]), (nx * sub, ny * sub),
                           interpolation=cv2.INTER_AREA).reshape(ny, sub, nx, sub, -1)
        parts.append(small.transpose(0, 2, 1, 3, 4).reshape(ny, nx, -1))
    return np.concatenate(parts, axis=2)
