"""The joint fit's target: one repeat of the photo, registered on the fabric being fitted (§6).

Preparation (§4) gives the rectified photo and the cell boundaries of one repeat; the fit
compares a render of one repeat with the photo's *median repeat* on that lattice. How well
that works rests on the lattice: a fifth of a cell off, or a drift of a pixel across the
photo, and even the true parameters score poorly. So the cells are registered on a render of
the fabric (:func:`register_cells`, one FFT), and the median repeat follows any residual drift
of the lattice across the photo (:func:`read_repeat` with a ``model``). The capture repeats
both between rounds of the fit (:func:`weavecap.fit.rounds.fit_registered`).

Shapes: images are (H, W, 3) linear RGB; a canvas of one repeat of an (n_e, n_a) pattern at
``c`` px per cell is (n_e*c, n_a*c, 3) (:mod:`weavecap.estimate.cells`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..estimate.cells import CellGrid, cell_canvas, gap_phase, mirror_phase
from ..params import Fabric

DRIFT_MAX_CELLS = 0.5  # a repeat's offset beyond this (cells) is a mismatch, not drift
QUADRATIC_BLOCKS = 16  # from this many repeats on, the drift model adds quadratic terms
MISMATCH_SPREAD = 1.5  # a drift spreading the repeats this much more than the lattice is a mismatch


def repeat_cells(prepared, image_box: tuple[float, float, float, float]) -> CellGrid:
    """The cells of one repeat inside the regularized box, in the box's pixels."""
    rows, cols = prepared.grid.cells()
    y0, x0 = image_box[0], image_box[1]
    rh, rw = rows[-1] - rows[0], cols[-1] - cols[0]
    # move the repeat by whole repeats so that it starts inside the box
    dy = y0 + np.mod(rows[0] - y0, rh) - rows[0]
    dx = x0 + np.mod(cols[0] - x0, rw) - cols[0]
    return CellGrid(rows=rows + dy - y0, cols=cols + dx - x0)


def shifted(cells: CellGrid, box) -> CellGrid:
    """``cells`` (pixels of the regularized box) in the rectified image's pixels."""
    return CellGrid(rows=cells.rows + box[0], cols=cells.cols + box[1])


def align_cells(image: np.ndarray, cells: CellGrid) -> CellGrid:
    """Put the cell corners on the gaps between yarns (§5's cells are centred on yarn
    crossings): first onto a centre of mirror symmetry of the projections (sub-pixel,
    :func:`weavecap.estimate.cells.mirror_phase`: the gaps or the yarn centres), then, of the
    four half-pitch shifts of that lattice, the one whose corners vary most and whose centres
    vary least.

    The yarn boundaries of §4.4 are valleys of the integral projection — right under front
    light, where gaps are dark, but off under back light, where they glow: there the valley is
    wherever the yarn is darkest, half a pitch from the gap give or take the yarn's shading (a
    sixth of a cell on the fixtures' plain weave, and every estimate of the pre-estimate is
    then made on the wrong cells: the true fabric scored 19.6 dB against that canvas, 33.4 dB
    registered). A corner window holds a gap and four yarn edges whatever the light; a centre
    window sits on a smooth crossing. ``image`` (H, W, 3) linear RGB, ``cells`` a CellGrid in
    its pixels.
    """
    c = 12
    win = max(1, c // 4)
    sy, sx = mirror_phase(cell_canvas(image, cells, c), cells.shape)
    sy, sx = (sy + c / 4) % (c / 2) - c / 4, (sx + c / 4) % (c / 2) - c / 4  # the centre nearest the corners
    cells = CellGrid(rows=cells.rows + sy / c * np.diff(cells.rows).mean(),
                     cols=cells.cols + sx / c * np.diff(cells.cols).mean())
    best, best_score = cells, -np.inf
    for dy in (0.0, 0.5):
        for dx in (0.0, 0.5):
            moved = CellGrid(rows=cells.rows + dy * np.diff(cells.rows).mean(),
                             cols=cells.cols + dx * np.diff(cells.cols).mean())
            grey = cell_canvas(image, moved, c).mean(axis=2)
            tiles = grey.reshape(moved.shape[0], c, moved.shape[1], c).transpose(0, 2, 1, 3)
            centre = tiles[:, :, c // 2 - win: c // 2 + win, c // 2 - win: c // 2 + win]
            corner = np.roll(np.roll(grey, win, axis=0), win, axis=1)
            corner = corner.reshape(moved.shape[0], c, moved.shape[1], c).transpose(0, 2, 1, 3)[:, :, :2 * win, :2 * win]
            score = float(corner.var(axis=(2, 3)).mean() - centre.var(axis=(2, 3)).mean())
            if score > best_score:
                best, best_score = moved, score
    return best


def correlation_shift(photo: np.ndarray, model: np.ndarray) -> np.ndarray:
    """Circular shifts (dy, dx), canvas px, that carry ``model`` onto each of ``photo``.

    ``photo`` (..., h, w) grey canvases of one period, ``model`` (h, w): the peak of their
    circular cross-correlation, refined to sub-pixel by a parabola through it along each axis,
    wrapped to (-h/2, h/2] × (-w/2, w/2]. photo(x) ≈ model(x - shift). Returns (..., 2).
    """
    a = photo - photo.mean(axis=(-2, -1), keepdims=True)
    b = model - model.mean()
    corr = np.real(np.fft.ifft2(np.fft.fft2(a) * np.conj(np.fft.fft2(b))))
    h, w = corr.shape[-2:]
    flat = corr.reshape(-1, h, w)
    out = np.empty((flat.shape[0], 2))
    for k, cc in enumerate(flat):
        iy, ix = np.unravel_index(int(np.argmax(cc)), cc.shape)
        for axis, (values, i) in enumerate(((cc[:, ix], iy), (cc[iy, :], ix))):
            n = values.size
            lo, mid, hi = values[(i - 1) % n], values[i], values[(i + 1) % n]
            den = lo - 2 * mid + hi
            pos = i + (0.5 * (lo - hi) / den if den < 0 else 0.0)
            out[k, axis] = pos - n if pos > n / 2 else pos
    return out.reshape(corr.shape[:-2] + (2,))


def register_cells(image: np.ndarray, cells: CellGrid, model: np.ndarray, c: int, *,
                   whole_cells: bool = True) -> tuple[CellGrid, tuple[float, float]]:
    """Move ``cells`` so that the photo's repeat lines up with ``model``, a render of the fabric
    ((n_e*c, n_a*c, 3) at ``c`` px per cell, as photographed).

    The cells found from §4.4's boundaries can sit a fraction of a yarn off (uneven lighting,
    bright gaps, residual perspective), and then no parameter values fit. The photo's cell
    canvas and the render are both one period of the fabric, so their circular
    cross-correlation (one FFT) peaks at the shift between them; the cells move by that shift
    (sub-pixel), whole cells included, so the fabric's pattern stays right for the moved
    cells. With ``whole_cells`` False only the fraction of a cell moves (the pattern's phase on
    the photo held, :func:`weavecap.fit.rounds.phase_check`). Returns the moved CellGrid and the
    shift in cells (dy, dx).
    """
    canvas = cell_canvas(image, cells, c)
    photo = canvas.mean(axis=2)
    model = np.asarray(model).mean(axis=2)
    dy, dx = correlation_shift(photo, model) / c
    # the sub-cell part from the gap lattices alone: a model unlike the photo (other shading,
    # colours not yet fitted) can correlate best half a cell off, and then no values fit;
    # the photo's gaps against the model's (the same estimator on both cancels its bias)
    (py, px), (my, mx) = gap_phase(canvas, cells.shape), gap_phase(np.asarray(model)[..., None], cells.shape)
    sy, sx = ((py - my) / c + 0.5) % 1.0 - 0.5, ((px - mx) / c + 0.5) % 1.0 - 0.5
    dy = float(np.round(dy - sy) + sy) if whole_cells else float(sy)
    dx = float(np.round(dx - sx) + sx) if whole_cells else float(sx)
    rows = cells.rows + dy * np.diff(cells.rows).mean()
    cols = cells.cols + dx * np.diff(cells.cols).mean()
    # back by whole repeats to start inside the image: the pattern's phase is the same there,
    # and a repeat pushed past the border would be read from its reflection next time
    rows -= np.floor(rows[0] / (rows[-1] - rows[0])) * (rows[-1] - rows[0])
    cols -= np.floor(cols[0] / (cols[-1] - cols[0])) * (cols[-1] - cols[0])
    return CellGrid(rows=rows, cols=cols), (float(dy), float(dx))


@dataclass(frozen=True)
class Drift:
    """The drift a median repeat was read along (:func:`read_repeat`): ``field(y, x)`` the
    displacement (dy, dx) in canvas px at ``c`` px a cell, (..., 2), with y and x (broadcasting)
    in repeats from the origin of the lattice of every whole repeat (:func:`_whole_repeats`)."""

    field: Callable
    c: int

    def at(self, c: int) -> Callable:
        """The same displacement in canvas px at ``c`` px a cell."""
        scale = c / self.c
        return lambda y, x: self.field(y, x) * scale


def _whole_repeats(shape: tuple[int, int], cells: CellGrid) -> tuple[CellGrid, int, int]:
    """The lattice of ``cells`` extended over every whole repeat of an image of ``shape``
    (H, W), one pitch clear of the border: (cells of all of them, repeats down, across). A
    photo holding less than one clear repeat gives the one in ``cells``."""
    n_e, n_a = cells.shape
    axes = []
    for bounds, n, size in ((cells.rows, n_e, shape[0]), (cells.cols, n_a, shape[1])):
        pitch = float(np.diff(bounds).mean())
        period = n * pitch
        start = bounds[0] - np.floor((bounds[0] - pitch) / period) * period  # first repeat clear of the edge
        count = max(1, int(np.floor((size - pitch - start) / period)))
        if start + period > size:
            start, count = bounds[0], 1
        axes.append((start + pitch * np.arange(count * n + 1), count))
    (rows, ky), (cols, kx) = axes
    return CellGrid(rows=rows, cols=cols), ky, kx


def lattice_drift(blocks: np.ndarray, model: np.ndarray, c: int):
    """How the photo's lattice drifts from a regular one, measured on its repeats.

    Parameters
    ----------
    blocks : (ky, kx, h, w) grey canvases of the photo's repeats on a regular lattice.
    model : (h, w) grey render of one repeat, registered on the lattice.
    c : canvas px per cell.

    Returns
    -------
    ``field(y, x)``: the smooth displacement (dy, dx) in canvas px, (..., 2) with y, x
    (broadcasting) in repeats from the lattice's origin
    (affine, plus quadratic terms when there are at least QUADRATIC_BLOCKS repeats: the
    residue of a homography). Fitted by least squares to each repeat's
    :func:`correlation_shift`, twice, the second time without repeats more than 3 MADs (at
    least a tenth of a pixel) off the first fit; repeats further than DRIFT_MAX_CELLS off are
    mismatches (a flaw, an occluded repeat) and never used.
    """
    ky, kx, h, w = blocks.shape
    shifts = correlation_shift(blocks, model).reshape(-1, 2)
    yy, xx = np.meshgrid(np.arange(ky) + 0.5, np.arange(kx) + 0.5, indexing="ij")
    quadratic = ky * kx >= QUADRATIC_BLOCKS

    def terms(y, x) -> list:  # the field's terms, broadcasting y against x
        y, x = np.asarray(y, float), np.asarray(x, float)
        return [np.ones(()), y, x] + ([y * y, y * x, x * x] if quadratic else [])

    a = np.stack([np.broadcast_to(t, yy.shape).ravel() for t in terms(yy, xx)], axis=1)
    keep = np.all(np.abs(shifts) <= DRIFT_MAX_CELLS * c, axis=1)
    coef = np.zeros((a.shape[1], 2))
    if keep.sum() >= a.shape[1]:
        coef = np.linalg.lstsq(a[keep], shifts[keep], rcond=None)[0]
        residual = np.linalg.norm(shifts - a @ coef, axis=1)
        mad = np.median(residual[keep])
        refit = keep & (residual <= max(3.0 * 1.4826 * mad, 0.1))
        if refit.sum() >= a.shape[1]:
            coef = np.linalg.lstsq(a[refit], shifts[refit], rcond=None)[0]

    def field(y, x) -> np.ndarray:  # term by term, each at its own shape: a whole canvas's (pixels, terms) is ~50 MB
        return sum(np.multiply.outer(t, k) for t, k in zip(terms(y, x), coef))

    return field


def read_repeat(image: np.ndarray, cells: CellGrid, c: int, model: np.ndarray | None = None, *,
                hold_phase: bool = False) -> tuple[np.ndarray, Drift | None]:
    """The photo's average repeat as a cell canvas: the median over every whole repeat of
    ``image`` (H, W, 3) on the lattice of ``cells`` (a CellGrid in its pixels), one pitch clear
    of the border. Irregularities average out (§4.2's aim) without kernel PCA's variable
    smoothing.

    With ``model`` ((n_e*c, n_a*c, 3) render of the fabric, registered on ``cells``) each repeat
    is first read where the lattice really is: a slightly wrong pitch or angle, or a residue of
    perspective, moves the repeats far from ``cells`` by up to a pixel or more, and the median
    of misaligned repeats is blurred. :func:`lattice_drift` measures that smooth drift and the
    canvas is resampled along it. (A synthetic plain weave turned 12° under a perspective
    camera: the true parameters score 27.1 dB against the median on the regular lattice.)
    A drift that leaves the repeats disagreeing far more than the regular lattice does (their
    mean absolute difference from their median over MISMATCH_SPREAD times as large) is no
    drift but a mismatch, and is not followed: a model unlike the photo (a start with the
    wrong pattern) correlates with each repeat at shifts that follow no drift, and the median
    along them is blurred — the independent twill 2/1 S registered on its pre-estimate's dual:
    spread 0.145 against 0.036 on the lattice, half the gradient energy; its fit on that haze
    scored the lowest loss of the starts and the capture was the wrong face at 15.3 dB. (Where
    the drift is real it may still spread the repeats a little more — noise, the resampling —
    while it puts the median where the model is: +3–10% on the own-render twill, which the
    plain median cost 21 dB.)

    With ``hold_phase`` the drift is measured from the cells' own repeat, as
    :func:`register_cells` placed it, rather than from the model: registration takes the whole
    cells from the correlation with the model but the fraction from the gaps, and the drift's
    common part (every repeat's correlation shift alike) would put the correlation's fraction
    back. Which is right depends on the model: a model unlike the photo correlates with every
    repeat alike half a cell off (the independent twill 2/1 S: its median then 10-12 px of 24
    off the gaps, and each family's fitted colour an average of both; held, 0.49 / 0.86 ΔE
    against 13.0 / 7.1), while a render close to the photo correlates more exactly than
    the gaps are found (the own-render twill 2/1, held in every round: 12.6 dB against 35.0).
    :func:`weavecap.fit.rounds.fit_registered` tries both and keeps the lower loss.

    Returns the median repeat, (n_e*c, n_a*c, 3) float32, and the :class:`Drift` it was read
    along (None: the regular lattice), so that the photo can be read again as the fit saw it
    (:func:`cells_canvas`).
    """
    n_e, n_a = cells.shape
    lattice, ky, kx = _whole_repeats(image.shape[:2], cells)
    canvas = cell_canvas(image, lattice, c)
    h, w = n_e * c, n_a * c

    def median_and_spread(canvas: np.ndarray) -> tuple[np.ndarray, float]:
        blocks = canvas.reshape(ky, h, kx, w, 3)
        median = np.median(blocks, axis=(0, 2), keepdims=True)
        return median[0, :, 0].astype(np.float32), float(np.mean(np.abs(blocks - median)))

    median, spread = median_and_spread(canvas)
    if model is None or ky * kx < 3:
        return median, None
    blocks = canvas.mean(axis=2).reshape(ky, h, kx, w).transpose(0, 2, 1, 3)
    measured = lattice_drift(blocks, np.asarray(model).mean(axis=2), c)
    held = correlation_shift(cell_canvas(image, cells, c).mean(axis=2), np.asarray(model).mean(axis=2)) \
        if hold_phase else 0.0  # the drift from where the cells' own repeat is, not from the model

    def drift(y, x) -> np.ndarray:
        return measured(y, x) - held

    followed, followed_spread = median_and_spread(_drifted_canvas(image, lattice, c, drift, (0, 0), (n_e, n_a)))
    if followed_spread <= MISMATCH_SPREAD * spread:
        return followed, Drift(drift, c)
    return median, None


def _drifted_canvas(image: np.ndarray, lattice: CellGrid, c: int, drift, first: tuple[int, int],
                    shape: tuple[int, int]) -> np.ndarray:
    """The cell canvas of ``lattice`` read along ``drift`` (a :attr:`Drift.field`, canvas px at
    ``c``), whose first cell is cell ``first`` (v, u) from the drift's origin, for a repeat of
    ``shape``."""
    h, w = shape[0] * c, shape[1] * c
    rows, cols = lattice.shape
    field = drift(((np.arange(rows * c) + 0.5 + first[0] * c) / h)[:, None],
                  ((np.arange(cols * c) + 0.5 + first[1] * c) / w)[None, :])  # canvas px
    scale = np.array([np.diff(lattice.rows).mean(), np.diff(lattice.cols).mean()]) / c  # image px per canvas px
    return cell_canvas(image, lattice, c, offset=np.moveaxis(field * scale, 2, 0))


def cells_canvas(image: np.ndarray, cells: CellGrid, c: int, drift: Drift | None = None
                 ) -> tuple[np.ndarray, tuple[int, int], CellGrid]:
    """Every whole cell of ``image`` (half a pitch clear of its border) on the lattice of
    ``cells``, read along ``drift`` — the one the fit's median repeat was read along on the same
    ``cells`` (:func:`read_repeat`), so that each cell shows what the fit saw there — or on the
    regular lattice: more threads than whole repeats hold, for what is read per thread
    (:mod:`weavecap.estimate.thread_colours`) and the capture at the photo's scale
    (:mod:`weavecap.fit.photo_view`).

    Returns
    -------
    canvas : (Y*c, X*c, 3) float32
    first : (v0, u0), the canvas's first cell counted from a repeat's first cell: canvas cell
        (v, u) is pattern cell ((v + v0) mod n_e, (u + u0) mod n_a), in [0, n_e) × [0, n_a)
    lattice : the canvas's cells in ``image`` pixels
    """
    n_e, n_a = cells.shape
    repeats = _whole_repeats(image.shape[:2], cells)[0]
    axes, first = [], []
    for bounds, n, size in ((repeats.rows, n_e, image.shape[0]), (repeats.cols, n_a, image.shape[1])):
        pitch = float(np.diff(bounds).mean())
        k0 = int(np.ceil((0.5 * pitch - bounds[0]) / pitch))  # the first cell half a pitch clear
        k1 = int(np.floor((size - 0.5 * pitch - bounds[0]) / pitch))  # one past the last
        k1 = max(k1, k0 + 1)
        axes.append(bounds[0] + pitch * np.arange(k0, k1 + 1))
        first.append(k0)
    lattice = CellGrid(rows=axes[0], cols=axes[1])
    if drift is None:
        canvas = cell_canvas(image, lattice, c)
    else:
        canvas = _drifted_canvas(image, lattice, c, drift.at(c), (first[0], first[1]), (n_e, n_a))
    return canvas, (first[0] % n_e, first[1] % n_a), lattice


def dual(fabric: Fabric) -> Fabric:
    """The fabric with every cell's state flipped and the warp's and weft's colours and radii
    exchanged: in each cell the other yarn family is on top, in the colour that was there. A
    cell-colour match cannot tell the two apart (a plain weave's two phases look alike cell by
    cell); only the yarns' shapes (running across or down) can."""
    swap = {}
    for key in ("body_reflection", "body_subsurface", "radius"):
        swap[f"warp.{key}"], swap[f"weft.{key}"] = fabric.get(f"weft.{key}"), fabric.get(f"warp.{key}")
    return fabric.replace({**swap, "pattern": 1 - fabric.pattern})


def sharpness_blur(image: np.ndarray, target: np.ndarray, c: int, *, sharpness: float = 1.0) -> float:
    """The most blur (σ, canvas px) the photo shows relative to ``image``, an unblurred render
    of its repeat: the σ at which the render's gradient energy falls to ``sharpness`` times the
    photo's (:func:`weavecap.fit.fidelity.gradient_energy`; bisection over [0, c/4]); 0 when
    the render is no sharper than that even unblurred. Edges dominate the gradient energy, so
    this is the photo's edge spread measured against the model's own edges; noise and fibre
    hair in the photo only lower it."""
    from ..model.render import as_photographed, white_level
    from .fidelity import gradient_energy

    white = white_level(target)
    goal = sharpness * gradient_energy(target)

    def energy(s: float) -> float:
        return gradient_energy(as_photographed(image, s, white))

    lo, hi = 0.0, c / 4
    if energy(lo) <= goal:
        return 0.0
    if energy(hi) >= goal:
        return hi
    for _ in range(12):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if energy(mid) > goal else (lo, mid)
    return 0.5 * (lo + hi)


def photo_blur(image: np.ndarray, target: np.ndarray, c: int, *, sharpness: float = 0.9) -> tuple[float, float]:
    """σ (canvas px) of the Gaussian that makes ``image``, an unblurred render of one repeat
    at ``c`` px per cell (same shape as ``target``), most like ``target`` without blurring it
    more than the photo is blurred, and the MSE it leaves.

    The photo is smoothed by resampling to the canvas, by the median over repeats and by the
    camera itself; how much in all varies from photo to photo, and the MSE is very sensitive to
    it (on a 16-px canvas: 0.0033 at σ = 1 px, 0.0025 at 1.5, 0.0053 at 2). It is measured by a
    bounded 1-D search over [0, c/4] — and capped at :func:`sharpness_blur` for
    ``sharpness`` (the render keeps that share of the photo's gradient energy): where the
    model cannot match the photo (another shading, colours not yet fitted), the MSE's best blur
    grows to average the mismatch away (real photos: 2.4–6.0 px on cells of 17–24 px, renders a
    sixth as sharp as their photos), and a fit through that blur learns a haze. At 1.0 the cap
    bound on the forward model's own renders too, whose 4-spp fibre grooves the photo's
    median averages (own-render random 2×3: 35.2 → 31.1 dB); 0.9 is the sharpness asked of a
    capture.
    """
    from scipy.optimize import minimize_scalar

    from ..model.render import blurred_mse

    cap = sharpness_blur(image, target, c, sharpness=sharpness)
    best = minimize_scalar(lambda s: blurred_mse(image, target, s), bounds=(0.0, c / 4), method="bounded",
                           options={"xatol": 0.02})
    sigma = min(float(best.x), cap)
    return sigma, blurred_mse(image, target, sigma)
