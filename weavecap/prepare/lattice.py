"""The lattice of a weave from its autocorrelation (Wu et al. 2025 §4.3–4.4).

A woven fabric is periodic in two dimensions: shifting the photo by a vector of its repeat's
lattice maps the weave onto itself. The autocorrelation of the rectified photo peaks at those
vectors, and the peaks say more than either integral projection: a plain weave's nearest
peak is one warp across and one weft along, a twill's too, a satin's one weft along and its
step across. The yarn grid is then the coarsest axis-aligned grid on which every lattice
vector is a whole number of yarns (:func:`cell_of`): for plain weaves, twills and satins,
whatever the colours, it *is* the yarn pitch; where yarns work in groups (a basket's pairs,
a random weave's columns) it is a whole number of yarns, which the lattice of yarn crossings
then splits (:func:`~weavecap.prepare.grid.crossing_pitches`).

What makes it robust on real cloth: the colour of every channel counts (a yarn-dyed check's
stripes and a colour-and-weave effect do not hide the weave), each channel is divided by its
own local mean (lighting and colour blocks drop out), and a lattice is only believed where its
points are peaks of the autocorrelation *and* it explains the strong peaks
(:func:`fit_lattice`): a projection that repeats over two yarns (alternate yarns of two
colours) cannot hide that the photo also matches itself one warp across and one weft along.

Conventions: vectors are (dx, dy) in rectified pixels, y down; warps run along y.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

import cv2
import numpy as np
from scipy.ndimage import maximum_filter


@dataclass(frozen=True)
class Lattice:
    """The repeat lattice of a rectified weave photo.

    Attributes
    ----------
    basis : (2, 2) float64, rows the two reduced basis vectors (dx, dy), px.
    cell : (along x, along y) px: the coarsest yarn grid on which every lattice vector is a
        whole number of yarns (:func:`cell_of`); None along an axis where no such grid of at
        most ``max_multiple`` yarns per basis component was found.
    score : how well the lattice fits the autocorrelation (:func:`fit_lattice`), 0–1.
    peaks : (K, 3) the autocorrelation's strong peaks (dx, dy, value) it was fitted to.
    """

    basis: np.ndarray
    cell: tuple[float | None, float | None]
    score: float
    peaks: np.ndarray

    @property
    def oblique(self) -> bool:
        """Whether a basis vector runs across both axes by at least a cell (:attr:`cell`):
        the lattice of interlacings of a plain weave, twill or satin. A rectangular lattice
        only says that each axis is periodic by itself, as its projection does."""
        return any(all(c is not None and abs(v) >= 0.5 * c for v, c in zip(b, self.cell)) for b in self.basis)

    def to_json(self) -> dict:
        return {"basis_px": [[round(float(v), 2) for v in b] for b in self.basis],
                "cell_px": [None if c is None else round(float(c), 3) for c in self.cell],
                "score": round(float(self.score), 3), "oblique": self.oblique}


def autocorrelation(image: np.ndarray, *, mean_sigma_px: float, max_side: int = 512) -> np.ndarray:
    """The normalised autocorrelation of a (square, centred, at most ``max_side``) crop.

    Each channel is divided by its own local mean (a Gaussian of σ ``mean_sigma_px``), so
    lighting and large colour blocks drop out and a dark yarn's texture counts as much as a
    pale one's; the channels' autocorrelations are summed and divided by the overlap at each
    shift (an unbiased estimate), then by the value at zero shift.

    Parameters
    ----------
    image : (H, W) or (H, W, C) float array, rectified photo (linear).
    mean_sigma_px : σ of the local mean, px (a few yarn pitches).

    Returns
    -------
    (2n - 1, 2n - 1) float64, n the crop's side; entry (n - 1 + dy, n - 1 + dx) is the
    autocorrelation at the shift (dx, dy); 1 at the centre.
    """
    img = np.asarray(image, np.float64)
    if img.ndim == 2:
        img = img[..., None]
    h, w = img.shape[:2]
    n = int(min(h, w, max_side))
    y0, x0 = (h - n) // 2, (w - n) // 2
    crop = img[y0:y0 + n, x0:x0 + n]
    power = np.zeros((2 * n, 2 * n))
    for c in range(crop.shape[2]):
        ch = crop[..., c]
        local = cv2.GaussianBlur(ch, (0, 0), mean_sigma_px)
        z = ch / np.maximum(local, 1e-6 * max(float(local.max()), 1e-12)) - 1.0
        z = z - z.mean()
        power += np.abs(np.fft.fft2(z, s=(2 * n, 2 * n))) ** 2
    corr = np.fft.fftshift(np.real(np.fft.ifft2(power)))[1:, 1:]
    k = np.arange(-(n - 1), n)
    overlap = np.outer(n - np.abs(k), n - np.abs(k)).astype(np.float64)
    corr = corr / overlap
    centre = corr[n - 1, n - 1]
    return corr / centre if centre > 0 else corr


def autocorrelation_peaks(acf: np.ndarray, *, radius: float, min_shift: float, rel: float) -> np.ndarray:
    """The local maxima of an autocorrelation (:func:`autocorrelation`) in one half-plane,
    within ``radius`` of zero shift and beyond ``min_shift``, at least ``rel`` times the
    strongest one (and above zero).

    Returns
    -------
    (K, 3) array of (dx, dy, value), strongest first, positions refined to sub-pixel by a
    parabola along each axis.
    """
    c = acf.shape[0] // 2
    r = int(min(c - 1, np.ceil(radius)))
    win = acf[c - r:c + r + 1, c - r:c + r + 1]
    size = max(3, int(round(min_shift)) | 1)
    mx = maximum_filter(win, size=size, mode="nearest")
    yy, xx = np.mgrid[-r:r + 1, -r:r + 1]
    dist = np.hypot(yy, xx)
    cand = (win >= mx) & (dist >= min_shift) & (dist <= radius) & ((yy > 0) | ((yy == 0) & (xx > 0))) & (win > 0)
    idx = np.argwhere(cand)
    if not len(idx):
        return np.empty((0, 3))
    vals = win[idx[:, 0], idx[:, 1]]
    keep = vals >= rel * vals.max()
    idx, vals = idx[keep], vals[keep]
    order = np.argsort(-vals)

    def sub(a, b, d):
        den = a - 2 * b + d
        return float(np.clip(0.5 * (a - d) / den, -0.5, 0.5)) if den < 0 else 0.0

    out = []
    for i, j in idx[order]:
        dy = sub(win[i - 1, j], win[i, j], win[i + 1, j]) if 0 < i < 2 * r else 0.0
        dx = sub(win[i, j - 1], win[i, j], win[i, j + 1]) if 0 < j < 2 * r else 0.0
        out.append((xx[i, j] + dx, yy[i, j] + dy, win[i, j]))
    return np.array(out, np.float64)


def _lattice_points(basis: np.ndarray, radius: float) -> np.ndarray:
    """Lattice points m·b1 + n·b2 within ``radius`` of zero, in one half-plane (no origin)."""
    b1, b2 = basis
    area = abs(b1[0] * b2[1] - b1[1] * b2[0])
    reach = int(np.ceil(radius * max(np.linalg.norm(b1), np.linalg.norm(b2)) / max(area, 1e-9))) + 1
    m, n = np.mgrid[-reach:reach + 1, -reach:reach + 1]
    pts = m.reshape(-1, 1) * b1 + n.reshape(-1, 1) * b2
    d = np.hypot(pts[:, 0], pts[:, 1])
    half = (pts[:, 1] > 1e-9) | ((np.abs(pts[:, 1]) <= 1e-9) & (pts[:, 0] > 0))
    return pts[half & (d <= radius) & (d > 1e-9)]


def _reduced(b1: np.ndarray, b2: np.ndarray) -> np.ndarray:
    """Lagrange–Gauss reduction: the shortest basis of the lattice of b1, b2."""
    u, v = np.asarray(b1, float), np.asarray(b2, float)
    if u @ u > v @ v:
        u, v = v, u
    for _ in range(32):
        k = np.round((u @ v) / (u @ u))
        v = v - k * u
        if v @ v >= u @ u:
            break
        u, v = v, u
    out = []
    for b in (u, v):  # into the half-plane y > 0 (or y = 0, x > 0)
        out.append(-b if b[1] < 0 or (b[1] == 0 and b[0] < 0) else b)
    return np.array(out)


def fit_lattice(acf: np.ndarray, peaks: np.ndarray, *, radius: float, tol: float, floor: float,
                candidates: int = 8) -> tuple[np.ndarray | None, float]:
    """The lattice that fits the autocorrelation best: every pair of the ``candidates``
    shortest strong peaks is tried as a basis (reduced), scored by recall × precision:

    - recall: the value-weighted share of the strong ``peaks`` within ``tol`` of a lattice
      point (a too coarse lattice, a super-lattice, misses some);
    - precision: the share of the lattice's points within ``radius`` where the
      autocorrelation reaches ``floor`` within ``tol`` (a too fine lattice, e.g. half a yarn,
      has points where the photo does not match itself).

    Parameters
    ----------
    acf : from :func:`autocorrelation`; peaks : from :func:`autocorrelation_peaks`.
    radius : px of the window scored; tol : px.
    floor : the autocorrelation value that counts as a match.

    Returns
    -------
    (basis (2, 2) or None, score): None when fewer than two non-collinear peaks.
    """
    if len(peaks) < 2:
        return None, 0.0
    c = acf.shape[0] // 2
    short = peaks[np.argsort(np.hypot(peaks[:, 0], peaks[:, 1]))[:candidates]]
    t = int(np.ceil(tol))

    def value_at(p: np.ndarray) -> float:
        x, y = int(round(p[0])) + c, int(round(p[1])) + c
        if not (t <= x < acf.shape[1] - t and t <= y < acf.shape[0] - t):
            return -1.0
        return float(acf[y - t:y + t + 1, x - t:x + t + 1].max())

    best, best_score, seen = None, 0.0, set()
    for a, b in combinations(short[:, :2], 2):
        cross = abs(a[0] * b[1] - a[1] * b[0])
        if cross < 0.3 * np.linalg.norm(a) * np.linalg.norm(b):
            continue
        basis = _reduced(a, b)
        key = tuple(np.round(basis.ravel(), 1))
        if key in seen:
            continue
        seen.add(key)
        pts = _lattice_points(basis, radius)
        if not len(pts):
            continue
        inv = np.linalg.inv(basis.T)
        coef = peaks[:, :2] @ inv.T
        near = np.linalg.norm((coef - np.round(coef)) @ basis, axis=1) <= tol
        recall = float(peaks[near, 2].sum() / peaks[:, 2].sum())
        vals = np.array([value_at(p) for p in pts])
        vals = vals[vals > -1.0]
        precision = float(np.mean(vals >= floor)) if len(vals) else 0.0
        score = recall * precision
        if score > best_score + 1e-9:
            best, best_score = _refined(basis, peaks[near, :2]), score
    return best, best_score


def _refined(basis: np.ndarray, points: np.ndarray) -> np.ndarray:
    """The basis that puts ``points`` (each near a lattice point of ``basis``) best on its
    lattice, by least squares over their whole coordinates (a twill's or satin's peaks are
    ridges along its diagonal: one peak's position is loose, many together are not)."""
    coef = np.round(points @ np.linalg.inv(basis.T).T)
    if len(points) < 3 or np.linalg.matrix_rank(coef) < 2:
        return basis
    sol, *_ = np.linalg.lstsq(coef, points, rcond=None)
    return sol if abs(np.linalg.det(sol)) > 0.5 * abs(np.linalg.det(basis)) else basis


def real_gcd(values: np.ndarray, *, tol: float, min_unit: float, max_multiple: int) -> float | None:
    """The largest unit ≥ ``min_unit`` of which every value is a whole multiple (1 to
    ``max_multiple``) within ``tol`` px or a tenth of the unit; values within ``tol`` of zero
    are multiples of any unit. Least squares over the multiples; None when no value is away
    from zero or no such unit exists."""
    v = np.abs(np.asarray(values, float))
    v = v[v > tol]
    if not len(v):
        return None
    units = sorted({float(x / k) for x in v for k in range(1, max_multiple + 1) if x / k >= min_unit}, reverse=True)
    for u in units:
        k = np.round(v / u)
        if np.all((k >= 1) & (k <= max_multiple)) and np.all(np.abs(v - k * u) <= max(tol, 0.1 * u)):
            return float(np.sum(v * k) / np.sum(k * k))
    return None


def cell_of(basis: np.ndarray, *, tol: float, min_unit: float,
            max_multiple: int = 12) -> tuple[float | None, float | None]:
    """The coarsest axis-aligned grid (along x, along y) on which both basis vectors are whole
    numbers of cells: the real greatest common divisor of their x and of their y components
    (:func:`real_gcd`). A plain weave's (p_x, p_y) and (−p_x, p_y), a twill's (p_x, p_y) and
    (n·p_x, 0), a satin's (s·p_x, p_y) and (n·p_x, 0) all give (p_x, p_y)."""
    return (real_gcd(basis[:, 0], tol=tol, min_unit=min_unit, max_multiple=max_multiple),
            real_gcd(basis[:, 1], tol=tol, min_unit=min_unit, max_multiple=max_multiple))


def weave_lattice(image: np.ndarray, pitch_guess_px: float, *, min_unit_px: float, max_side: int = 512,
                  radius_pitches: float = 8.0, rel: float = 0.25, floor_share: float = 0.5,
                  max_multiple: int = 6) -> Lattice | None:
    """The repeat lattice of a rectified weave photo and the yarn grid it implies.

    Parameters
    ----------
    image : (H, W, 3) rectified photo, linear RGB.
    pitch_guess_px : a first guess at the yarn pitch (rectified px): it sets the local mean
        (σ = 3 guesses), the window (``radius_pitches`` guesses), the shortest shift
        (a third of a guess) and the tolerance (a tenth, at least 1.5 px).
    min_unit_px : finest cell accepted (px).
    rel : a peak is strong when it reaches this share of the strongest.
    floor_share : a lattice point matches where the autocorrelation reaches this share of the
        weakest strong peak.

    Returns
    -------
    :class:`Lattice`, or None when the autocorrelation holds no two non-collinear strong peaks.
    """
    p = float(pitch_guess_px)
    acf = autocorrelation(image, mean_sigma_px=3 * p, max_side=max_side)
    radius = min(radius_pitches * p, acf.shape[0] // 2 - 2)
    peaks = autocorrelation_peaks(acf, radius=radius, min_shift=p / 3, rel=rel)
    if len(peaks) < 2:
        return None
    tol = max(1.5, 0.1 * p)
    floor = floor_share * float(peaks[:, 2].min())
    basis, score = fit_lattice(acf, peaks, radius=radius, tol=tol, floor=floor)
    if basis is None:
        return None
    return Lattice(basis=basis, cell=cell_of(basis, tol=tol, min_unit=min_unit_px, max_multiple=max_multiple),
                   score=score, peaks=peaks)
