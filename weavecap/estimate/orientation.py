"""A model-free vote per cell on which yarn is on top (Wu et al. 2025 §5.1's question).

§5.1 anneals the pattern against the forward model: a cell's state is the one whose render
explains the photo better. When the model's render differs from the photo (another shading,
another exposure), that comparison can be a coin toss. A photo shows the answer without any
model: the yarn on top runs on through the crossing, so its edges do — a weft on top keeps
the gap lines above and below it unbroken across the cell, while the warp's side edges stop
at its borders, hidden under it; a warp on top the other way round. So a cell's vote
compares the edge strength along its top and bottom borders (|∂I/∂y| in a band about each,
over the middle of the side) with that along its left and right borders (|∂I/∂x|):

    v = (E_horizontal − E_vertical) / (E_horizontal + E_vertical)   ∈ [−1, 1],

positive where the weft is on top (pattern 1), negative for the warp. Shading inside a yarn
(its highlight, ply grooves, where it dips under the next yarn) does not enter: only the
borders count. The cells must run from gap to gap (:func:`weavecap.fit.target.gap_phase`).
On the independent bench photos (:mod:`weavecap.bench.heightfield_photos`) the votes alone give the
whole pattern, face and direction included, on 8 of 18 and 93% of the cells of the repeats
preparation found right; the structure tensor of the cell's centre (the first cue tried)
gave 1 of 11: a weft dipping under a warp puts strong vertical edges inside its own cell.

The votes' signs alone mislead: a yarn's neighbours lay their edges on its borders too (a warp
cell between weft floats votes about 0, not −1), and the light shades one axis's edges more.
:func:`expected_votes` predicts a pattern's votes from the edges it lays on each border, and
:func:`decode_pattern` finds the pattern that explains a photo's votes best; the fit's end stage
weighs it against the fitted pattern (:func:`weavecap.fit.rounds.edge_check`).
"""

from __future__ import annotations

import numpy as np

BAND = 0.15  # half-width of the band about a cell border, share of the cell side
SPAN = 0.5  # middle share of each border that counts (not the corners, where both gaps cross)


def cell_votes(canvas: np.ndarray, shape: tuple[int, int], *, band: float = BAND, span: float = SPAN) -> np.ndarray:
    """The edge-continuity vote of every cell of a repeat's canvas.

    Parameters
    ----------
    canvas : (n_e * c, n_a * c, 3) linear RGB, one repeat with cell borders on the gaps
        between yarns (:func:`weavecap.estimate.cells.cell_canvas`); the canvas wraps around.
    shape : (n_e, n_a) wefts and warps of the repeat.

    Returns
    -------
    (n_e, n_a) float in [−1, 1]: > 0 the weft is on top, < 0 the warp; 0 for a flat cell.
    """
    img = np.sqrt(np.clip(np.asarray(canvas, np.float64), 0.0, None))  # closer to what the eye sees
    if img.ndim == 2:
        img = img[..., None]
    n_e, n_a = shape
    c_y, c_x = img.shape[0] // n_e, img.shape[1] // n_a
    gx = np.abs(0.5 * (np.roll(img, -1, axis=1) - np.roll(img, 1, axis=1))).sum(axis=2)
    gy = np.abs(0.5 * (np.roll(img, -1, axis=0) - np.roll(img, 1, axis=0))).sum(axis=2)
    by, bx = max(1, int(round(band * c_y))), max(1, int(round(band * c_x)))
    y0, y1 = int(round(c_y * (1 - span) / 2)), c_y - int(round(c_y * (1 - span) / 2))
    x0, x1 = int(round(c_x * (1 - span) / 2)), c_x - int(round(c_x * (1 - span) / 2))
    # bands centred on each cell's top border (rows −by..by) and left border (columns −bx..bx)
    top = np.roll(gy, by, axis=0).reshape(n_e, c_y, n_a, c_x)[:, :2 * by, :, x0:x1].sum(axis=(1, 3))
    left = np.roll(gx, bx, axis=1).reshape(n_e, c_y, n_a, c_x)[:, y0:y1, :, :2 * bx].sum(axis=(1, 3))
    horizontal = top + np.roll(top, -1, axis=0)  # top and bottom borders
    vertical = left + np.roll(left, -1, axis=1)  # left and right borders
    total = horizontal + vertical
    return np.where(total > 1e-20, (horizontal - vertical) / np.maximum(total, 1e-20), 0.0)


def aligned_votes(canvas: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """:func:`cell_votes` of a canvas whose cells need not run from gap to gap: it is first
    rolled (it wraps) by :func:`weavecap.estimate.cells.gap_phase`, whole pixels."""
    from .cells import gap_aligned

    return cell_votes(gap_aligned(canvas, shape), shape)


def vote_pattern(votes: np.ndarray) -> np.ndarray:
    """The pattern the votes give (1 where the weft is on top)."""
    return (np.asarray(votes) > 0).astype(np.uint8)


def agreement(pattern: np.ndarray, votes: np.ndarray) -> float:
    """How well ``pattern`` agrees with the votes: the vote-weighted share of cells whose state
    the votes back, in [0, 1] (0.5 when the votes say nothing)."""
    v = np.asarray(votes, np.float64)
    total = float(np.abs(v).sum())
    if total <= 0:
        return 0.5
    signed = np.where(np.asarray(pattern) == 1, v, -v)
    return float(0.5 + 0.5 * signed.sum() / total)


# ------------------------------------------------------------------ what a pattern's votes look like

#: the ratio of the two axes' edge strengths that :func:`vote_residual` allows (the light's
#: direction shades one family's edges more than the other's, and the gaps between wefts need
#: not be as wide as those between warps): e^±1.2, about 1/3.3 to 3.3
AXIS_GAINS = np.exp(np.linspace(-1.2, 1.2, 25))
#: edge strength a border shows without any yarn edge on it (texture, noise), in yarn edges
EDGE_FLOOR = 0.3


def border_edges(pattern: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """How many yarn edges each cell's borders hold, by the pattern alone: (horizontal,
    vertical), each (n_e, n_a) in 0..4.

    A weft on top lays its two edges (top and bottom) along its cell's horizontal borders, and
    a warp on top its two along the vertical ones; a yarn underneath hides its edges there. So
    the horizontal border between two cells of a column holds one edge for each of the two
    that has its weft on top (0, 1 or 2), and the vertical border between two cells of a row
    one for each that has its warp on top. A cell's horizontal count is that of its top and
    bottom borders, its vertical count that of its left and right ones: a weft in the middle
    of a float scores (4, 0), a float's end (3, 1), a lone warp between weft floats (2, 2) —
    which is why the edge votes of a twill 3/1's warp cells sit near 0, not −1. ``pattern``
    may be a stack, (..., n_e, n_a)."""
    p = np.asarray(pattern, dtype=np.int64)
    w = 1 - p
    between_rows = p + np.roll(p, -1, axis=-2)  # the border below each cell
    between_cols = w + np.roll(w, -1, axis=-1)  # the border right of each cell
    horizontal = between_rows + np.roll(between_rows, 1, axis=-2)
    vertical = between_cols + np.roll(between_cols, 1, axis=-1)
    return horizontal.astype(np.float64), vertical.astype(np.float64)


def expected_votes(pattern: np.ndarray, gain: float = 1.0, floor: float = EDGE_FLOOR) -> np.ndarray:
    """The votes (:func:`cell_votes`) a photo of ``pattern`` shows when a horizontal edge is
    ``gain`` times as strong as a vertical one and every border shows ``floor`` edges of
    texture: (g (H + f) − (V + f)) / (g (H + f) + (V + f)) with (H, V) of
    :func:`border_edges`; (n_e, n_a) in (−1, 1)."""
    horizontal, vertical = border_edges(pattern)
    h, v = gain * (horizontal + floor), vertical + floor
    return (h - v) / (h + v)


def vote_misfit(patterns: np.ndarray, votes: np.ndarray) -> np.ndarray:
    """How far ``votes`` ((n_e, n_a), :func:`cell_votes`) are from what each of ``patterns``
    ((..., n_e, n_a), in the votes' own phase) would show: the mean squared difference from
    :func:`expected_votes` at the best of :data:`AXIS_GAINS`; (...,), 0 a perfect match."""
    v = np.asarray(votes, np.float64)
    expected = expected_votes(np.asarray(patterns)[None], AXIS_GAINS.reshape((-1,) + (1,) * np.ndim(patterns)))
    return np.mean((expected - v) ** 2, axis=(-2, -1)).min(axis=0)


def vote_residual(pattern: np.ndarray, votes: np.ndarray) -> float:
    """:func:`vote_misfit` of ``pattern`` (same shape as ``votes``) at the best of its cyclic
    shifts (the votes' phase need not be the pattern's). Lower is better.

    Unlike :func:`agreement` it reads the votes' pattern across the cells, not their signs: the
    light and the gaps make one axis's edges stronger on a whole photo (the independent bench's
    twills vote "weft on top" in every cell, 0.0 to 0.95), which the gain absorbs, while a
    twill 3/1 and its other face 1/3 stay apart — the one puts 4 edges on a float's horizontal
    borders and none on its vertical ones, the other the reverse."""
    p = np.asarray(pattern)
    if p.shape != np.shape(votes):
        raise ValueError(f"pattern {p.shape} and votes {np.shape(votes)} differ in shape")
    n_e, n_a = p.shape
    shifts = np.stack([np.roll(p, (i, j), axis=(0, 1)) for i in range(n_e) for j in range(n_a)])
    return float(vote_misfit(shifts, votes).min())


def decode_pattern(votes: np.ndarray) -> tuple[np.ndarray, float]:
    """The pattern whose :func:`expected_votes` explain ``votes`` ((n_e, n_a), finite) best,
    found without any model of the yarns' looks: greedy single-cell flips (every weft and warp
    keeps both states) from the votes cut at each of their values (an offset hides the sign,
    not the order), from a diagonal each way and from a checkerboard; the lowest
    :func:`vote_misfit` wins. Returns (pattern (n_e, n_a) uint8 in the votes' phase, its
    misfit). On the final targets of the independent bench photos it
    gave the true pattern on 17 of 18, faces, directions and a random 6×6 included (the fits
    had 7 wrong); the random 8×8's target was too far off to vote."""
    from .sampling import descend_by_flips, interlacing

    v = np.asarray(votes, np.float64)
    if v.ndim != 2 or not np.isfinite(v).all():
        raise ValueError(f"votes must be a finite (wefts, warps) array, got shape {v.shape}")
    starts = [(v > t).astype(np.uint8) for t in np.unique(v)[:-1]]
    i, j = np.indices(v.shape)  # a diagonal each way and a checkerboard: no cut may interlace
    starts += [((j + d * i) % v.shape[1] < v.shape[1] / 2).astype(np.uint8) for d in (1, -1)]
    starts.append(((i + j) % 2).astype(np.uint8))
    seen, best = set(), (None, np.inf)
    for start in starts:
        if start.tobytes() in seen or not interlacing(start):
            continue
        seen.add(start.tobytes())
        p, misfit = descend_by_flips(start, lambda stack: vote_misfit(stack, v))
        if misfit < best[1]:
            best = (p, misfit)
    if best[0] is None:
        raise ValueError("no interlacing pattern fits these votes (a repeat needs at least 2 wefts and 2 warps)")
    return best[0].astype(np.uint8), best[1]
