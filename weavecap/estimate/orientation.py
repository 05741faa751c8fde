"""A model-free vote per cell on which yarn is on top (issue 11; Wu et al. 2025 §5.1's question).

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
On the independent bench photos (:mod:`weavecap.heightfield_photos`) the votes alone give the
whole pattern, face and direction included, on 8 of 18 and 93% of the cells of the repeats
preparation found right; the structure tensor of the cell's centre (the first cue tried)
gave 1 of 11: a weft dipping under a warp puts strong vertical edges inside its own cell.
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
    from .cells import gap_phase

    gy, gx = gap_phase(canvas, shape)
    return cell_votes(np.roll(canvas, (-int(round(gy)), -int(round(gx))), axis=(0, 1)), shape)


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

