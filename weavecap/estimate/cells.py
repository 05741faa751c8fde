"""Cells of one weave repeat: resampling a photo onto a regular cell canvas (Wu et al. §5).

The preparation stage (§4.4) gives the boundaries of the cells of one minimum repeat in the
regularized photo: ``rows`` (n_e + 1,) y positions between wefts and ``cols`` (n_a + 1,) x
positions between warps, in pixels, ascending (cells may differ in size). Every estimator of
this package works on a *cell canvas*: that repeat resampled so that each cell is exactly
``cell_px`` × ``cell_px`` pixels, which is also the layout of a forward-model render of one
repeat (``View(tiles=(1, 1), size=cell_px * max(n_e, n_a))``: cell (i, j) covers rows
``i*cell_px .. (i+1)*cell_px`` and columns ``j*cell_px ..``).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np


@dataclass(frozen=True)
class CellGrid:
    """Cell boundaries of one repeat in an image, pixels (y for ``rows``, x for ``cols``).

    Attributes
    ----------
    rows : (n_e + 1,) float array, ascending: the top of each weft's cell, then the bottom.
    cols : (n_a + 1,) float array, ascending: the left of each warp's cell, then the right.
    """

    rows: np.ndarray
    cols: np.ndarray

    def __post_init__(self):
        for name in ("rows", "cols"):
            b = np.asarray(getattr(self, name), dtype=np.float64)
            if b.ndim != 1 or b.size < 2 or np.any(np.diff(b) <= 0):
                raise ValueError(f"{name} must be at least two ascending boundaries, got {b!r}")
            object.__setattr__(self, name, b)

    @property
    def shape(self) -> tuple[int, int]:
        """(wefts, warps) of the repeat."""
        return self.rows.size - 1, self.cols.size - 1

    @classmethod
    def regular(cls, shape: tuple[int, int], cell_px: float, origin: tuple[float, float] = (0.0, 0.0)) -> "CellGrid":
        """Evenly spaced cells of ``cell_px`` from ``origin`` (y, x), e.g. a render's grid."""
        n_e, n_a = shape
        return cls(rows=origin[0] + cell_px * np.arange(n_e + 1), cols=origin[1] + cell_px * np.arange(n_a + 1))


def _axis_map(bounds: np.ndarray, cell_px: int) -> np.ndarray:
    """Source coordinate (pixel-centre convention) of each canvas pixel along one axis."""
    n = bounds.size - 1
    t = (np.arange(n * cell_px) + 0.5) / cell_px  # position in cells
    return np.interp(t, np.arange(n + 1), bounds) - 0.5


def cell_canvas(image: np.ndarray, grid: CellGrid, cell_px: int, offset: np.ndarray | None = None) -> np.ndarray:
    """Resample the repeat of ``image`` inside ``grid`` so that every cell is ``cell_px`` square.

    Parameters
    ----------
    image : (H, W, 3) float linear RGB, holding the repeat (cells outside it are read with
        reflection at the image border).
    grid : the repeat's cell boundaries in ``image`` pixels.
    cell_px : side of a cell on the canvas, pixels.
    offset : optional (2, n_e * cell_px, n_a * cell_px) displacement (dy, dx) in ``image``
        pixels added to where each canvas pixel is read (a lattice that is not quite regular:
        :func:`weavecap.fit.target.read_repeat`).

    Returns
    -------
    (n_e * cell_px, n_a * cell_px, 3) float32 linear RGB. Shrinking is area-averaged (the
    image is blurred to the canvas's sampling first), enlarging is bilinear.
    """
    img = np.asarray(image, dtype=np.float32)
    scale = min(np.diff(grid.rows).min(), np.diff(grid.cols).min()) / cell_px
    if scale > 1.5:  # shrink: prefilter so that bilinear sampling does not alias
        img = cv2.GaussianBlur(img, (0, 0), 0.5 * np.sqrt(scale * scale - 1.0), borderType=cv2.BORDER_REFLECT)
    ys = _axis_map(grid.rows, cell_px).astype(np.float32)
    xs = _axis_map(grid.cols, cell_px).astype(np.float32)
    map_x, map_y = np.meshgrid(xs, ys)
    if offset is not None:
        map_y = map_y + np.asarray(offset[0], dtype=np.float32)
        map_x = map_x + np.asarray(offset[1], dtype=np.float32)
    return cv2.remap(img, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)


def _cell_blocks(canvas: np.ndarray, shape: tuple[int, int], trim: float) -> np.ndarray:
    """(n_e, n_a, pixels, C) trimmed cell contents of an (n_e * c, n_a * c, C) canvas."""
    n_e, n_a = shape
    c = canvas.shape[0] // n_e
    lo, hi = int(round(trim * c)), c - int(round(trim * c))
    blocks = np.asarray(canvas, dtype=np.float64).reshape(n_e, c, n_a, c, -1)[:, lo:hi, :, lo:hi]
    return blocks.transpose(0, 2, 1, 3, 4).reshape(n_e, n_a, (hi - lo) ** 2, -1)


def cell_errors(render: np.ndarray, photo: np.ndarray, shape: tuple[int, int], *, trim: float = 0.1,
                match_colour: bool = False) -> np.ndarray:
    """Per-cell mean squared difference of a render and a photo canvas, edges trimmed.

    With ``match_colour`` the render's cell is first given, per channel, the offset and the
    non-negative gain that fit the photo's cell best (least squares): what is left is the
    error of the cell's *structure* — which yarn lies on top, how its shading runs — and not
    of colours or brightness the fabric's parameters do not yet match.

    Returns
    -------
    (n_e, n_a) float64, linear RGB² per pixel and channel.
    """
    r = _cell_blocks(render, shape, trim)
    p = _cell_blocks(photo, shape, trim)
    if not match_colour:
        return np.square(r - p).mean(axis=(2, 3))
    r = r - r.mean(axis=2, keepdims=True)
    p = p - p.mean(axis=2, keepdims=True)
    rr = np.square(r).sum(axis=2)
    rp = (r * p).sum(axis=2)
    gain = np.where(rr > 1e-12, np.maximum(rp, 0.0) / np.maximum(rr, 1e-12), 0.0)
    residual = np.square(p).sum(axis=2) - gain * rp
    return residual.mean(axis=2) / r.shape[2]


def wrap_window(canvas: np.ndarray, shape: tuple[int, int], cells: int) -> np.ndarray:
    """A ``cells`` × ``cells`` window of the infinite tiling of a repeat's canvas, from cell (0, 0).

    Parameters
    ----------
    canvas : (n_e * c, n_a * c, ...) array of one repeat; shape : (n_e, n_a).

    Returns
    -------
    (cells * c, cells * c, ...) array.
    """
    n_e, n_a = shape
    c = canvas.shape[0] // n_e
    reps = (-(-cells // n_e), -(-cells // n_a)) + (1,) * (canvas.ndim - 2)
    return np.tile(canvas, reps)[: cells * c, : cells * c]


def gap_phase(canvas: np.ndarray, shape: tuple[int, int]) -> tuple[float, float]:
    """Where the gaps between yarns lie in a repeat's canvas, model-free: (y, x) in canvas px
    within one cell, (0, 0) when the cells already run from gap to gap.

    A gap is a thin line, dark under a front light and bright under a back light; either way
    the luminance curves sharply across it, while a yarn, many pixels wide, curves gently. So
    the mean |∂²I/∂x²| down the canvas (|∂²I/∂y²| across it), folded over the cells and
    smoothed, peaks at the warp (weft) gaps whatever their brightness — where §4.4's valleys
    of the projection are the gaps only under a front light. The peak is located to a
    fraction of a pixel by a parabola. ``canvas`` (n_e*c, n_a*c, 3) wraps around.
    """
    from scipy.ndimage import gaussian_filter, gaussian_filter1d

    n_e, n_a = shape
    c_y, c_x = canvas.shape[0] // n_e, canvas.shape[1] // n_a
    y = np.sqrt(np.clip(np.asarray(canvas, np.float64), 0.0, None))
    y = y.mean(axis=2) if y.ndim == 3 else y
    y = gaussian_filter(y, max(0.7, min(c_y, c_x) / 24), mode="wrap")
    out = []
    for axis, n, c_ in ((0, n_e, c_y), (1, n_a, c_x)):
        curv = np.abs(np.roll(y, -1, axis) - 2 * y + np.roll(y, 1, axis)).mean(axis=1 - axis)
        prof = gaussian_filter1d(curv.reshape(n, c_).sum(axis=0), c_ / 12, mode="wrap")
        out.append(_circular_peak(prof) % c_)
    return out[0], out[1]


def gap_aligned(canvas: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """``canvas`` rolled (it wraps) by :func:`gap_phase`, whole pixels, so that its cells run
    from gap to gap."""
    gy, gx = gap_phase(canvas, shape)
    return np.roll(canvas, (-int(round(gy)), -int(round(gx))), axis=(0, 1))


def _circular_peak(values: np.ndarray) -> float:
    """Index of the maximum of a circular 1-D array, to a fraction of a sample: the vertex of
    the parabola through it and its two neighbours (the integer index where that is flat)."""
    i = int(np.argmax(values))
    a, b, d = values[(i - 1) % values.size], values[i], values[(i + 1) % values.size]
    den = a - 2 * b + d
    return i + (0.5 * (a - d) / den if den < 0 else 0.0)


def mirror_phase(canvas: np.ndarray, shape: tuple[int, int]) -> tuple[float, float]:
    """Where the repeat's projections are mirror-symmetric, model-free: (y, x) in canvas px,
    each in [0, c/2), c the cell side; 0 when the cell borders (or the cell centres) are
    already on a centre of symmetry.

    A yarn's cross-section, and the gap between two yarns, are each symmetric about their
    middle, whatever the light: the canvas's row means folded over the cells (and its column
    means) are mirror-symmetric about the gaps and about the yarn centres, two centres half a
    cell apart, so this finds the gap lattice up to half a cell (:func:`weavecap.fit.target.align_cells`
    decides which half). Unlike :func:`gap_phase` (the sharpest curvature: a gap's edge where
    the gap is wide, a yarn centre where the yarns are thin and round) it has no bias from the
    gap's width. A profile ``f`` with ``f(i) = f(k - i)`` maximises the circular
    autoconvolution ``(f * f)(k)``; the peak is located to a fraction of a pixel by a parabola
    and the centre is ``k / 2`` (pixel i's centre at i + 0.5). ``canvas`` (n_e*c, n_a*c, ...)
    wraps around; a flat projection gives 0.
    """
    n_e, n_a = shape
    grey = np.asarray(canvas, np.float64)
    grey = grey.mean(axis=2) if grey.ndim == 3 else grey
    out = []
    for axis, n in ((0, n_e), (1, n_a)):
        prof = grey.mean(axis=1 - axis)
        c_ = prof.size // n
        f = prof[: n * c_].reshape(n, c_).mean(axis=0)
        f = f - f.mean()
        if not np.any(np.abs(f) > 1e-9):
            out.append(0.0)
            continue
        spec = np.fft.rfft(f)
        k = _circular_peak(np.fft.irfft(spec * spec, c_))
        out.append(float((k / 2.0 + 0.5) % (c_ / 2.0)))
    return out[0], out[1]


def repeat_deviation(image: np.ndarray, cell_px: int, repeat: tuple[int, int],
                     first: tuple[int, int] = (0, 0)) -> tuple[np.ndarray, np.ndarray]:
    """What of ``image`` differs between the repeats in view: (deviation, seen).

    ``image`` is (Y·c, X·c) or (Y·c, X·c, C) over whole cells of ``cell_px`` pixels, its cell
    (v, u) showing the repeat's cell ((v + v0) mod n_e, (u + u0) mod n_a) of ``repeat`` =
    (n_e, n_a) and ``first`` = (v0, u0). The deviation is each pixel less its mean over the
    views of its repeat cell, times √(k / (k − 1)) for k views (so that its variance estimates
    the variance about the true mean, as a sample's does); ``seen`` (Y·c, X·c) is where a cell
    is seen at least twice (elsewhere the deviation is 0: one view has no mean to differ from).
    """
    c = int(cell_px)
    n_e, n_a = (int(v) for v in repeat)
    a = np.asarray(image, np.float64)
    rows, cols = a.shape[0] // c, a.shape[1] // c
    a = a[:rows * c, :cols * c]
    blocks = a.reshape(rows, c, cols, c, -1).transpose(0, 2, 1, 3, 4).reshape(rows * cols, c, c, -1)
    which = ((np.arange(rows)[:, None] + first[0]) % n_e * n_a + (np.arange(cols)[None, :] + first[1]) % n_a).ravel()
    count = np.bincount(which, minlength=n_e * n_a).astype(np.float64)[which][:, None, None, None]
    total = np.zeros((n_e * n_a, *blocks.shape[1:]))
    np.add.at(total, which, blocks)
    dev = np.where(count >= 2, (blocks - total[which] / count) * np.sqrt(count / np.maximum(count - 1, 1)), 0.0)
    dev = dev.reshape(rows, cols, c, c, -1).transpose(0, 2, 1, 3, 4).reshape(a.shape[0], a.shape[1], -1)
    seen = (count[:, 0, 0, 0] >= 2).reshape(rows, cols).repeat(c, 0).repeat(c, 1)
    return dev.reshape(a.shape), seen
