"""Tests for weavecap.model.geometry: yarns from any weave pattern (Algorithm 1, §5.1) lie where
the pattern says, cross without passing through each other, tile seamlessly, and sweep into
valid, outward-facing tube meshes."""

from __future__ import annotations

import numpy as np
import pytest

from weavecap.model import geometry as g

RNG = np.random.default_rng(7)
PATTERNS = {
    "plain-2x2": np.array([[1, 0], [0, 1]]),
    "twill-3x3": np.array([[1, 1, 0], [0, 1, 1], [1, 0, 1]]),
    "non-square-3x5": np.array([[1, 0, 0, 1, 0], [0, 1, 0, 0, 1], [1, 1, 0, 1, 0]]),
    "one-cell": np.array([[1]]),
    "all-0": np.zeros((3, 4), dtype=int),
    "all-1": np.ones((4, 3), dtype=int),
    "satin-5": np.roll(np.eye(5, dtype=int), 2, axis=1)[np.arange(5) * 2 % 5],
    "random-64x64": RNG.integers(0, 2, (64, 64)),
}
RADII = [(1.0, 1.0), (5.0, 5.0), (1.0, 5.0), (5.0, 1.0)]  # (warp, weft): the ends of Table 1


def height_at(points: np.ndarray, along: int, coord: float) -> float:
    """Height z of a yarn's B-spline where its coordinate ``along`` (0 = x, 1 = y) is ``coord``."""
    pos, _ = g.bspline(points, 40 * points.shape[0])
    return float(np.interp(coord, pos[:, along], pos[:, 2]))


@pytest.mark.parametrize("name", PATTERNS)
def test_control_points_count_and_placement(name):
    """One curve per weft and per warp, at the pitch, spanning the repeat plus padding."""
    pattern = PATTERNS[name]
    n_e, n_a = pattern.shape
    curves = g.control_points(pattern, r_warp=2.0, r_weft=3.0)
    assert len(curves.weft) == n_e and len(curves.warp) == n_a
    k = g.CONTROL_POINTS_PER_CELL
    for i, cp in enumerate(curves.weft):
        assert cp.shape == ((n_a + 2 * g.PAD_CELLS) * k, 3)
        assert np.all(cp[:, 1] == (i + 0.5) * g.PITCH)
        assert np.all(np.diff(cp[:, 0]) > 0)
    for j, cp in enumerate(curves.warp):
        assert cp.shape == ((n_e + 2 * g.PAD_CELLS) * k, 3)
        assert np.all(cp[:, 0] == (j + 0.5) * g.PITCH)
        assert np.all(np.diff(cp[:, 1]) > 0)


@pytest.mark.parametrize("r_warp, r_weft", RADII)
@pytest.mark.parametrize("name", [n for n in PATTERNS if n != "random-64x64"])
def test_over_yarn_lies_above_under_yarn_at_every_crossing(name, r_warp, r_weft):
    """At each crossing the yarn the pattern puts on top is higher by r_a + r_e: they touch and
    do not pass through each other."""
    pattern = PATTERNS[name]
    curves = g.control_points(pattern, r_warp=r_warp, r_weft=r_weft)
    h = g.crossover_height(r_warp, r_weft)
    assert h == r_warp + r_weft
    for i, weft in enumerate(curves.weft):
        for j, warp in enumerate(curves.warp):
            z_weft = height_at(weft, 0, (j + 0.5) * g.PITCH)
            z_warp = height_at(warp, 1, (i + 0.5) * g.PITCH)
            over, under = (z_weft, z_warp) if pattern[i, j] else (z_warp, z_weft)
            assert over - under == pytest.approx(h, rel=1e-3), (i, j)


@pytest.mark.parametrize("name, weft_z", [("all-0", -0.5), ("all-1", 0.5), ("one-cell", 0.5)])
def test_uniform_patterns_give_flat_yarns(name, weft_z):
    """With no alternation the yarns are straight: wefts at ±h/2 and warps opposite."""
    curves = g.control_points(PATTERNS[name], r_warp=2.0, r_weft=4.0)
    for cp in curves.weft:
        np.testing.assert_allclose(cp[:, 2], weft_z * 6.0, atol=1e-12)
    for cp in curves.warp:
        np.testing.assert_allclose(cp[:, 2], -weft_z * 6.0, atol=1e-12)


@pytest.mark.parametrize("name", ["plain-2x2", "non-square-3x5", "satin-5", "one-cell"])
def test_height_profile_tiles_across_repeats(name):
    """Repeats are identical and windows agree where they overlap, so tiles join without seams."""
    pattern = PATTERNS[name]
    n_e, n_a = pattern.shape
    k = g.CONTROL_POINTS_PER_CELL
    two = g.control_points(pattern, r_warp=2.0, r_weft=2.0, rows=(-n_e, n_e), cols=(-n_a, n_a))
    one = g.control_points(pattern, r_warp=2.0, r_weft=2.0)
    for i in range(n_e):
        z = two.weft[i][:, 2]
        np.testing.assert_allclose(z[: n_a * k], z[n_a * k: 2 * n_a * k], atol=1e-12)
        np.testing.assert_allclose(two.weft[i + n_e][:, 2], z, atol=1e-12)
        np.testing.assert_allclose(one.weft[i], two.weft[i + n_e][n_a * k:], atol=1e-12)
    for j in range(n_a):
        z = two.warp[j][:, 2]
        np.testing.assert_allclose(z[: n_e * k], z[n_e * k: 2 * n_e * k], atol=1e-12)
        np.testing.assert_allclose(one.warp[j], two.warp[j + n_a][n_e * k:], atol=1e-12)


def test_smoothed_heights_keep_range_and_mean():
    """The §5.1 smoothing stays in [0, 1], keeps the fraction of 'up' and is cyclic."""
    states = np.array([1, 0, 0, 1, 1, 0, 0])
    z = g.smoothed_heights(states)
    assert z.shape == (states.size * g.CONTROL_POINTS_PER_CELL,)
    assert z.min() >= 0 and z.max() <= 1
    assert z.mean() == pytest.approx(states.mean())
    np.testing.assert_allclose(g.smoothed_heights(np.roll(states, 2)), np.roll(z, 2 * g.CONTROL_POINTS_PER_CELL))


def test_bspline_reproduces_lines_and_constants():
    """Known answers: a uniform cubic B-spline of evenly spaced collinear points is that line,
    with derivative one step per unit of parameter; of equal points, a point."""
    points = np.stack([np.arange(8.0), 2 * np.arange(8.0), np.full(8, 3.0)], axis=1)
    pos, der = g.bspline(points, 11)
    t = np.linspace(0, 5, 11)
    np.testing.assert_allclose(pos, np.stack([t + 1, 2 * (t + 1), np.full(11, 3.0)], axis=1), atol=1e-12)
    np.testing.assert_allclose(der, np.tile([1.0, 2.0, 0.0], (11, 1)), atol=1e-12)
    pos, der = g.bspline(np.ones((4, 3)), 5)
    np.testing.assert_allclose(pos, 1.0)
    np.testing.assert_allclose(der, 0.0, atol=1e-12)


def ring_centres(mesh: g.TubeMesh) -> np.ndarray:
    """The centre of every vertex's ring of ``RING`` vertices."""
    rings = mesh.positions.astype(np.float64).reshape(-1, g.RING, 3)
    return np.repeat(rings.mean(axis=1), g.RING, axis=0)


def axis_points(curves: list[np.ndarray]) -> np.ndarray:
    """The tube axis point of every vertex: where its yarn's B-spline is at its ring."""
    points = []
    for cp in curves:
        rings = max(2, int(round((cp.shape[0] - 3) / g.CONTROL_POINTS_PER_CELL * g.SAMPLES_PER_CELL)) + 1)
        points.append(np.repeat(g.bspline(cp, rings)[0], g.RING, axis=0))
    return np.concatenate(points)


def check_mesh(mesh: g.TubeMesh, radius: float, curves: list[np.ndarray]) -> None:
    """Finite, valid indices, non-degenerate faces, every vertex within ``radius`` of its ring's
    axis point (at it but on the inner side of a bend tighter than the tube is thick), unit
    normals pointing away from the axis, texcoord ranges."""
    v, n, uv, f = mesh.positions, mesh.normals, mesh.texcoords, mesh.faces
    assert v.dtype == n.dtype == uv.dtype == np.float32 and f.dtype == np.uint32
    assert np.isfinite(v).all() and np.isfinite(n).all() and np.isfinite(uv).all()
    assert f.max() < len(v)
    assert np.all((f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2]))
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-5)

    out = v - axis_points(curves)
    distance = np.linalg.norm(out, axis=1)
    assert distance.max() <= radius * (1 + 1e-4)
    circle = np.abs(distance - radius) <= 1e-4 * radius
    assert circle.mean() > 0.7  # only the inner sides of tight bends are squeezed (>= 74% left at r = 5)
    if radius <= 1.0:  # no bend of these patterns is tighter than 2.2 units: circles throughout
        assert circle.all()
    assert np.all(np.einsum("ij,ij->i", n, out) > 0), "normals must point away from the axis"

    tri = v[f].astype(np.float64)
    assert np.all(np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1) > 0)
    assert uv[:, 1].min() >= 0 and uv[:, 1].max() < 1  # angle / 2π


def inward_faces(mesh: g.TubeMesh) -> float:
    """Fraction of triangles whose winding (geometric normal) points into the tube."""
    tri = mesh.positions[mesh.faces].astype(np.float64)
    geo = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    outward = tri.mean(axis=1) - ring_centres(mesh)[mesh.faces].mean(axis=1)
    return float(np.mean(np.einsum("ij,ij->i", geo, outward) <= 0))


MESH_CASES = [(name, *radii) for name in PATTERNS if name != "random-64x64" for radii in RADII]
MESH_CASES.append(("random-64x64", 5.0, 5.0))  # once: the largest repeat at the largest radii


@pytest.mark.parametrize("name, r_warp, r_weft", MESH_CASES)
def test_fabric_meshes_are_valid(name, r_warp, r_weft):
    """Tube meshes of one repeat are well-formed for every pattern and Table 1's radius limits."""
    pattern = PATTERNS[name]
    n_e, n_a = pattern.shape
    wefts, warps = g.fabric_meshes(pattern, r_warp=r_warp, r_weft=r_weft, rows=(0, n_e), cols=(0, n_a))
    curves = g.control_points(pattern, r_warp=r_warp, r_weft=r_weft, rows=(0, n_e), cols=(0, n_a))
    check_mesh(wefts, r_weft, curves.weft)
    check_mesh(warps, r_warp, curves.warp)
    assert len(wefts.positions) % (n_e * g.RING) == 0 and len(warps.positions) % (n_a * g.RING) == 0
    # the mesh covers the window: wefts span every warp, warps every weft
    assert wefts.positions[:, 0].min() < 0 and wefts.positions[:, 0].max() > n_a * g.PITCH
    assert warps.positions[:, 1].min() < 0 and warps.positions[:, 1].max() > n_e * g.PITCH


@pytest.mark.parametrize("radius", [1.0, 5.0])
def test_texcoord_u_is_position_along_the_yarn_in_circumferences(radius):
    """u is the position along the yarn's direction over 2πr, so plies keep their pitch at any
    radius and sit at the same place whichever window of the fabric is built."""
    pattern = PATTERNS["twill-3x3"]
    for rows, cols in [((0, 3), (0, 3)), ((-3, 6), (2, 7))]:
        wefts, warps = g.fabric_meshes(pattern, r_warp=radius, r_weft=radius, rows=rows, cols=cols)
        curves = g.control_points(pattern, r_warp=radius, r_weft=radius, rows=rows, cols=cols)
        for mesh, along, axis in ((wefts, 0, curves.weft), (warps, 1, curves.warp)):
            expected = axis_points(axis)[:, along] / (2 * np.pi * radius)
            np.testing.assert_allclose(mesh.texcoords[:, 0], expected, rtol=1e-5, atol=1e-5)


def test_bad_inputs_are_refused():
    """An empty pattern or a non-positive radius is a ValueError, not a broken mesh."""
    with pytest.raises(ValueError, match="pattern"):
        g.control_points(np.zeros((0, 3)), r_warp=1.0, r_weft=1.0)
    curves = g.control_points(PATTERNS["plain-2x2"], r_warp=1.0, r_weft=1.0)
    for radius in (0.0, -1.0, float("nan")):
        with pytest.raises(ValueError, match="radius"):
            g.sweep_tubes(curves.weft, radius, side=np.array([0.0, 1.0, 0.0]))


@pytest.mark.parametrize("radius", [1.0, 3.0, 5.0])
@pytest.mark.parametrize("name", ["plain-2x2", "twill-3x3", "non-square-3x5", "satin-5"])
def test_every_face_is_wound_outward(name, radius):
    """Meshes are one-sided: every triangle's winding must face out of its tube, also at the
    bends where a yarn dives under a crossing one — at r >= 3 those bend with a radius (1.2
    units at r = 5) smaller than the tube's, where a swept circle folds over itself."""
    pattern = PATTERNS[name]
    n_e, n_a = pattern.shape
    for mesh in g.fabric_meshes(pattern, r_warp=radius, r_weft=radius, rows=(0, n_e), cols=(0, n_a)):
        assert inward_faces(mesh) == 0


@pytest.mark.parametrize("name", ["twill-3x3", "non-square-3x5", "satin-5"])
def test_yarns_swept_together_equal_each_swept_alone(name):
    """A family's yarns are swept as one stack: the mesh is each yarn's tube, in order, exactly
    as swept alone (the faces offset by the vertices before them)."""
    curves = g.control_points(PATTERNS[name], r_warp=3.0, r_weft=2.0, rows=(-1, 6), cols=(-1, 7))
    for family, radius, side in ((curves.weft, 2.0, (0.0, 1.0, 0.0)), (curves.warp, 3.0, (1.0, 0.0, 0.0))):
        together = g.sweep_tubes(family, radius, side=np.array(side))
        alone = [g.sweep_tubes([cp], radius, side=np.array(side)) for cp in family]
        offsets = np.cumsum([0] + [m.positions.shape[0] for m in alone[:-1]])
        for key in ("positions", "normals", "texcoords"):
            np.testing.assert_array_equal(getattr(together, key), np.concatenate([getattr(m, key) for m in alone]))
        np.testing.assert_array_equal(together.faces, np.concatenate([m.faces + o for m, o in zip(alone, offsets)]))
