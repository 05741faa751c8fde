"""Minimum repeat size (Wu et al. 2025 §4.3): superposed distance matching functions.

The distance matching function (DMF) of a row r at shift τ is the mean squared difference
between r(x) and r(x + τ) [ANB12]. Summed over all rows (and, for the other axis, all
columns) it dips to ~0 at every whole number of repeats. A photo that holds a single repeat
has no dip; that is reported as such rather than as an error.

The number of yarns in the repeat is decided on the cells of the yarn grid rather than on
pixels (:func:`cell_dmf`, :func:`cell_repeat`): a pixel DMF also compares what the weave does
not set — plies and fibres whose phase along a yarn is not the repeat's, gaps that repeat at
every yarn — and then dips nearly as deep at a divisor or a multiple of the repeat. The pixel
DMF (:func:`superposed_dmf`) then only refines the repeat's length in pixels.
"""

from __future__ import annotations

import numpy as np


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


def detrend_cells(cells: np.ndarray) -> np.ndarray:
    """Remove from every cell feature its smooth drift across the photo (a quadratic in the
    cell indices): lighting and view angle change the look of a yarn slowly, the weave does
    not, and a drift would make the DMF grow with the shift."""
    c = np.asarray(cells, np.float64)
    ny, nx, nf = c.shape
    i, j = np.meshgrid(np.linspace(-1, 1, ny), np.linspace(-1, 1, nx), indexing="ij")
    basis = np.stack([np.ones_like(i), i, j, i * i, j * j, i * j], axis=-1).reshape(-1, 6)
    flat = c.reshape(-1, nf)
    coef, *_ = np.linalg.lstsq(basis, flat, rcond=None)
    return (flat - basis @ coef).reshape(ny, nx, nf)


def cell_dmf(cells: np.ndarray, *, axis: int, max_shift: int) -> tuple[np.ndarray, np.ndarray]:
    """The DMF of the yarn-grid cells: mean squared difference of cell features ``n`` yarns apart.

    The pixel DMF of §4.3 compares everything down to the fibres; a forward-model render or a
    real yarn carries plies and fibres whose phase along the yarn is not that of the weave, and
    gaps that repeat at every yarn. Compared cell by cell
    (:func:`~weavecap.prepare.grid.cell_features`) only what the weave sets is left: which yarn
    is on top, and how it is shaded. What varies along the shift axis alone (one weft brighter
    than the next) is removed first: it says nothing about the repeat. Each feature is then
    weighed by how well it repeats at its best shift, ``(1 - min_n d_f(n))²``: a feature that
    repeats at no shift (the speckle of a gap, fibres) is noise, not weave.

    Parameters
    ----------
    cells : (Ny, Nx, F) features of the cells (rows are wefts, columns warps), detrended.
    axis : 0 compares cells ``n`` wefts apart (the repeat along y), 1 ``n`` warps apart.
    max_shift : largest ``n`` (≥ 2).

    Returns
    -------
    (dmf, se): (max_shift + 1,) arrays, the weighted mean squared difference at each shift,
    each feature divided by twice its variance (≈ 1 for unrelated cells, 0 for a perfect
    repeat), and its standard error over the cell pairs compared.
    """
    c = np.asarray(cells, np.float64)
    if axis == 1:
        c = c.transpose(1, 0, 2)
    # per-yarn offsets along the shift axis say nothing about the repeat; those across it
    # cancel in every difference and would only swell the variance
    c = c - c.mean(axis=1, keepdims=True) - c.mean(axis=0, keepdims=True) + c.mean(axis=(0, 1))
    c = c / np.sqrt(np.maximum(2 * (c ** 2).mean(axis=(0, 1)), 1e-12))
    n = c.shape[0]
    shifts = range(1, min(max_shift, n - 1) + 1)
    pairs = [((c[k:] - c[:n - k]) ** 2).reshape(-1, c.shape[2]) for k in shifts]
    per_feature = np.array([p.mean(axis=0) for p in pairs])  # (shifts, F)
    w = np.clip(1.0 - per_feature[1:].min(axis=0), 0.0, 1.0) ** 2
    w = w / w.sum() if w.sum() > 0 else np.full_like(w, 1.0 / w.size)
    d, se = [0.0], [0.0]
    for p in pairs:
        v = p @ w
        d.append(float(v.mean()))
        se.append(float(v.std() / np.sqrt(v.size)))
    return np.array(d), np.array(se)


def multiple_contrast(dmf: np.ndarray) -> np.ndarray:
    """How well each shift ``n`` explains the DMF as a repeat: how far the DMF dips at every
    multiple of ``n`` below the shifts one yarn to either side, on average (§4.3).

    A repeat of ``n`` yarns makes the DMF dip at ``n`` *and at every multiple of it*. A shift
    that merely resembles the weave nearby (a twill's diagonal step, which a herringbone's
    reversals undo a few yarns further on) dips at ``n`` but not at its multiples. A divisor of
    the repeat that is no repeat itself dips only at some of its multiples. Either way its
    contrast is lower than the repeat's; a multiple of the repeat ties with it.

    Parameters
    ----------
    dmf : (N + 1,) DMF at shifts 0…N (shift 0 is not used).

    Returns
    -------
    (N + 1,) array: entry ``n`` ≥ 2 is the mean over the multiples ``m·n ≤ N`` of the mean DMF
    at ``m·n ± 1`` (the one inside 1…N at ``N``) less that at ``m·n`` (same units as the DMF);
    entries 0 and 1 are -inf.
    """
    d = np.asarray(dmf, np.float64)
    top = len(d) - 1
    out = np.full(len(d), -np.inf)
    for n in range(2, top + 1):
        dips = [np.mean([d[k - 1]] + ([d[k + 1]] if k < top else [])) - d[k] for k in range(n, top + 1, n)]
        out[n] = float(np.mean(dips))
    return out


def cell_repeat(cells: np.ndarray, *, axis: int, max_yarns: int, tol: float, z: float,
                min_depth: float) -> tuple[int | None, float, np.ndarray]:
    """The minimum repeat along one axis, in yarns, from the cell DMF (§4.3).

    Only shifts up to half the cells are compared (a repeat must show twice). With d* the
    lowest DMF (at two yarns or more: a weave interlaces) and d⁺ the highest, a repeat shows
    when 1 - d*/d⁺ reaches ``min_depth`` and d⁺ - d* is ``z`` standard errors. The repeat is
    then, of the shifts whose DMF lies within ``tol·(d⁺ - d*)`` of d*, the fewest yarns whose
    dips at all its multiples (:func:`multiple_contrast`) are as deep, within the same margin,
    as the deepest such: a shift that is not a multiple of the repeat changes whole cells (a
    twill of n shifted by n - 1 still changes two cells in n), and every multiple of the
    repeat dips too.

    Returns
    -------
    (yarns or None, depth, dmf): depth = 1 - d*/d⁺; None when no repeat shows (the photo holds
    at most one repeat along this axis).
    """
    n_all = cells.shape[axis]
    nmax = min(max_yarns, n_all // 2)
    if nmax < 2:
        return None, 0.0, np.ones(1)
    d, se = cell_dmf(detrend_cells(cells), axis=axis, max_shift=nmax)
    k_best, k_top = 2 + int(np.argmin(d[2:])), 1 + int(np.argmax(d[1:]))
    best, top = float(d[k_best]), float(d[k_top])
    depth = 1.0 - best / max(top, 1e-12)
    if depth < min_depth or top - best < z * (se[k_best] + se[k_top]):
        return None, depth, d
    low, slack = _low_shifts(d, tol)
    c = multiple_contrast(d)
    n = next(k for k in low if c[k] >= max(c[low]) - slack)
    return n, depth, d


def _low_shifts(dmf: np.ndarray, tol: float) -> tuple[list[int], float]:
    """The shifts ≥ 2 whose DMF lies within ``tol·(d⁺ - d*)`` of the lowest d* (d⁺ the
    highest, over shifts ≥ 1), and that margin (:func:`cell_repeat`)."""
    d = np.asarray(dmf, np.float64)
    best, top = float(d[2:].min()), float(d[1:].max())
    slack = tol * (top - best)
    return [k for k in range(2, len(d)) if d[k] <= best + slack], slack


def complement_repeats(yarns: list[int | None], dmfs: list[np.ndarray], *, tol: float) -> list[int | None]:
    """The repeats per axis (y, x) with a 2-yarn repeat doubled where the look is that of a
    2/2 twill whose warp and weft floats look alike (§4.3).

    A 2/2 twill shifted by two yarns along either axis is its complement (every warp float
    becomes a weft float); where the photo does not tell the two floats apart — one grey
    yarn, floats shorter than the blur resolves — its cells repeat over 2 yarns along both
    axes, the look of a plain weave. A plain weave also repeats over 2 along both axes; a
    herringbone (Brodatz D16) or a broken twill does only within a leg: its reversals undo
    the 2-yarn match a few yarns on, so the DMF of that axis dips at 2 as deep as at its
    repeat, which is longer (:func:`multiple_contrast` chose it). A 2-yarn repeat across
    such an axis is then ambiguous between a weave of 2 yarns and a 2/2 twill base of 4,
    and it is doubled: a 4-yarn repeat holds a 2-yarn one, so the fit, whose model tells a
    warp float from a weft float by its shape, can still find either.

    Parameters
    ----------
    yarns : the cells' repeat per axis (None: none shown).
    dmfs : the cell DMF of each axis (:func:`cell_repeat`'s third value).
    tol : the margin of :func:`cell_repeat` (``cell_tol``).
    """
    out = list(yarns)
    for i in (0, 1):
        j = 1 - i
        n_other, d_other = yarns[j], np.asarray(dmfs[j], np.float64)
        if yarns[i] == 2 and n_other is not None and n_other > 2 and len(d_other) > 2 \
                and 2 in _low_shifts(d_other, tol)[0]:
            out[i] = 4
    return out


def orientation_features(cells: np.ndarray, *, sub: int) -> np.ndarray:
    """The direction of each block's edges, from the cell features of
    :func:`~weavecap.prepare.grid.cell_features` (whose last ``2·sub²`` entries are the blocks'
    mean |∂x| and |∂y|): (|∂x| − |∂y|) / (|∂x| + |∂y|) per block, +1 where the edges run along
    y (a warp on top), −1 along x (a weft on top).

    Which yarn is on top sets it, not the yarns' colours or brightness: a yarn-dyed stripe
    or check leaves it as it is, so the weave's repeat shows in it where the colours repeat
    over other numbers of yarns.

    Returns
    -------
    (Ny, Nx, sub·sub) float64.
    """
    c = np.asarray(cells, np.float64)
    grads = c[..., -2 * sub * sub:].reshape(c.shape[0], c.shape[1], sub * sub, 2)
    gx, gy = grads[..., 0], grads[..., 1]
    return (gx - gy) / np.maximum(gx + gy, 1e-12)
