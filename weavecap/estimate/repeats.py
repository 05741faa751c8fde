"""Weave patterns compared up to a cyclic shift: a photo's repeat may start at any yarn.

A pattern is (wefts, warps), 1 = weft over warp. The named weaves
(:mod:`weavecap.estimate.weave_name`), their library (:mod:`weavecap.estimate.sampling`) and
the pattern decision compare patterns with these.
"""

from __future__ import annotations

import numpy as np


def minimal_repeat(pattern: np.ndarray) -> np.ndarray:
    """The smallest block whose tiling is ``pattern`` (which tiles to it)."""
    p = np.asarray(pattern, dtype=np.uint8)
    n_e, n_a = p.shape
    rows = next(k for k in range(1, n_e + 1) if n_e % k == 0 and np.array_equal(p, np.roll(p, k, axis=0)))
    cols = next(k for k in range(1, n_a + 1) if n_a % k == 0 and np.array_equal(p, np.roll(p, k, axis=1)))
    return p[:rows, :cols].copy()


def shift_agreement(a: np.ndarray, b: np.ndarray) -> tuple[float, tuple[int, int]]:
    """Largest fraction of equal cells of ``a`` and a cyclic shift of ``b`` (same shape), and
    that shift (rows, cols) such that ``np.roll(b, shift, axis=(0, 1))`` matches best."""
    a, b = np.asarray(a), np.asarray(b)
    if a.shape != b.shape:
        raise ValueError(f"patterns differ in shape: {a.shape} and {b.shape}")
    best, best_shift = -1.0, (0, 0)
    for i in range(a.shape[0]):
        for j in range(a.shape[1]):
            agree = float(np.mean(a == np.roll(b, (i, j), axis=(0, 1))))
            if agree > best:
                best, best_shift = agree, (i, j)
    return best, best_shift


def canonical(pattern: np.ndarray) -> tuple:
    """A key equal for two patterns exactly when they tile the same fabric up to a cyclic
    shift: the minimal repeat's shape and the smallest of its cyclic shifts' bytes."""
    p = minimal_repeat(pattern)
    shifts = cyclic_shifts(p).reshape(p.size, -1)
    return p.shape, min(r.tobytes() for r in shifts)


def cyclic_shifts(pattern: np.ndarray) -> np.ndarray:
    """Every cyclic shift of ``pattern`` (n_e, n_a): (n_e * n_a, n_e, n_a), shift (i, j) at
    i * n_a + j being ``np.roll(pattern, (i, j), axis=(0, 1))``."""
    p = np.asarray(pattern)
    n_e, n_a = p.shape
    i = (np.arange(n_e)[None, None, :, None] - np.arange(n_e)[:, None, None, None]) % n_e
    j = (np.arange(n_a)[None, None, None, :] - np.arange(n_a)[None, :, None, None]) % n_a
    return np.ascontiguousarray(p[i, j].reshape(n_e * n_a, n_e, n_a))


def equal_up_to_shift(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether two patterns tile the same fabric, up to a cyclic shift."""
    return canonical(a) == canonical(b)
