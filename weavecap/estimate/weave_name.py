"""Names of weaves for people (the comparisons up to a cyclic shift they rest on are in
:mod:`weavecap.estimate.repeats`).

A pattern (wefts, warps), 1 = weft over warp, is named after its minimum repeat:

- ``plain``;
- ``twill a/b`` (each weft passes over ``a`` warps and under ``b``; a > b is weft-faced) with
  its direction: ``Z`` when the diagonal rises to the right ("/"), ``S`` when it falls ("\\");
- ``satin n/s``: n × n, one interlacing per yarn, moving ``s`` warps per weft (s ≠ ±1,
  coprime with n), ``weft-faced`` or ``warp-faced``; ``satin n/s extended a/b``: a satin's
  derivative whose rows hold one run of ``a`` raised cells (``b`` lowered, both > 1), each row
  the last moved by ``s`` (the extended or reinforced satins of weaving handbooks);
- ``basket a/b`` (a × b blocks of plain weave: a hopsack where a = b) and ``rib`` (plain
  weave with yarns doubled in one direction);
- ``herringbone a/b, legs of k warps`` (a broken twill: the twill a/b turned back every k
  warps, cut at the turn) and ``point twill a/b, legs of k warps`` (turned back without the cut,
  a zigzag), or ``… wefts`` when the legs are groups of wefts;
- ``custom n×m`` otherwise.

Every name is invariant to cyclic shifts of the repeat (the photo's repeat may start at any
yarn) and to repeating it.
"""

from __future__ import annotations

from functools import lru_cache
from math import gcd

import numpy as np

from .repeats import canonical, cyclic_shifts, equal_up_to_shift, minimal_repeat, shift_agreement

__all__ = ["weave_name", "weave_family", "FAMILIES", "canonical", "cyclic_shifts", "equal_up_to_shift",
           "minimal_repeat", "shift_agreement"]


def _moving_run(p: np.ndarray) -> str | None:
    """A twill, or an extended satin: a square ``p`` whose first row is one run of ones and one
    of zeros (cyclically) and whose every row moves the last by the same step s
    (``p[i] == roll(p[0], s i)``): s = ±1 is a twill; s coprime with n otherwise, on at least
    5 × 5 with runs of at least 2, an extended satin (one raised cell a row is a plain satin,
    :func:`_satin`)."""
    n = p.shape[0]
    if n < 3 or p.shape != (n, n):
        return None
    row = p[0]
    ones = int(row.sum())
    if not 0 < ones < n or int(np.sum(row != np.roll(row, 1))) != 2:
        return None
    steps = [s for s in range(n) if all(np.array_equal(p[i], np.roll(row, s * i)) for i in range(n))]
    for step, direction in ((1, "S"), (n - 1, "Z")):
        if step in steps:
            return f"twill {ones}/{n - ones} {direction}"
    satin_steps = [s for s in steps if 1 < s < n - 1 and gcd(s, n) == 1]
    if n >= 5 and 1 < ones < n - 1 and satin_steps:
        return f"satin {n}/{satin_steps[0]} extended {ones}/{n - ones}"
    return None


def _satin(p: np.ndarray) -> str | None:
    n = p.shape[0]
    if n < 5 or p.shape != (n, n):
        return None
    for face, points in (("weft-faced", p == 0), ("warp-faced", p == 1)):
        if np.all(points.sum(axis=1) == 1) and np.all(points.sum(axis=0) == 1):
            cols = np.argmax(points, axis=1)
            step = int((cols[1] - cols[0]) % n)
            if step not in (1, n - 1) and gcd(step, n) == 1 and np.all((np.diff(cols) % n) == step):
                return f"satin {n}/{step} {face}"
    return None


def _blocks(p: np.ndarray) -> str | None:
    plain = np.array([[1, 0], [0, 1]], dtype=np.uint8)
    n_e, n_a = p.shape
    if n_e % 2 or n_a % 2:
        return None
    ke, ka = n_e // 2, n_a // 2
    block = np.kron(plain, np.ones((ke, ka), dtype=np.uint8))
    if not equal_up_to_shift(p, block):
        return None
    if min(ke, ka) == 1:
        return f"rib {max(ke, ka)} ({'wefts' if ke > 1 else 'warps'} doubled)"
    return f"basket {ke}/{ka}"


@lru_cache(maxsize=None)
def _broken_names(shape: tuple[int, int]) -> dict:
    """canonical key → name of every herringbone and point twill of a repeat ``shape``."""
    from .sampling import broken_twills

    names: dict = {}
    for kind, over, under, leg, along, q in broken_twills(shape):
        names.setdefault(canonical(q), f"{kind} {over}/{under}, legs of {leg} {along}")
    return names


def _broken_twill(p: np.ndarray) -> str | None:
    """A herringbone or a point twill (:func:`weavecap.estimate.sampling.broken_twills`) at any
    phase, legs of warps or of wefts."""
    return _broken_names(p.shape).get(canonical(p))


def weave_name(pattern: np.ndarray) -> str:
    """A name for people: ``plain``, ``twill 2/1 Z``, ``satin 5/2 weft-faced``, ``basket 2/2``,
    ``rib 2 (wefts doubled)``, ``herringbone 2/2, legs of 4 warps`` or ``custom 4×6`` (the
    minimum repeat's wefts × warps)."""
    p = minimal_repeat(pattern)
    if p.shape == (2, 2) and p[0, 0] == p[1, 1] != p[0, 1] == p[1, 0]:
        return "plain"
    if p.shape == (1, 1) or min(p.shape) == 1:
        return f"custom {p.shape[0]}×{p.shape[1]} (yarns that never interlace)"
    for namer in (_moving_run, _satin):
        # try every cyclic shift of the rows: a twill or satin is recognised from any start
        for i in range(p.shape[0]):
            name = namer(np.roll(p, i, axis=0))
            if name:
                return name
    return _blocks(p) or _broken_twill(p) or f"custom {p.shape[0]}×{p.shape[1]}"


#: the weave families a name belongs to (a broken twill is a twill, an extended satin a satin)
FAMILIES = ("plain", "twill", "satin", "basket", "rib", "custom")


def weave_family(name: str) -> str:
    """The family of a :func:`weave_name`: one of :data:`FAMILIES` (``herringbone`` and
    ``point twill`` are twills)."""
    first = name.split()[0]
    if first in ("herringbone", "point"):
        return "twill"
    return first if first in FAMILIES else "custom"
