"""Per-thread body colours of a yarn-dyed fabric, as Dr.Jit lookups by thread index.

A fabric with ``threads`` (:class:`weavecap.params.Threads`) gives each warp end and weft pick
the body colours R^B, S^B (Wu et al. 2025 §3.3) of its entry in the family's colour order; the
colour repeat tiles on its own, apart from the weave's. A render reads them by the index of the
thread it hit in the tiled fabric — one :func:`drjit.gather` from a table of the colour repeat's
threads, no kernel per colour and no new kernel for a new colour order (the table and its
length are read from memory). The tables are plain Dr.Jit arrays, so a render is
differentiable in them as in any other colour.

Thread indices count like the pattern: warp ``j`` is column ``j`` of the tiled fabric (any
integer, negative to the left of the repeat at the origin), weft ``i`` row ``i``; thread ``j``
wears entry ``sequence[j mod L]`` of a colour repeat of ``L`` threads.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..params import Fabric
from . import bysdf as _bysdf

mi = _bysdf.mi
dr = _bysdf.dr

FAMILIES = ("warp", "weft")


@dataclass
class ThreadTable:
    """One family's body colours per thread of its colour repeat (Dr.Jit, opaque).

    Attributes
    ----------
    reflection, subsurface : Color3f of width L, R^B and S^B of each thread of the repeat
    repeat : L, as an opaque Float (a new colour order compiles nothing; thread indices are
        wrapped in floating point, exact below 2²⁴: an integer division's masked-off lanes
        can divide by zero in a Mitsuba virtual call, which the CPU traps)
    cumulative_reflection, cumulative_subsurface : Color3f of width L + 1, the running sums of
        ``reflection`` and ``subsurface`` (for :meth:`box_mean`)
    """

    reflection: object
    subsurface: object
    repeat: object
    cumulative_reflection: object
    cumulative_subsurface: object

    def turns(self, index):
        """How many whole colour repeats lie left of thread ``index`` (Float, an integer value):
        ``floor(index / L)``."""
        return dr.floor(index / self.repeat)

    def wrap(self, index):
        """``index`` (Float, an integer value, any sign) into the colour repeat: ``index mod L``
        as a UInt32 in [0, L)."""
        m = index - self.repeat * self.turns(index)
        return mi.UInt32(dr.clip(m, 0.0, self.repeat - 1.0))

    def at(self, index):
        """(R^B, S^B) of the threads at ``index`` (thread indices of the tiled fabric, Int32 or
        an integer-valued Float)."""
        k = self.wrap(mi.Float(index))
        return dr.gather(mi.Color3f, self.reflection, k), dr.gather(mi.Color3f, self.subsurface, k)

    def at_position(self, x):
        """(R^B, S^B) at ``x`` (Float), a position across the family in threads: thread
        ``floor(x)``."""
        return self.at(dr.floor(x))

    def box_mean(self, x, half):
        """(R^B, S^B) averaged over the threads covering ``[x - half, x + half]`` (Float, in
        threads), each by the length it covers: the colour a footprint of that width sees.
        Exact box filtering by the running sums (two gathers per end); a point lookup where
        ``half`` is (nearly) zero."""
        lo, hi = x - half, x + half
        width = dr.maximum(hi - lo, 1e-6)
        out = []
        for per_thread, cumulative in ((self.reflection, self.cumulative_reflection),
                                       (self.subsurface, self.cumulative_subsurface)):
            total = dr.gather(mi.Color3f, cumulative, mi.UInt32(self.repeat))

            def running(y):  # Σ of the colours of threads left of position y (y in threads)
                whole = dr.floor(y)
                m = self.wrap(whole)
                inside = dr.gather(mi.Color3f, cumulative, m)
                return self.turns(whole) * total + inside + (y - whole) * dr.gather(mi.Color3f, per_thread, m)

            mean = (running(hi) - running(lo)) / width
            point = dr.gather(mi.Color3f, per_thread, self.wrap(dr.floor(x)))
            out.append(dr.select(half > 1e-4, mean, point))
        return out[0], out[1]


def thread_table(per_thread_reflection: np.ndarray, per_thread_subsurface: np.ndarray) -> ThreadTable:
    """A :class:`ThreadTable` from (L, 3) arrays of each thread's R^B and S^B."""
    r = np.asarray(per_thread_reflection, np.float64).reshape(-1, 3)
    s = np.asarray(per_thread_subsurface, np.float64).reshape(-1, 3)

    def colours(a: np.ndarray):
        value = mi.Color3f(*(a[:, c].astype(np.float32) for c in range(3)))
        dr.make_opaque(value)
        return value

    zero = np.zeros((1, 3))
    table = ThreadTable(reflection=colours(r), subsurface=colours(s), repeat=dr.opaque(mi.Float, r.shape[0]),
                        cumulative_reflection=colours(np.concatenate([zero, np.cumsum(r, axis=0)])),
                        cumulative_subsurface=colours(np.concatenate([zero, np.cumsum(s, axis=0)])))
    return table


def thread_tables(fabric: Fabric) -> dict[str, ThreadTable]:
    """The :class:`ThreadTable` of each family of ``fabric`` that has a colour order
    (``"warp"``, ``"weft"``); empty for a fabric without thread colours."""
    if fabric.threads is None:
        return {}
    out = {}
    for name in FAMILIES:
        order = fabric.threads.family(name)
        if order is not None:
            out[name] = thread_table(order.per_thread("body_reflection"), order.per_thread("body_subsurface"))
    return out


def surface_colours(tables: dict[str, ThreadTable], shape: tuple[int, int], s, t, half=None) -> dict:
    """Per family with a colour order, (R^B, S^B) at fabric coordinates ``(s, t)`` (Float, in
    weave repeats: ``s`` along +u across the warps, ``t`` along +v up across the wefts, weft 0
    at the top of the repeat at t ∈ [0, 1]; :mod:`weavecap.render.surface`'s convention), of
    the (n_e, n_a) repeat ``shape``: warp ``floor(s n_a)``, weft ``floor((1 - t) n_e)``, as the
    forward model counts them. With ``half`` (Float, half a footprint's side in yarn pitches)
    the colours are box means over the threads the footprint covers
    (:meth:`ThreadTable.box_mean`)."""
    n_e, n_a = shape
    out = {}
    for family, position in (("warp", s * n_a), ("weft", (1.0 - t) * n_e)):
        table = tables.get(family)
        if table is not None:
            out[family] = table.at_position(position) if half is None else table.box_mean(position, half)
    return out
