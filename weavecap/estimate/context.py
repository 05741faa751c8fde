"""The pattern a photo's own cells explain best: cells in the same neighbourhood look alike
(Wu et al. 2025 §5.1's question, answered without the forward model).

A cell's look is set by which yarn is on top there and by what its neighbours do: a yarn in
the middle of a float, at its end, or alone between two of the other family each look their
own way — shading where the yarn dips, shadows cast at a float's end, edges where a yarn runs
under — and every cell with the same neighbourhood looks the same way, whatever the light,
the yarns' cross-section or the camera. So a pattern can be judged on the photo alone: model
each cell's look (its crop with a margin into its neighbours, every pixel and channel) as a
sum of terms, one for the state of the cell and one for each of its four neighbours paired
with it (the cell's state against the neighbour's),

    look(cell) ≈ a + b[s] + Σ_{up, down, left, right} c_dir[s, s_dir]    (per pixel),

fitted by least squares over the repeat's cells, and score the pattern by the share of the
looks' variance it leaves unexplained, per degree of freedom left (:func:`context_misfit`).
The true pattern explains them with few terms; a wrong one puts unlike cells in one term.

What it cannot see: the face (every cell flipped explains the looks equally, the terms merely
relabelled; the edge votes tell it, :func:`weavecap.estimate.orientation.vote_residual`); and
it needs many more cells than its 10 free terms. On the final targets of the independent
bench's 18 photos (:mod:`weavecap.bench.heightfield_photos`; docs/capture.md) the best
pattern it found was the truth, up to the face, on 15; on the random 8×8 (64 cells, its two
families one colour) the truth left the looks 2.1 times less unexplained than the fitted
pattern, 15 cells off. On the 3×3 twills (9 cells) and the weft-faced satin 5 (25) it found
patterns one to seven cells off the truth that explain the looks 1.3–1.5 times better than
the truth does — which is why the fit asks for :data:`MIN_CELLS`.
"""

from __future__ import annotations

import numpy as np

#: how far each cell's crop reaches into its neighbours, share of the cell side: enough to see
#: whether a yarn runs on across the border, shadows cast over it included
MARGIN = 0.25
#: the fewest cells of a repeat the looks are judged on: the model has 10 free terms per pixel,
#: and below about 40 cells a wrong pattern can explain the looks better than the truth
#: (module docstring)
MIN_CELLS = 40


def cell_looks(canvas: np.ndarray, shape: tuple[int, int], *, margin: float = MARGIN) -> np.ndarray:
    """Every cell's crop of a repeat's canvas, with ``margin`` of its neighbours around it.

    Parameters
    ----------
    canvas : (n_e * c, n_a * c, 3) linear RGB, one repeat whose cells run from gap to gap
        (:func:`weavecap.estimate.cells.gap_aligned`); it wraps around.
    shape : (n_e, n_a) wefts and warps of the repeat.

    Returns
    -------
    (n_e * n_a, pixels) float64, row i * n_a + j the cell of weft i and warp j, in the square
    root of the linear values (closer to what the eye sees, as the edge votes use).
    """
    n_e, n_a = shape
    canvas = np.asarray(canvas, np.float64)
    if not np.isfinite(canvas).all():
        raise ValueError("the canvas must be finite (a NaN or Inf pixel has no look to compare)")
    img = np.sqrt(np.clip(canvas, 0.0, None))
    if img.ndim == 2:
        img = img[..., None]
    c_y, c_x = img.shape[0] // n_e, img.shape[1] // n_a
    m_y, m_x = int(round(margin * c_y)), int(round(margin * c_x))
    padded = np.pad(img, ((m_y, m_y), (m_x, m_x), (0, 0)), mode="wrap")
    return np.stack([padded[i * c_y:(i + 1) * c_y + 2 * m_y, j * c_x:(j + 1) * c_x + 2 * m_x].ravel()
                     for i in range(n_e) for j in range(n_a)])


def _design(pattern: np.ndarray) -> np.ndarray:
    """The model's regressors for ``pattern`` (n_e, n_a): (n_e * n_a, 19) — a constant, the
    cell's state, and for each of the four neighbours an indicator of each (state here, state
    there) pair. Rank 10 at most (the indicators of a direction sum to the constant)."""
    p = np.asarray(pattern, dtype=np.int64)
    here = p.ravel()
    columns = [np.ones(p.size), here.astype(np.float64)]
    for axis, step in ((0, 1), (0, -1), (1, 1), (1, -1)):
        there = np.roll(p, step, axis=axis).ravel()
        columns += [((here == a) & (there == b)).astype(np.float64) for a in (0, 1) for b in (0, 1)]
    return np.stack(columns, axis=1)


def looks_gram(looks: np.ndarray) -> np.ndarray:
    """The centred looks' Gram matrix (n_cells, n_cells), all :func:`context_misfit` needs."""
    y = np.asarray(looks, np.float64)
    y = y - y.mean(axis=0)
    return y @ y.T


def context_misfit(pattern: np.ndarray, gram: np.ndarray) -> float:
    """How much of the cells' looks ``pattern`` leaves unexplained: the residual variance of the
    least-squares fit of the looks on :func:`_design`, per degree of freedom left, over the
    looks' own variance (1 − the adjusted R²): 0 a perfect explanation, about 1 none; inf
    where the pattern has as many free terms as cells. ``gram``: :func:`looks_gram` of the
    looks, cells in ``pattern``'s order. Equal for a pattern and every cell flipped."""
    x = _design(pattern)
    u, s, _ = np.linalg.svd(x, full_matrices=False)
    basis = u[:, s > 1e-9 * s[0]]
    n, rank = x.shape[0], basis.shape[1]
    total = float(np.trace(gram))
    if n <= rank or total <= 0:
        return float("inf")
    residual = total - float(np.sum(basis * (gram @ basis)))
    return (residual / (n - rank)) / (total / (n - 1))


def shifted_misfit(pattern: np.ndarray, gram: np.ndarray) -> tuple[float, np.ndarray]:
    """:func:`context_misfit` of ``pattern`` at the best of its cyclic shifts (the canvas's cells
    need not be in the pattern's phase): (misfit, the pattern at that shift)."""
    p = np.asarray(pattern, dtype=np.uint8)
    n_e, n_a = p.shape
    shifts = [np.roll(p, (i, j), axis=(0, 1)) for i in range(n_e) for j in range(n_a)]
    misfits = [context_misfit(q, gram) for q in shifts]
    k = int(np.argmin(misfits))
    return misfits[k], shifts[k]


def context_pattern(gram: np.ndarray, starts: list[np.ndarray]) -> tuple[np.ndarray, float]:
    """The pattern whose :func:`context_misfit` is lowest, found by greedy single-cell flips
    (every weft and warp keeps both states) from each of ``starts`` ((n_e, n_a) each, in the
    canvas's phase): the one that lowers the misfit most, until none does. Returns (pattern
    (n_e, n_a) uint8, its misfit); of a pattern and its every cell flipped, the one reached."""
    from .sampling import descend_by_flips, interlacing

    best = (None, np.inf)
    for start in starts:
        if not interlacing(np.asarray(start)):
            continue
        p, misfit = descend_by_flips(start, lambda stack: np.array([context_misfit(q, gram) for q in stack]))
        if misfit < best[1]:
            best = (p, misfit)
    if best[0] is None:
        raise ValueError("no start interlaces (a repeat needs at least 2 wefts and 2 warps)")
    return best[0], float(best[1])
