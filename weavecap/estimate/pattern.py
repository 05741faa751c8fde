"""Weave pattern pre-estimation (Wu et al. 2025 §5.1): annealing at temperature 0, batched.

Each cell of the grid is a binary state (1: the weft is on top). The objective is the MSE
between the forward model's render of the repeat and the photo's repeat on the same cell
canvas (:mod:`.cells`), summed over the cells with each cell's edges trimmed; by default each
rendered cell is first matched to the photo's in colour (a per-channel gain and offset,
:func:`.cells.cell_errors`), so that the states are judged by the structure of the cell —
which yarn runs across it on top — while the colours and the other parameters are still the
defaults (the paper starts from "twill and grey", Fig. 6).

At temperature 0 simulated annealing keeps a cell's flip only if it lowers the error; instead of one render per trial flip, a sweep renders a few patterns in which
many cells are flipped at once and reads, for every cell, its trimmed-cell error in both
states (:func:`anneal_pattern`). The cells whose other state fits better are flipped
together; the new pattern is kept if the objective falls, else only the half of those flips
with the largest gains is tried, and so on. A cell's look depends mostly on its own state, so
sweeps converge in a few renders: tens for a 16 × 16 repeat, not 256 per sweep.

The start is a 2/1 twill (§5.1, Fig. 6); the answer is defined up to a cyclic shift of the
repeat, as the photo's repeat may start at any yarn.

The yarn radii shape every cell (thin yarns leave wide gaps; Table 1 allows 1 to 5), so a
fabric whose radii are far off can prefer wrong states. :func:`fit_radii` picks them on a
grid by the same objective (the initializer's guess among them), and
:func:`estimate_pattern` alternates annealing and radii until the pattern stops changing.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .cells import cell_errors
from .forward import RepeatRenderer
from .sampling import interlaces

TRIM = 0.15  # fraction of each cell edge left out of its local error (neighbours reach there)


def twill_start(shape: tuple[int, int]) -> np.ndarray:
    """A 2/1 twill filling ``shape`` (wefts, warps): the default start (§5.1); a plain weave
    where a side has only 2 yarns (so that every yarn interlaces)."""
    i, j = np.indices(shape)
    period = 3 if min(shape) >= 3 else 2
    return ((i + j) % period != 0).astype(np.uint8)


@dataclass(frozen=True)
class PatternResult:
    """The pre-estimated pattern.

    Attributes
    ----------
    pattern : (n_e, n_a) uint8, 1 = weft over warp.
    error : the objective of that pattern: the mean of the cell errors (linear RGB²).
    margin : (n_e, n_a) float, the cell's error in its other state minus in its chosen state
        (> 0: the state is preferred; small values flag cells the photo barely decides).
    sweeps : sweeps made; renders : forward renders made.
    """

    pattern: np.ndarray
    error: float
    margin: np.ndarray
    sweeps: int
    renders: int


def _sublattices(shape: tuple[int, int]) -> list[np.ndarray]:
    """Four masks of cells two apart in both directions (every cell in one of them). A flip
    reaches about 2/3 of a cell along its weft and its warp (the heights' Gaussian, §5.1), so
    the cells of one mask can be flipped together and each still be judged on its own."""
    i, j = np.indices(shape)
    masks = [((i % 2 == a) & (j % 2 == b)) for a in (0, 1) for b in (0, 1)]
    return [m.astype(np.uint8) for m in masks if m.any()]


def anneal_pattern(canvas: np.ndarray, renderer: RepeatRenderer, *, start: np.ndarray | None = None,
                   max_sweeps: int = 12, polish: bool = True, interlacing: bool = True, trim: float = TRIM,
                   match_colour: bool = True, locked: np.ndarray | None = None) -> PatternResult:
    """Batched annealing at T = 0 of the renderer's pattern against ``canvas`` (§5.1).

    Two kinds of sweep read every cell's gain from a few renders: first the complement
    (1 render: every cell flipped, with its neighbours — quick, large moves), then, once those
    stop helping, four sparse sub-lattices (4 renders: each cell flipped with no neighbour
    along its yarns flipped — the gain of flipping it alone). The cells with a gain are
    flipped together and kept if the objective falls, else the better-gaining half, and so on.

    Parameters
    ----------
    canvas : (n_e * c, n_a * c, 3) linear RGB cell canvas of the photo's repeat, c the
        renderer's ``cell_px``.
    renderer : a :class:`RepeatRenderer` of the fabric (colours, radii and other parameters
        as currently believed); its pattern is replaced.
    start : (n_e, n_a) 0/1 start; default :func:`twill_start`.
    max_sweeps : at most this many sweeps.
    polish : False skips the single-flip sweeps (a quick answer while the radii are still
        being found).
    interlacing : refuse moves to patterns in which a yarn never interlaces (no woven fabric
        holds together so, §7.3; a photo with such a look is better explained otherwise), when
        the start interlaces.
    trim : fraction of each cell edge left out; match_colour : see :func:`.cells.cell_errors`.
    locked : (n_e, n_a) bool, cells never flipped (their state in ``start`` is kept): what a
        model-free vote decides with confidence (:mod:`.orientation`).

    Returns
    -------
    :class:`PatternResult` (``margin`` from the last sweep); the renderer is left
    showing the result.
    """
    shape = renderer.fabric.shape
    if canvas.shape[:2] != (shape[0] * renderer.cell_px, shape[1] * renderer.cell_px):
        raise ValueError(f"canvas {canvas.shape[:2]} does not hold {shape} cells of {renderer.cell_px} px")
    pattern = (twill_start(shape) if start is None else np.asarray(start, dtype=np.uint8)).copy()

    def errors(p: np.ndarray) -> np.ndarray:
        renderer.set_pattern(p)
        return cell_errors(renderer.render(), canvas, shape, trim=trim, match_colour=match_colour)

    err_now = errors(pattern)
    if locked is not None and np.all(locked):  # nothing may move: the margins of the pattern as it is
        margin = errors(1 - pattern) - err_now
        renderer.set_pattern(pattern)
        return PatternResult(pattern=pattern, error=float(err_now.mean()), margin=margin, sweeps=0, renders=2)
    renders, sweeps, single, margin = 1, 0, False, np.zeros(shape)
    while sweeps < max_sweeps:
        sweeps += 1
        if single:  # each cell's error with only itself (and cells two apart) flipped
            err_flip = np.zeros(shape)
            for mask in _sublattices(shape):
                err_flip = np.where(mask == 1, errors(pattern ^ mask), err_flip)
                renders += 1
        else:
            err_flip = errors(1 - pattern)
            renders += 1
        margin = err_flip - err_now
        free_margin = np.where(locked, np.inf, margin) if locked is not None else margin
        candidates = np.argsort(free_margin, axis=None)[: int(np.sum(free_margin < 0))]
        improved = False
        while candidates.size:  # T = 0: keep a batch of flips only if the objective falls
            trial = pattern.copy().ravel()
            trial[candidates] ^= 1
            trial = trial.reshape(shape)
            if interlacing and interlaces(pattern) and not interlaces(trial):
                candidates = candidates[: candidates.size // 2]
                continue
            err_trial = errors(trial)
            renders += 1
            if err_trial.mean() < err_now.mean():
                pattern, err_now, improved = trial, err_trial, True
                break
            candidates = candidates[: candidates.size // 2]
        if not improved:
            if single or not polish:
                break
            single = True
    renderer.set_pattern(pattern)
    return PatternResult(pattern=pattern, error=float(err_now.mean()), margin=margin, sweeps=sweeps,
                         renders=renders)


RADIUS_GRID = (1.0, 2.0, 3.0, 4.0, 5.0)  # Table 1: [1, 5]; then refined by ±REFINE
REFINE = 0.5


def fit_radii(canvas: np.ndarray, renderer: RepeatRenderer, *, coarse: bool = True,
              extra: tuple[float, float] | None = None, trim: float = TRIM,
              match_colour: bool = True) -> tuple[float, float]:
    """Warp and weft radii minimising the cell objective for the renderer's pattern, each in
    turn: on ``RADIUS_GRID`` (if ``coarse``) plus the current value and ``extra`` (e.g. the
    initializer's guess), then at ±``REFINE`` around the best. Each value tried is a geometry rebuild (a few
    hundred ms); the renderer keeps the result.

    Returns
    -------
    (warp radius, weft radius), Table 1 units.
    """
    shape = renderer.fabric.shape
    best = {k: float(renderer.fabric.get(k)) for k in ("warp.radius", "weft.radius")}
    lo, hi = min(RADIUS_GRID), max(RADIUS_GRID)

    def score(key: str, r: float) -> float:
        renderer.set({key: r})
        return float(cell_errors(renderer.render(), canvas, shape, trim=trim, match_colour=match_colour).mean())

    for n, key in enumerate(best):
        tries = (set(RADIUS_GRID) if coarse else set()) | {best[key]} | (
            {round(extra[n], 3)} if extra is not None else set())
        scores = {r: score(key, r) for r in sorted(tries)}
        r0 = min(scores, key=scores.get)
        scores.update({r: score(key, r) for r in (r0 - REFINE, r0 + REFINE) if lo <= r <= hi and r not in scores})
        best[key] = min(scores, key=scores.get)
        renderer.set({key: best[key]})
    return best["warp.radius"], best["weft.radius"]


def estimate_pattern(canvas: np.ndarray, renderer: RepeatRenderer, *, start: np.ndarray | None = None,
                     radii: tuple[float, float] | None = None, rounds: int = 3, trim: float = TRIM,
                     match_colour: bool = True, locked: np.ndarray | None = None) -> tuple[PatternResult, int]:
    """Anneal the pattern, fit the radii to it, and again, until the pattern is stable (§5.1).

    ``radii``: (warp, weft) also tried by the first radius fit (e.g. the initializer's guess);
    the first fit searches Table 1's whole range, later ones only around their start. The first
    anneal skips the single-flip polish (:func:`anneal_pattern`): with the radii still unknown
    it is not worth its renders. ``locked``: cells kept as in ``start`` (:func:`anneal_pattern`).

    Returns
    -------
    (the last :class:`PatternResult`, rounds made); the renderer keeps pattern and radii.
    """
    result = anneal_pattern(canvas, renderer, start=start, polish=False, trim=trim, match_colour=match_colour,
                            locked=locked)
    made = 1
    while made < rounds:
        fit_radii(canvas, renderer, coarse=made == 1, extra=radii if made == 1 else None, trim=trim,
                  match_colour=match_colour)
        again = anneal_pattern(canvas, renderer, start=result.pattern, trim=trim, match_colour=match_colour,
                               locked=locked)
        made += 1
        stable = np.array_equal(again.pattern, result.pattern)
        result = again
        if stable:
            break
    return result, made
