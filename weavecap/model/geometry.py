"""Yarn geometry from a weave pattern: Algorithm 1 (Appendix A) and §5.1 of Wu et al. 2025.

Coordinates (world units are those of Algorithm 1, where radii lie in Table 1's [1, 5]):

- the fabric lies in the plane z = 0, the camera looks down -z;
- warp ``j`` runs along +y at ``x = (j + 0.5) * PITCH``; weft ``i`` runs along +x at
  ``y = (i + 0.5) * PITCH``; image rows grow with +y, columns with +x, so row ``i`` of the
  pattern is weft ``i`` from the top and column ``j`` is warp ``j`` from the left;
- ``pattern[i, j] == 1``: weft ``i`` passes over warp ``j``.

Algorithm 1 spaces the yarns by their diameters; here the pitch is fixed at
``PITCH = 2 * max radius`` (10 units) and the radius sets the gap between yarns, as §3.3
("Yarn Gaps") describes: radius 5 closes the gaps, radius 1 leaves wide ones. Heights follow
§5.1: ``CONTROL_POINTS_PER_CELL`` (12) control points per cell take the cell's up/down state,
smoothed by a Gaussian of σ = 1 control point (window 16), cyclically so repeats tile; the top
yarn's centre is ``+h/2`` and the bottom one's ``-h/2`` with ``h = r_a + r_e`` (touching).

Thick yarns bend more tightly than they are thick where they dive under a crossing yarn (the
axis's radius of curvature is 2.2 units at r = 1, 1.5 at r = 2.5, 1.2 at r = 5): there a swept
circle would fold over itself, so :func:`sweep_tubes` flattens the inside of such bends.

Why tube meshes and not Mitsuba's ``bsplinecurve``: measured by ``scripts/measure_geometry.py``
on our scenes (the same camera and shadow rays cast against both; 2-core machine), tubes took
12 ms warm for a 128² repeat at 4 spp and 150 ms for a 512² 4×4-repeat photo, curves 660 ms
and 19 s — 50-120× slower — with 98% of rays hitting the same yarn. Tubes also carry texture
coordinates for the procedural plies and fibres, build from numpy in milliseconds (curves load
only from files in Mitsuba 3.9.1) and have back faces, which the exit-point rays of the
transmission lobe need (curve back faces are culled). Neither gives usable radius gradients
without projective sampling, so radii are differentiated by finite differences
(:func:`weavecap.model.render.radius_gradient`).
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import groupby

import numpy as np
from scipy.ndimage import gaussian_filter1d

PITCH = 10.0  # distance between neighbouring yarn centres, in Algorithm 1 units
CONTROL_POINTS_PER_CELL = 12  # §5.1
HEIGHT_SIGMA = 1.0  # §5.1: Gaussian of standard deviation 1 control point ...
HEIGHT_TRUNCATE = 8.0 / HEIGHT_SIGMA  # ... and size 16 (radius 8)
SAMPLES_PER_CELL = 8  # spline evaluations per cell along a yarn when sweeping the tube
RING = 10  # vertices around a tube's cross-section
BEND_MARGIN = 0.9  # a tube's inner side keeps at most this fraction of the bend's radius from its axis
PAD_CELLS = 1  # extra cells at each end of a yarn so that splines reach past the frame


@dataclass(frozen=True)
class YarnCurves:
    """Control points of every yarn of a patch of the fabric (Algorithm 1's c_e, c_a).

    Attributes
    ----------
    weft, warp : list of (K, 3) float arrays
        Control points of each weft (along +x) and each warp (along +y), world units.
    weft_index, warp_index : (n,) int arrays
        Which row (weft) or column (warp) of the tiled fabric each yarn is.
    """

    weft: list[np.ndarray]
    warp: list[np.ndarray]
    weft_index: np.ndarray
    warp_index: np.ndarray


def crossover_height(r_warp: float, r_weft: float) -> float:
    """Vertical distance h between the centres of crossing yarns: they touch (§5.1, App. A)."""
    return float(r_warp + r_weft)


def smoothed_heights(states: np.ndarray) -> np.ndarray:
    """Cyclic up/down profile of one yarn, one value in [0, 1] per control point (§5.1).

    Parameters
    ----------
    states : (n,) array of 0/1
        1 where this yarn is on top at each successive crossing.

    Returns
    -------
    (n * CONTROL_POINTS_PER_CELL,) float array in [0, 1].
    """
    raw = np.repeat(np.asarray(states, dtype=np.float64), CONTROL_POINTS_PER_CELL)
    return gaussian_filter1d(raw, HEIGHT_SIGMA, mode="wrap", truncate=HEIGHT_TRUNCATE)


def control_points(pattern: np.ndarray, *, r_warp: float, r_weft: float,
                   rows: tuple[int, int] | None = None, cols: tuple[int, int] | None = None) -> YarnCurves:
    """Algorithm 1 for a window of the fabric tiled from ``pattern``.

    Parameters
    ----------
    pattern : (n_e, n_a) array of 0/1
        The minimum repeat; any size from 1×1 to 64×64, square or not.
    r_warp, r_weft : float
        Yarn radii r_a, r_e (Table 1: [1, 5]); they set the crossover height.
    rows, cols : (start, stop), optional
        Which wefts and warps of the infinite tiling to build (default: one repeat). Indices
        may be negative or exceed the repeat; the pattern is read modulo its size.

    Returns
    -------
    YarnCurves
        Each yarn's control points span its window plus ``PAD_CELLS`` cells at both ends.
    """
    pattern = np.asarray(pattern, dtype=np.uint8)
    if pattern.ndim != 2 or pattern.size == 0:
        raise ValueError(f"pattern must be a non-empty 2-D array, got shape {pattern.shape}")
    n_e, n_a = pattern.shape
    r0, r1 = rows if rows is not None else (0, n_e)
    c0, c1 = cols if cols is not None else (0, n_a)
    h = crossover_height(r_warp, r_weft)
    k = CONTROL_POINTS_PER_CELL

    def profile(seq: np.ndarray, start: int, stop: int) -> tuple[np.ndarray, np.ndarray]:
        """Heights along a yarn whose crossings repeat with ``seq``, from cell start-PAD to stop+PAD."""
        period = smoothed_heights(seq)  # one period, control points at cell offsets (m + 0.5) / k
        lo, hi = start - PAD_CELLS, stop + PAD_CELLS
        idx = np.arange(lo * k, hi * k)
        t = (idx + 0.5) / k  # position along the yarn in cells
        return t * PITCH, (period[idx % period.size] - 0.5) * h

    weft, weft_index = [], np.arange(r0, r1)
    for i in weft_index:
        along, z = profile(pattern[i % n_e, :], c0, c1)
        weft.append(np.stack([along, np.full_like(along, (i + 0.5) * PITCH), z], axis=1))
    warp, warp_index = [], np.arange(c0, c1)
    for j in warp_index:
        along, z = profile(1 - pattern[:, j % n_a], r0, r1)
        warp.append(np.stack([np.full_like(along, (j + 0.5) * PITCH), along, z], axis=1))
    return YarnCurves(weft=weft, warp=warp, weft_index=weft_index, warp_index=warp_index)


def bspline(points: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray]:
    """Evaluate a uniform cubic B-spline and its derivative at ``count`` even parameter steps.

    Parameters
    ----------
    points : (..., K, 3) control points, K >= 4 (a stack of curves of K points each)
    count : number of evaluations from the start to the end of the curve (>= 2)

    Returns
    -------
    positions, derivatives : (..., count, 3) arrays (derivative per unit of control-point index)
    """
    k = points.shape[-2]
    t = np.linspace(0.0, k - 3, count)
    seg = np.minimum(t.astype(int), k - 4)
    u = (t - seg)[:, None]
    p0, p1, p2, p3 = (points[..., seg + o, :] for o in range(4))
    pos = ((1 - u) ** 3 * p0 + (3 * u**3 - 6 * u**2 + 4) * p1 + (-3 * u**3 + 3 * u**2 + 3 * u + 1) * p2
           + u**3 * p3) / 6.0
    der = (-(1 - u) ** 2 * p0 + (3 * u**2 - 4 * u) * p1 + (-3 * u**2 + 2 * u + 1) * p2 + u**2 * p3) / 2.0
    return pos, der


@dataclass(frozen=True)
class TubeMesh:
    """Triangle tubes swept along yarn splines, ready for ``mi.Mesh``.

    Attributes
    ----------
    positions, normals : (V, 3) float32
    texcoords : (V, 2) float32
        u = position along the yarn's axis / (2π r) (one unit ≈ one circumference), v = angle / 2π.
    faces : (F, 3) uint32, counter-clockwise seen from outside
    """

    positions: np.ndarray
    normals: np.ndarray
    texcoords: np.ndarray
    faces: np.ndarray


def bend_limits(points: np.ndarray, count: int, up: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """How far a tube may reach from its axis towards each side of a bend without folding.

    Parameters
    ----------
    points : (..., K, 3) control points of a yarn (or a stack of yarns), in a vertical plane
    count : rings along the yarn (:func:`bspline`'s ``count``)
    up : (..., count, 3) each ring's unit normal in the yarn's plane

    Returns
    -------
    above, below : (..., count) the largest offsets along ``+up`` and ``-up``: ``BEND_MARGIN`` ×
        the tightest radius of curvature, within half a ring spacing either side, of a bend whose
        centre lies on that side (inf where the axis bends the other way or not at all)
    """
    fine = 8
    pos, der = bspline(points, (count - 1) * fine + 1)
    tangent = der / np.linalg.norm(der, axis=-1, keepdims=True)
    ds = np.linalg.norm(np.gradient(pos, axis=-2), axis=-1)
    curvature = np.gradient(tangent, axis=-2) / ds[..., None]  # points to the centre of the bend
    up_fine = np.repeat(up, fine, axis=-2)[..., : pos.shape[-2], :]
    toward_up = np.sum(curvature * up_fine, axis=-1)
    padded = np.pad(toward_up, [(0, 0)] * (toward_up.ndim - 1) + [(fine // 2, fine // 2)], mode="edge")
    window = np.lib.stride_tricks.sliding_window_view(padded, fine + 1, axis=-1)
    bend_up, bend_down = window.max(axis=-1)[..., ::fine], -window.min(axis=-1)[..., ::fine]
    with np.errstate(divide="ignore"):
        return (np.where(bend_up > 0, BEND_MARGIN / bend_up, np.inf),
                np.where(bend_down > 0, BEND_MARGIN / bend_down, np.inf))


def sweep_tubes(curves: list[np.ndarray], radius: float, *, side: np.ndarray,
                samples_per_cell: int = SAMPLES_PER_CELL, ring: int = RING) -> TubeMesh:
    """Sweep a circle of ``radius`` along each yarn's B-spline into one triangle mesh.

    Where the axis bends more tightly than the tube is thick (a thick yarn diving under a
    crossing one: at r = 5 the bend's radius is ~1.2 units, at r = 2.5 ~1.5), a swept circle
    folds over itself on the inside of the bend. There the cross-section's reach towards the
    bend's centre is held to ``BEND_MARGIN`` of the bend's radius (:func:`bend_limits`): the
    inner side is flattened, as a yarn squeezed in a bend is, and keeps the circle's shading
    normals (it is mostly hidden under the crossing yarn). Everywhere else, and wherever the
    tube is thinner than ``BEND_MARGIN`` of the bend's radius, the rings are the circle's.

    Parameters
    ----------
    curves : list of (K, 3) control-point arrays, each in a vertical plane
    radius : float, tube radius in world units (> 0)
    side : (3,) unit vector normal to the yarns' plane ((0, 1, 0) for wefts, (1, 0, 0) for warps)
    """
    if radius <= 0 or not np.isfinite(radius):
        raise ValueError(f"radius must be a positive finite number, got {radius}")
    angles = np.linspace(0.0, 2 * np.pi, ring, endpoint=False)
    cos_a, sin_a = np.cos(angles), np.sin(angles)
    side = np.asarray(side, dtype=np.float64)
    pos_all, nrm_all, uv_all, faces_all = [], [], [], []
    offset = 0
    # yarns of the same length (all of a family, in a window) are swept together: (Y, K, 3)
    for length, run in groupby(curves, key=len):
        cp = np.stack(list(run))
        cells = (length - 3) / CONTROL_POINTS_PER_CELL
        s_count = max(2, int(round(cells * samples_per_cell)) + 1)
        pos, der = bspline(cp, s_count)  # (Y, s_count, 3)
        tangent = der / np.linalg.norm(der, axis=-1, keepdims=True)
        up = np.cross(side, tangent)  # in the yarn's vertical plane, pointing up (+z-ish)
        turned = up[..., 2].mean(axis=-1) < 0  # (Y,)
        up = np.where(turned[:, None, None], -up, up)
        # u from the absolute position along the yarn's axis, not the arc from the window's
        # start: the plies then sit at the same place whatever window of the fabric is built
        arc = pos @ np.abs(np.cross(side, (0.0, 0.0, 1.0)))
        n = (up[:, :, None, :] * cos_a[None, None, :, None] + side * sin_a[None, None, :, None])
        above, below = bend_limits(cp, s_count, up)
        reach_up = np.clip(radius * cos_a, -below[..., None], above[..., None])  # (Y, rings, ring)
        p = pos[:, :, None, :] + reach_up[..., None] * up[:, :, None, :] + (radius * sin_a)[:, None] * side
        uv = np.stack(np.broadcast_arrays((arc / (2 * np.pi * radius))[..., None], angles / (2 * np.pi)), axis=-1)
        pos_all.append(p.reshape(-1, 3))
        nrm_all.append(n.reshape(-1, 3))
        uv_all.append(uv.reshape(-1, 2))
        a = np.arange(s_count - 1)[:, None] * ring + np.arange(ring)[None, :]
        b = np.arange(s_count - 1)[:, None] * ring + (np.arange(ring)[None, :] + 1) % ring
        c, d = a + ring, b + ring
        quads = np.stack([a, c, b, b, c, d], axis=-1).reshape(-1, 3)
        # meshes are one-sided: a face's normal (c - a) × (b - a), along the yarn × around the
        # ring (from up towards side), is -cross(side, tangent): outward where up was turned
        outward = np.where(turned[:, None, None], quads, quads[:, [0, 2, 1]])
        starts = offset + np.arange(cp.shape[0]) * (s_count * ring)
        faces_all.append((outward + starts[:, None, None]).reshape(-1, 3))
        offset += cp.shape[0] * s_count * ring
    return TubeMesh(positions=np.concatenate(pos_all).astype(np.float32),
                    normals=np.concatenate(nrm_all).astype(np.float32),
                    texcoords=np.concatenate(uv_all).astype(np.float32),
                    faces=np.concatenate(faces_all).astype(np.uint32))


def fabric_meshes(pattern: np.ndarray, *, r_warp: float, r_weft: float,
                  rows: tuple[int, int], cols: tuple[int, int]) -> tuple[TubeMesh, TubeMesh]:
    """Weft and warp tube meshes of the window ``rows`` × ``cols`` of the tiled fabric."""
    curves = control_points(pattern, r_warp=r_warp, r_weft=r_weft, rows=rows, cols=cols)
    wefts = sweep_tubes(curves.weft, r_weft, side=np.array([0.0, 1.0, 0.0]))
    warps = sweep_tubes(curves.warp, r_warp, side=np.array([1.0, 0.0, 0.0]))
    return wefts, warps
