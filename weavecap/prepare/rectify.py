"""Rectification (Wu et al. 2025 §4.1): turn the photo so warps run vertically, undo perspective.

Three steps, each a plain function:

1. :func:`coarse_pitch` — the finest strong period of the texture (radial power spectrum of
   a centre crop), only to choose working resolutions.
2. :func:`estimate_perspective` — the auto-rectification of pitch and yaw. The paper uses the
   RANSAC line-segment method of Chaudhury et al. [CDI14]; on a weave close-up the "segments"
   are the yarn lattice itself, so the local lattice is measured directly: the frequency of
   a few spectral peaks in overlapping tiles (each peak a family of parallel lines, i.e. a
   vanishing direction plus a spacing), then a homography whose Jacobian makes every tile's
   lattice the same is fitted by RANSAC over tiles and refined by least squares.
3. :func:`dominant_angles` — the Radon transform of the Laplacian-filtered image (the
   Laplacian keeps yarn edges and drops the broad angular features of highlights): the two
   yarn directions are the pair of angles, 90° apart up to a little skew, whose projections
   vary most (among pairs about equally strong, the one nearest the image axes: a twill's
   diagonal can rival the yarns), found coarse to fine with a parabolic peak fit.

:func:`rectify` chains them and returns the 3×3 homography from input pixels to rectified
pixels (turn, skew and perspective, plus the resampling to a pitch-based resolution) and the
rectified image.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np
from scipy.optimize import least_squares
from skimage.transform import radon

from .config import PrepareConfig
from .illumination import colour_blind, flatten_illumination, luminance


@dataclass(frozen=True)
class Rectification:
    """The result of :func:`rectify`.

    Attributes
    ----------
    rotation_deg : the turn (degrees, counter-clockwise positive with image y down) that makes
        warps run vertically, |rotation_deg| ≤ 45.
    homography : (3, 3) float64, input pixel (x, y, 1) → rectified pixel (pixel centres at
        integer coordinates).
    image : (h, w, 3) float32 linear RGB, the rectified photo.
    scale : rectified pixels per input pixel at the photo centre.
    coarse_pitch_px : the dominant texture period in input pixels (a first estimate).
    perspective : relative change of scale across the photo that was undone (0: none).
    skew_deg : departure from 90° of the yarn directions as found in the photo.
    """

    rotation_deg: float
    homography: np.ndarray
    image: np.ndarray
    scale: float
    coarse_pitch_px: float
    perspective: float
    skew_deg: float
    notes: dict = field(default_factory=dict)


# ----------------------------------------------------------------------------- helpers

def _centred(shape: tuple[int, int]) -> np.ndarray:
    """Translation taking pixel coordinates to coordinates centred on the image."""
    h, w = shape
    return np.array([[1, 0, -(w - 1) / 2], [0, 1, -(h - 1) / 2], [0, 0, 1]], float)


def _scaling(s: float) -> np.ndarray:
    return np.diag([s, s, 1.0])


def _hann2(n: int) -> np.ndarray:
    w = np.hanning(n).astype(np.float32)
    return np.outer(w, w)


def _standardise(grey: np.ndarray) -> np.ndarray:
    g = grey - float(np.mean(grey))
    sd = float(np.std(g))
    return (g / sd if sd > 0 else g).astype(np.float32)


def _subbin(m: np.ndarray, iy: int, ix: int) -> tuple[float, float]:
    """Sub-bin peak position by a parabola through the log magnitude, per axis."""
    h, w = m.shape

    def par(a, b, c):
        den = a - 2 * b + c
        return 0.0 if den >= 0 else float(np.clip(0.5 * (a - c) / den, -0.5, 0.5))

    lm = np.log(m + 1e-12)
    dy = par(lm[(iy - 1) % h, ix], lm[iy, ix], lm[(iy + 1) % h, ix])
    dx = par(lm[iy, (ix - 1) % w], lm[iy, ix], lm[iy, (ix + 1) % w])
    return iy + dy, ix + dx


# ----------------------------------------------------------------------------- coarse pitch

def coarse_pitch(grey: np.ndarray, *, crop_px: int = 768, min_period_px: float = 2.0,
                 rel_floor: float = 0.2, noise_floor: float = 6.0) -> float | None:
    """The finest strong period of a texture, in pixels: a first guess at the yarn pitch.

    The yarns are the finest periodic structure of a weave; a twill's diagonal, a satin's
    lattice of interlacings or a colour stripe have longer periods and are often stronger.
    So the result is the *shortest* period among the peaks of the radially averaged power
    spectrum (weighted by frequency squared, i.e. energy per octave) that reach ``rel_floor``
    of the strongest one and ``noise_floor`` times the spectrum's median (JPEG blocks, fibre
    noise and grain are broad, not peaked). It only chooses working resolutions (§4.1); the
    pitch itself is measured later from the integral projections (§4.4).

    Parameters
    ----------
    grey : (H, W) float array, linear grey.
    crop_px : side of the centre crop analysed.
    min_period_px : shortest period considered.
    rel_floor, noise_floor : how strong a peak must be, relative to the strongest peak and to
        the median of the weighted spectrum.

    Returns
    -------
    The period (px), or None when the image is too small or flat.
    """
    h, w = grey.shape
    n = int(min(h, w, crop_px))
    if n < 32:
        return None
    y0, x0 = (h - n) // 2, (w - n) // 2
    g = grey[y0:y0 + n, x0:x0 + n].astype(np.float32)
    g, _ = flatten_illumination(g, sigma_px=n / 12)
    g = _standardise(g)
    if not np.any(g):
        return None
    spec = np.abs(np.fft.fftshift(np.fft.fft2(g * _hann2(n)))) ** 2
    yy, xx = np.indices(spec.shape)
    r = np.hypot(yy - n // 2, xx - n // 2)
    ri = np.round(r).astype(int)
    radial = np.bincount(ri.ravel(), spec.ravel()) / np.maximum(np.bincount(ri.ravel()), 1)
    k = np.arange(radial.size, dtype=float)
    lo, hi = 4, int(n / min_period_px)  # at least 4 periods in the crop
    if hi <= lo + 2:
        return None
    score = radial[lo:hi] * k[lo:hi] ** 2  # energy per octave, favours the fine yarn structure
    score = np.convolve(score, [0.25, 0.5, 0.25], mode="same")
    peaks = [j for j in range(1, len(score) - 1) if score[j] >= score[j - 1] and score[j] >= score[j + 1]]
    floor = max(rel_floor * float(score.max()), noise_floor * float(np.median(score)))
    strong = [j for j in peaks if score[j] >= floor]
    j = max(strong) if strong else int(np.argmax(score))
    i = float(j + lo)
    if 0 < j < len(score) - 1:
        a, b, c = score[j - 1], score[j], score[j + 1]
        den = a - 2 * b + c
        i = i + (0.5 * (a - c) / den if den < 0 else 0.0)
    return float(n / i)


# ----------------------------------------------------------------------------- perspective

def _tile_spectra(img: np.ndarray, tile: int) -> tuple[np.ndarray, np.ndarray]:
    """Centres (N, 2) as (x, y) and magnitude spectra (N, 2t, 2t) of overlapping tiles."""
    h, w = img.shape
    step = tile // 2
    ys = list(range(0, h - tile + 1, step))
    xs = list(range(0, w - tile + 1, step))
    win = _hann2(tile)
    centres, specs = [], []
    for y in ys:
        for x in xs:
            t = img[y:y + tile, x:x + tile]
            t = (t - t.mean()) * win
            specs.append(np.abs(np.fft.fft2(t, s=(2 * tile, 2 * tile))).astype(np.float32))
            centres.append((x + (tile - 1) / 2, y + (tile - 1) / 2))
    return np.array(centres, float), np.array(specs)


def _pick_peaks(spec: np.ndarray, *, count: int, min_period: float, max_period: float,
                rel_floor: float = 0.3) -> list[tuple[int, int]]:
    """The strongest local maxima of a (2t, 2t) magnitude spectrum in one half-plane.

    Peaks nearly collinear with a stronger one (its harmonics) are skipped; peaks weaker than
    ``rel_floor`` times the strongest are not tracked beyond the first two.
    """
    n = spec.shape[0]
    f = np.fft.fftfreq(n)
    fy, fx = np.meshgrid(f, f, indexing="ij")
    rad = np.hypot(fx, fy)
    half = (fy > 0) | ((fy == 0) & (fx > 0))
    band = half & (rad <= 1 / min_period) & (rad >= 1 / max_period)
    mx = cv2.dilate(spec, np.ones((3, 3), np.uint8))
    cand = np.argwhere(band & (spec >= mx) & (spec > 0))
    cand = sorted(cand.tolist(), key=lambda p: -spec[p[0], p[1]])
    chosen: list[tuple[int, int]] = []
    for iy, ix in cand:
        k = np.array([fx[iy, ix], fy[iy, ix]])
        ok = True
        for jy, jx in chosen:
            k2 = np.array([fx[jy, jx], fy[jy, jx]])
            cosang = abs(k @ k2) / (np.linalg.norm(k) * np.linalg.norm(k2))
            if cosang > np.cos(np.deg2rad(12)) :  # a harmonic or neighbour of one already chosen
                ok = False
                break
        if ok and len(chosen) >= 2 and spec[iy, ix] < rel_floor * spec[chosen[0][0], chosen[0][1]]:
            break
        if ok:
            chosen.append((iy, ix))
        if len(chosen) == count:
            break
    return chosen


def _freq(n: int, iy: float, ix: float) -> np.ndarray:
    """Cycles per pixel (fx, fy) of a (possibly fractional) bin of an n×n FFT."""
    fy = iy / n if iy < n / 2 else iy / n - 1
    fx = ix / n if ix < n / 2 else ix / n - 1
    return np.array([fx, fy])


def _predict(params: np.ndarray, xy: np.ndarray, n_peaks: int) -> np.ndarray:
    """Local frequencies (T, P, 2) under H(x) = x / (1 + g·x) for rectified frequencies q."""
    g = params[:2]
    q = params[2:].reshape(n_peaks, 2)
    s = 1 + xy @ g  # (T,)
    # J = I/s - x g^T / s^2 ; k = J^T q = q/s - g (x·q)/s^2
    xq = xy @ q.T  # (T, P)
    return q[None] / s[:, None, None] - g[None, None] * (xq / s[:, None] ** 2)[..., None]


def estimate_perspective(img: np.ndarray, *, tile: int, peaks: int = 3, iterations: int = 60,
                         threshold: float = 0.02, min_tiles: int = 6, min_period: float = 2.5,
                         seed: int = 0) -> tuple[np.ndarray, dict]:
    """The projective part of the photo's distortion, from how the local lattice changes.

    Parameters
    ----------
    img : (H, W) float array, illumination-flattened grey.
    tile : tile side in pixels (tiles overlap by half).
    peaks : number of spectral peaks (line families) tracked from the centre outwards.
    iterations, threshold : RANSAC over tiles; ``threshold`` is the relative frequency error
        of an inlier tile.
    min_tiles : fewest inlier tiles for a result.

    Returns
    -------
    h_rel : (3, 3) homography in coordinates centred on the image, of the form
        x ↦ x / (1 + g·x): identity Jacobian at the centre, so it changes neither the turn nor
        the scale there. The identity when nothing reliable was found.
    info : dict with ``tiles`` (used), ``inliers``, ``g`` and ``change`` (relative scale
        change across the image).
    """
    h, w = img.shape
    eye = np.eye(3)
    if min(h, w) < 2 * tile:
        return eye, {"tiles": 0, "reason": "image too small for tiles"}
    centres, specs = _tile_spectra(img, tile)
    n = 2 * tile
    xy = centres - np.array([(w - 1) / 2, (h - 1) / 2])
    order = np.argsort(np.hypot(*xy.T))
    c0 = order[0]
    near = order[: min(9, len(order))]
    mean_spec = specs[near].mean(0)
    chosen = _pick_peaks(mean_spec, count=peaks, min_period=min_period, max_period=tile / 3)
    if len(chosen) < 2:
        return eye, {"tiles": 0, "reason": "fewer than two spectral peaks"}
    p = len(chosen)
    k_meas = np.full((len(centres), p, 2), np.nan)
    ref_mag = np.array([mean_spec[iy, ix] for iy, ix in chosen])
    fgrid = np.fft.fftfreq(n)
    # breadth-first from the centre: each tile searches near its nearest measured neighbour
    done: list[int] = []
    for t in order:
        for j, (iy0, ix0) in enumerate(chosen):
            if done:
                d = np.hypot(*(centres[done] - centres[t]).T)
                cand = [done[i] for i in np.argsort(d) if np.isfinite(k_meas[done[i], j, 0])]
                k_pred = k_meas[cand[0], j] if cand else _freq(n, iy0, ix0)
            else:
                k_pred = _freq(n, iy0, ix0)
            cy, cx = k_pred[1] * n, k_pred[0] * n
            r = max(1.5, 0.06 * np.hypot(cx, cy))
            iy_lo, iy_hi = int(np.floor(cy - r)), int(np.ceil(cy + r))
            ix_lo, ix_hi = int(np.floor(cx - r)), int(np.ceil(cx + r))
            sub = specs[t][np.ix_(np.arange(iy_lo, iy_hi + 1) % n, np.arange(ix_lo, ix_hi + 1) % n)]
            a = np.unravel_index(int(np.argmax(sub)), sub.shape)
            iy, ix = (iy_lo + a[0]) % n, (ix_lo + a[1]) % n
            if specs[t][iy, ix] < 0.3 * ref_mag[j]:
                continue
            fy_, fx_ = _subbin(specs[t], iy, ix)
            k = np.array([fgrid[ix] + (fx_ - ix) / n, fgrid[iy] + (fy_ - iy) / n])
            k_meas[t, j] = k
        done.append(int(t))
    good = np.all(np.isfinite(k_meas[..., 0]), axis=1)
    idx = np.flatnonzero(good)
    if len(idx) < min_tiles or not good[c0]:
        return eye, {"tiles": int(len(idx)), "reason": "too few tiles with a clear lattice"}
    q0 = k_meas[c0]
    scale_xy = float(max(h, w))
    xs = xy / scale_xy  # keep the unknowns well scaled

    def resid(params, sel):
        pr = _predict(params, xs[sel], p)
        return ((pr - k_meas[sel]) / np.linalg.norm(params[2:].reshape(p, 2), axis=1)[None, :, None]).ravel()

    def fit(sel, loss="linear"):
        x0 = np.concatenate([[0.0, 0.0], q0.ravel()])
        r = least_squares(resid, x0, args=(sel,), loss=loss, f_scale=threshold)
        return r.x

    def tile_err(params):
        pr = _predict(params, xs[idx], p)
        e = np.linalg.norm(pr - k_meas[idx], axis=2) / np.linalg.norm(params[2:].reshape(p, 2), axis=1)[None]
        return e.max(axis=1)

    rng = np.random.default_rng(seed)
    best_in = None
    for _ in range(iterations):
        sel = rng.choice(idx, size=min(4, len(idx)), replace=False)
        prm = fit(sel)
        inl = idx[tile_err(prm) < threshold]
        if best_in is None or len(inl) > len(best_in):
            best_in = inl
        if len(best_in) == len(idx):
            break
    if best_in is None or len(best_in) < min_tiles:
        return eye, {"tiles": int(len(idx)), "reason": "no consistent lattice across tiles"}
    prm = fit(best_in, loss="soft_l1")
    g = prm[:2] / scale_xy
    change = float(np.abs(g) @ np.array([w, h]))
    h_rel = np.array([[1, 0, 0], [0, 1, 0], [g[0], g[1], 1]], float)
    return h_rel, {"tiles": int(len(idx)), "inliers": int(len(best_in)), "g": g.tolist(), "change": change}


# ----------------------------------------------------------------------------- Radon

def _disc(img: np.ndarray, diameter: int) -> np.ndarray:
    h, w = img.shape
    d = int(min(diameter, h, w))
    y0, x0 = (h - d) // 2, (w - d) // 2
    crop = img[y0:y0 + d, x0:x0 + d].astype(np.float64)
    yy, xx = np.indices((d, d))
    r = (d - 1) / 2
    mask = (xx - r) ** 2 + (yy - r) ** 2 <= (r - 0.5) ** 2
    crop = crop - crop[mask].mean()
    return np.where(mask, crop, 0.0)


def _radon_variance(edge: np.ndarray, thetas: np.ndarray) -> np.ndarray:
    """Variance across offsets of the chord-normalised Radon projections, per angle."""
    sino = radon(edge, theta=thetas, circle=True, preserve_range=True)
    d = edge.shape[0]
    s = np.arange(sino.shape[0]) - (sino.shape[0] - 1) / 2
    r = (d - 1) / 2
    keep = np.abs(s) < 0.7 * r
    chord = 2 * np.sqrt(np.maximum(r ** 2 - s[keep] ** 2, 1.0))
    prof = sino[keep] / chord[:, None]
    return prof.var(axis=0)


def _laplacian_edges(img: np.ndarray, *, sigma_px: float = 0.7) -> np.ndarray:
    """Laplacian of a Gaussian-smoothed image: the yarn edges, without broad highlights.

    ``sigma_px`` is the Gaussian's σ in pixels; the filter's gain peaks at the frequency
    1/(π·√2·σ) cycles/px (the default keeps every edge).
    """
    g = cv2.GaussianBlur(img.astype(np.float32), (0, 0), sigma_px)
    return cv2.Laplacian(g, cv2.CV_32F, ksize=3)


def _parabola_peak(x: np.ndarray, y: np.ndarray) -> float:
    i = int(np.argmax(y))
    if 0 < i < len(y) - 1:
        a, b, c = y[i - 1], y[i], y[i + 1]
        den = a - 2 * b + c
        if den < 0:
            return float(x[i] + 0.5 * (a - c) / den * (x[1] - x[0]))
    return float(x[i])


def _recheck_pair(edge: np.ndarray, refined: list[float], config: PrepareConfig) -> list[float]:
    """Move each of the two refined Radon angles (degrees) to the strongest line family within
    the skew window around the square of the other, where that one is clearly stronger (§4.1).

    A lattice is a family of lines along each of its lattice vectors: next to a yarn direction,
    at atan(1/j) for the j-th lattice line of an n-yarn repeat, lie line families at about j/n
    times the yarn frequency. Thin, sharp gaps make these harmonics strong, and the coarse
    search (1° steps, a small disc) can pick one a few degrees off the yarns; the fine disc
    separates them. A move needs the new family to reach ``1 / radon_pair_tie`` times the old
    one, so that a broad, ambiguous peak (hairy yarns) keeps the coarse choice.

    Parameters
    ----------
    edge : (D, D) Laplacian in a disc (:func:`_disc`).
    refined : [first, second] Radon angles (degrees).

    Returns
    -------
    [first, second], each moved or not.
    """
    out = list(refined)
    ts0 = np.arange(-config.radon_pair_skew_deg, config.radon_pair_skew_deg + 1e-9, config.radon_fine_step_deg)
    for i in (1, 0):
        ts = np.concatenate([[out[i]], out[1 - i] + 90.0 + ts0])
        var = _radon_variance(edge, ts)
        if var[1:].max() * config.radon_pair_tie > var[0]:
            out[i] = _parabola_peak(ts[1:], var[1:]) % 180.0
    return out


def _squarest_pair(pair: np.ndarray, thetas: np.ndarray, *, tie: float) -> int:
    """Index of the yarn-direction pair among the local maxima of the Radon pair score (§4.1).

    A twill's diagonal, or the twist of plied yarns, can make a second pair of line families
    about as strong as the yarns themselves. Among the local maxima that reach ``tie`` times
    the best score (equally good within the score's noise), the pair nearest to the image
    axes wins: a person photographing a swatch holds it roughly square to the frame far more
    often than at 45°.
    """
    n = len(pair)
    peaks = [i for i in range(n) if pair[i] >= pair[i - 1] and pair[i] >= pair[(i + 1) % n]]
    good = [i for i in peaks if pair[i] >= tie * float(pair.max())] or [int(np.argmax(pair))]

    def off_axis(i: int) -> float:
        t = thetas[i] % 90.0
        return min(t, 90.0 - t)

    return min(good, key=lambda i: (off_axis(i), -pair[i]))


def dominant_angles(img: np.ndarray, *, pitch_px: float, band: bool = False,
                    config: PrepareConfig = PrepareConfig()) -> dict:
    """The two yarn directions of a weave, by the Radon transform of its Laplacian (§4.1).

    Parameters
    ----------
    img : (H, W) float array, illumination-flattened grey, free of perspective.
    pitch_px : the approximate yarn pitch in ``img`` pixels.
    band : ``pitch_px`` is a measured yarn pitch (not a texture period that may be one of its
        harmonics): the Laplacian is then taken of a Gaussian tuned to it
        (``radon_band_sigma_pitch``), which keeps the yarn frequency and drops the harmonics,
        where line families of the repeat's lattice lie a few degrees off the yarns (see
        :func:`_recheck_pair`).

    Returns
    -------
    dict with ``vertical_deg`` and ``horizontal_deg``: directions of the lines (image angle
    atan2(dy, dx), y down) nearest to vertical and to horizontal; ``contrast``: the Radon
    variance at the chosen pair relative to its median over angles (≫ 1 for straight yarns).
    """
    # coarse: few yarns across, so the peak is broad enough for a 1° step
    f = min(1.0, config.radon_coarse_pitch_px / pitch_px)
    small = cv2.resize(img, None, fx=f, fy=f, interpolation=cv2.INTER_AREA) if f < 1 else img
    edge_sigma_px = config.radon_band_sigma_pitch * pitch_px if band else 0.7
    edge = _disc(_laplacian_edges(small, sigma_px=edge_sigma_px * f), config.radon_coarse_diameter_px)
    thetas = np.arange(0.0, 180.0, config.radon_coarse_step_deg)
    v = _radon_variance(edge, thetas)
    # a weave is two families of lines: score each direction together with the strongest
    # direction within ±max_skew of its perpendicular, by the geometric mean, so that one strong
    # family alone (a twill diagonal, a rib, a highlight streak) does not win
    n_t = len(thetas)
    half = n_t // 2
    reach = int(round(config.radon_pair_skew_deg / config.radon_coarse_step_deg))
    partner = np.max([np.roll(v, -(half + k)) for k in range(-reach, reach + 1)], axis=0)
    pair = np.sqrt(v * partner)
    best = _squarest_pair(pair, thetas, tie=config.radon_pair_tie)
    k_best = max(range(-reach, reach + 1), key=lambda k: v[(best + half + k) % n_t])
    contrast = float(pair[best] / max(np.median(pair), 1e-12))
    edge_f = _disc(_laplacian_edges(img, sigma_px=edge_sigma_px), config.radon_fine_diameter_px)
    refined = []
    for t0 in (thetas[best], thetas[best] + 90.0 + k_best * config.radon_coarse_step_deg):
        ts = t0 + np.arange(-config.radon_fine_halfwidth_deg, config.radon_fine_halfwidth_deg + 1e-9,
                            config.radon_fine_step_deg)
        refined.append(_parabola_peak(ts, _radon_variance(edge_f, ts)))
    refined = _recheck_pair(edge_f, refined, config)
    # skimage's projection at angle θ sums along lines of direction 90° − θ (image, y down)
    dirs = [(90.0 - t) % 180.0 for t in refined]
    # the one nearest to vertical (90°) is the warp direction
    dv = min(dirs, key=lambda a: abs(a - 90.0))
    dh = dirs[1] if dv is dirs[0] else dirs[0]
    dh = dh if dh < 90 else dh - 180.0  # near 0
    return {"vertical_deg": float(dv), "horizontal_deg": float(dh), "contrast": contrast}


def straightening(vertical_deg: float, horizontal_deg: float) -> np.ndarray:
    """The 2×2 linear map taking the two yarn directions to the image axes.

    Warps (direction ``vertical_deg``) go to +y, wefts (``horizontal_deg``) to +x, with unit
    length, so a skewed lattice is made square-cornered and nothing is flipped.
    """
    a, b = np.deg2rad(horizontal_deg), np.deg2rad(vertical_deg)
    d = np.array([[np.cos(a), np.cos(b)], [np.sin(a), np.sin(b)]])
    return np.linalg.inv(d)


def rotation_of(jac: np.ndarray) -> float:
    """The turn (degrees, CCW positive with y down) of a 2×2 map, from its polar decomposition."""
    u, _, vt = np.linalg.svd(jac)
    r = u @ vt
    return float(np.rad2deg(np.arctan2(r[0, 1], r[0, 0])))


# ----------------------------------------------------------------------------- the stage

def _inner_box(hmg: np.ndarray, shape: tuple[int, int]) -> tuple[float, float, float, float]:
    """An axis-aligned box (x0, y0, x1, y1) inside the image of the input's outline under hmg."""
    h, w = shape
    n = 64
    t = np.linspace(0, 1, n)
    edges = [np.stack([t * (w - 1), np.zeros(n)], 1), np.stack([np.full(n, w - 1.0), t * (h - 1)], 1),
             np.stack([(1 - t) * (w - 1), np.full(n, h - 1.0)], 1), np.stack([np.zeros(n), (1 - t) * (h - 1)], 1)]
    pts = [cv2.perspectiveTransform(e[None].astype(np.float64), hmg)[0] for e in edges]
    poly = np.concatenate(pts).astype(np.float32)
    c = cv2.perspectiveTransform(np.array([[[(w - 1) / 2, (h - 1) / 2]]]), hmg)[0, 0]
    # grow a box around the centre while all four corners stay inside the outline
    lo, hi = 0.0, float(max(h, w)) * 4
    aspect = w / h
    for _ in range(40):
        mid = (lo + hi) / 2
        hw_, hh_ = mid * np.sqrt(aspect), mid / np.sqrt(aspect)
        corners = [(c[0] + sx * hw_, c[1] + sy * hh_) for sx in (-1, 1) for sy in (-1, 1)]
        if all(cv2.pointPolygonTest(poly, (float(x), float(y)), False) >= 0 for x, y in corners):
            lo = mid
        else:
            hi = mid
    hw_, hh_ = lo * np.sqrt(aspect), lo / np.sqrt(aspect)
    return c[0] - hw_, c[1] - hh_, c[0] + hw_, c[1] + hh_


def rectify(rgb: np.ndarray, *, config: PrepareConfig = PrepareConfig(),
            pitch_px: float | None = None) -> Rectification | None:
    """Turn, de-skew and undo the perspective of a weave photo (§4.1).

    Parameters
    ----------
    rgb : (H, W, 3) or (H, W) float32 linear image.
    config : hyper-parameters.
    pitch_px : the yarn pitch in input pixels where already measured (else the texture period of
        :func:`coarse_pitch`); the Radon is then tuned to it (:func:`dominant_angles`' ``band``).

    Returns
    -------
    :class:`Rectification`, or None when the photo has no texture period at all.
    """
    p0 = pitch_px if pitch_px is not None else coarse_pitch(luminance(rgb), crop_px=config.coarse_crop_px,
                                                           rel_floor=config.coarse_rel_floor,
                                                           noise_floor=config.coarse_noise_floor)
    if p0 is None or not np.isfinite(p0):
        return None
    if config.colour_blind:  # the yarns' texture without their colours, its period measured again
        grey = colour_blind(rgb, sigma_px=config.colour_sigma_pitches * p0)
        p0 = p0 if pitch_px is not None else coarse_pitch(grey, crop_px=config.coarse_crop_px,
                                                         rel_floor=config.coarse_rel_floor,
                                                         noise_floor=config.coarse_noise_floor)
        if p0 is None or not np.isfinite(p0):
            return None
    else:
        grey = luminance(rgb)
    h, w = grey.shape
    # working image: pitch ≈ work_pitch_px, a centre crop of at most work_max_px
    fw = float(np.clip(config.work_pitch_px / p0, 0.05, 2.0))
    side = config.work_max_px / fw
    ch, cw = int(min(h, side)), int(min(w, side))
    y0, x0 = (h - ch) // 2, (w - cw) // 2
    crop = grey[y0:y0 + ch, x0:x0 + cw]
    interp = cv2.INTER_AREA if fw < 1 else cv2.INTER_CUBIC
    work = cv2.resize(crop, (max(8, round(cw * fw)), max(8, round(ch * fw))), interpolation=interp)
    work, _ = flatten_illumination(work, sigma_px=config.illumination_sigma_pitches * config.work_pitch_px)
    work = _standardise(work)
    wh, ww = work.shape
    # input px → centred working px
    to_work = _scaling(fw) @ np.array([[1, 0, -x0 - (cw - 1) / 2], [0, 1, -y0 - (ch - 1) / 2], [0, 0, 1]])
    # fw maps crop px to work px only approximately at the border (rounding); fine at the centre
    tile = int(round(config.tile_pitches * config.work_pitch_px / 2) * 2)
    # small photos: smaller tiles (down to ``tile_min_pitches``) so that a 3×3 set still fits
    tile_small = int(min(wh, ww) / 2.2) // 2 * 2
    tile = int(np.clip(min(tile, tile_small), round(config.tile_min_pitches * config.work_pitch_px), 160))
    h_rel, pinfo = estimate_perspective(work, tile=tile, peaks=config.tile_peaks,
                                        iterations=config.ransac_iterations,
                                        threshold=config.ransac_threshold, min_tiles=config.min_tiles)
    change = float(pinfo.get("change", 0.0))
    if change < config.min_perspective or change > config.max_perspective:
        h_rel = np.eye(3)
        change = 0.0 if change < config.min_perspective else change
        if change:
            pinfo["reason"] = "implausibly strong perspective; ignored"
            change = 0.0
    # Radon on the perspective-free working image
    cw_ = _centred(work.shape)
    flat = cv2.warpPerspective(work, np.linalg.inv(cw_) @ h_rel @ cw_, (ww, wh),
                               flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)
    ang = dominant_angles(flat, pitch_px=config.work_pitch_px, band=pitch_px is not None, config=config)
    m2 = straightening(ang["vertical_deg"], ang["horizontal_deg"])
    m2 /= np.sqrt(abs(np.linalg.det(m2)))  # keep the area at the centre
    a0 = np.eye(3)
    a0[:2, :2] = m2
    h_work = a0 @ h_rel  # centred working px → centred, straightened working px
    # output scale: rectified px per input px
    s_out = float(min(1.0, config.rectified_pitch_px / p0))
    full = _scaling(s_out / fw) @ h_work @ to_work
    full /= full[2, 2]
    bx0, by0, bx1, by1 = _inner_box(full, (h, w))
    area = (bx1 - bx0) * (by1 - by0)
    if area > config.rectified_max_pixels:
        k = np.sqrt(config.rectified_max_pixels / area)
        cx, cy = (bx0 + bx1) / 2, (by0 + by1) / 2
        bx0, bx1 = cx - (cx - bx0) * k, cx + (bx1 - cx) * k
        by0, by1 = cy - (cy - by0) * k, cy + (by1 - cy) * k
    out_w, out_h = max(1, int(np.floor(bx1 - bx0))), max(1, int(np.floor(by1 - by0)))
    hmg = np.array([[1, 0, -bx0], [0, 1, -by0], [0, 0, 1]]) @ full
    hmg /= hmg[2, 2]
    image = warp_to_rectified(rgb, hmg, (out_h, out_w), scale=s_out)
    jac = hmg[:2, :2] - np.outer(hmg[:2] @ [(w - 1) / 2, (h - 1) / 2, 1], hmg[2, :2]) / (hmg[2] @ [(w - 1) / 2, (h - 1) / 2, 1])
    rot = rotation_of(jac)
    skew = float(abs(abs(ang["vertical_deg"] - ang["horizontal_deg"]) - 90.0))
    notes = {"perspective": pinfo, "radon": ang, "work_scale": fw}
    return Rectification(rotation_deg=rot, homography=hmg, image=image, scale=s_out,
                         coarse_pitch_px=float(p0), perspective=change, skew_deg=skew, notes=notes)


def warp_to_rectified(rgb: np.ndarray, hmg: np.ndarray, shape: tuple[int, int], *, scale: float) -> np.ndarray:
    """Resample ``rgb`` through ``hmg`` into an image of ``shape`` (h, w), without aliasing.

    When the map shrinks the photo (``scale`` < 1) the photo is first reduced by area
    averaging to about the output resolution, so the warp only interpolates.
    """
    src = rgb.astype(np.float32, copy=False)
    pre = np.eye(3)
    if scale < 0.7:
        f = min(1.0, scale * 1.25)
        h, w = src.shape[:2]
        nw, nh = max(1, round(w * f)), max(1, round(h * f))
        src = cv2.resize(src, (nw, nh), interpolation=cv2.INTER_AREA)
        sx, sy = w / nw, h / nh
        # small px (x', y') → input px: x = (x' + 0.5) * sx - 0.5
        pre = np.array([[sx, 0, 0.5 * sx - 0.5], [0, sy, 0.5 * sy - 0.5], [0, 0, 1]])
    m = hmg @ pre
    out = cv2.warpPerspective(src, m, (shape[1], shape[0]), flags=cv2.INTER_LINEAR,
                              borderMode=cv2.BORDER_REFLECT)
    return out.astype(np.float32)
