"""Neighbourhood visibility: view samples, probes (§2.2) and ASG lobes (§2.1)."""

from __future__ import annotations

import numpy as np

from weavecap.render.fold import visibility as Vis
from weavecap.render.fold.descriptors import compute_descriptors
from weavecap.render.fold.localpt import mi

from .shapes import diffuse, grid_faces, heightfield, mesh_shape
from .test_localpt import groove, wall_view_factor


def scene_with(v, f, desc):
    garment = mesh_shape(v, f, normals=desc.normals, bsdf=diffuse(0.6), name="garment")
    return mi.load_dict({"type": "scene", "garment": garment}), garment


def test_hat_points_lie_on_the_vertexs_faces_weighted_towards_it():
    v, f = heightfield(lambda x, y: 0.1 * np.sin(3 * x), n=21)
    n = np.tile([0.0, 0.0, 1.0], (len(v), 1))
    at = np.array([0, 10, 220, 440])  # a corner, an edge, the middle, the far corner
    pts, nrm, faces = Vis.hat_points(v, f, n, at, 400, np.random.default_rng(0))
    for row, i in enumerate(at):
        assert np.all(np.any(f[faces[row]] == i, axis=1))  # every sample on a face of the vertex
        corners = v[f[faces[row]]]  # (count, 3, 3)
        # barycentric coordinate of the vertex: distance to the opposite edge's line, by area ratio
        own = np.argmax(f[faces[row]] == i, axis=1)
        a = corners[np.arange(400), own]
        b = corners[np.arange(400), (own + 1) % 3]
        c = corners[np.arange(400), (own + 2) % 3]
        full = np.linalg.norm(np.cross(b - a, c - a), axis=1)
        part = np.linalg.norm(np.cross(b - pts[row], c - pts[row]), axis=1)
        assert abs(np.mean(part / full) - 0.5) < 0.03  # Beta(2, 2) has mean 1/2


def test_a_plane_has_no_lit_neighbourhood():
    v, f = heightfield(lambda x, y: 0 * x, n=11)
    desc = compute_descriptors(v, f, radius=0.4)
    scene, garment = scene_with(v, f, desc)
    nb = Vis.neighbourhood_samples(scene, garment, v, f, desc, 0, 32, seed=0)
    assert not nb.found.any()
    assert np.all(Vis.lit_share(scene, nb, np.array([0.0, 0.0, 1.0]), desc.radius) == 0.0)
    assert Vis.lit_share(scene, nb, np.array([0.0, 0.0, 1.0]), desc.radius).shape == (len(v), 2)


def test_lit_share_in_a_groove_is_the_view_factor_times_the_walls_cosine():
    v, f = groove()
    desc = compute_descriptors(v, f, radius=10.0)
    scene, garment = scene_with(v, f, desc)
    wanted = np.array([-0.2, -0.5, -0.8])  # x of vertices on the x < 0 wall, at y = 0
    at = np.array([np.argmin(np.linalg.norm(v[:, :2] - [x, 0.0], axis=1)) for x in wanted])
    nb = Vis.neighbourhood_samples(scene, garment, v, f, desc, 0, 20000, seed=1, at=at)
    share = Vis.lit_share(scene, nb, np.array([0.0, 0.0, 1.0]), desc.radius)
    # lit from above, the walls' far sides are dark: nothing comes through
    assert np.all(share[:, 1] == 0.0)
    below = Vis.lit_share(scene, nb, np.array([0.0, 0.0, -1.0]), desc.radius)
    np.testing.assert_allclose(below[:, 1], share[:, 0], rtol=0.05)  # lit from below: the same walls, through
    assert np.all(below[:, 0] == 0.0)
    share = share[:, 0]
    # the samples start on the vertex's faces (a hat around it), not at it: average the view
    # factor over the same spread along the wall (Beta(2, 2) of a face's width either side)
    rng = np.random.default_rng(0)
    edge = np.sqrt(2) * 0.05
    expected = []
    for i in at:
        s0 = np.hypot(v[i, 0], v[i, 2])
        spread = s0 + (1 - rng.beta(2, 2, 4000)) * edge * rng.choice([-1, 1], 4000)
        expected.append(np.mean([wall_view_factor(x) for x in np.clip(spread, 1e-3, None)]))
    np.testing.assert_allclose(share, np.array(expected) * np.cos(np.pi / 4), rtol=0.05)


def test_both_sides_at_once_sample_each_side_as_its_own_call():
    # a pleat-like sine sheet: both sides find neighbours; one query for both gives each side exactly what its
    # own call gives at the same seed, and the back's rays are the front's mirrored (cosine about -n)
    v, f = heightfield(lambda x, y: 0.3 * np.sin(6 * x), n=31)
    desc = compute_descriptors(v, f, radius=0.4)
    scene, garment = scene_with(v, f, desc)
    at = np.arange(0, len(v), 7)
    front, back = Vis.both_sides_samples(scene, garment, v, f, desc, 48, seed=3, at=at)
    for side, got in enumerate((front, back)):
        alone = Vis.neighbourhood_samples(scene, garment, v, f, desc, side, 48, seed=3, at=at)
        np.testing.assert_array_equal(got.found, alone.found)
        np.testing.assert_array_equal(got.points, alone.points)
        np.testing.assert_array_equal(got.albedo, alone.albedo)
        assert 0.05 < got.found.mean() < 0.6
        found_normals = got.normals[got.found]
        np.testing.assert_allclose(np.linalg.norm(found_normals, axis=1), 1.0, atol=1e-5)
    # crests on one side are valleys on the other: where the front finds most, the back finds least
    crest = v[at, 2] > 0.24
    assert front.found[~crest].mean() > front.found[crest].mean() and back.found[crest].mean() > back.found[~crest].mean()
    d = np.random.default_rng(0).normal(size=(100, 3))
    n = np.random.default_rng(1).normal(size=(100, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    m = Vis.mirrored(d, n)
    np.testing.assert_allclose(np.einsum("kj,kj->k", m, n), -np.einsum("kj,kj->k", d, n), atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(m, axis=1), np.linalg.norm(d, axis=1))


def test_asg_fit_recovers_a_lobe():
    rng = np.random.default_rng(0)
    dirs = Vis.fibonacci_sphere(64)
    normal = np.tile([0.0, 0.0, 1.0], (20, 1))
    z = rng.normal(size=(20, 1, 3)) + [0, 0, 2.0]
    truth = np.concatenate([z / np.linalg.norm(z, axis=-1, keepdims=True), np.full((20, 1, 2), [3.0, 8.0]),
                            np.full((20, 1, 1), 0.7)], axis=-1)
    target = np.stack([Vis.asg_value(truth, normal, np.broadcast_to(d, (20, 3))) for d in dirs], axis=1)
    direct = np.zeros_like(target)
    fit = Vis.fit_asg(direct, target, normal, dirs, lobes=2, steps=150)
    again = np.stack([Vis.asg_value(fit.astype(float), normal, np.broadcast_to(d, (20, 3))) for d in dirs], axis=1)
    assert np.sqrt(np.mean((again - target) ** 2)) < 0.01 * target.max()  # measured 0.0003


def test_the_neighbourhood_does_not_depend_on_how_long_the_faces_are():
    # a 90° groove z = |x| extruded along y, once with rows 2 apart (faces far longer than r)
    # and once with rows 0.1 apart: N is the sphere about where each ray leaves (LocalPT's
    # about its first hit), so a wall vertex sees the same lit share of it on both
    shares = []
    for rows in (3, 41):
        x, y = np.meshgrid(np.linspace(-1, 1, 41), np.linspace(-2, 2, rows), indexing="ij")
        v = np.stack([x, y, np.abs(x)], -1).reshape(-1, 3)
        f = grid_faces(41, rows)
        desc = compute_descriptors(v, f, radius=0.6)
        scene, garment = scene_with(v, f, desc)
        at = np.array([np.argmin(np.linalg.norm(v[:, :2] - [-0.3, 0.0], axis=1))])
        nb = Vis.neighbourhood_samples(scene, garment, v, f, desc, 0, 20000, seed=1, at=at)
        shares.append(Vis.lit_share(scene, nb, np.array([0.0, 0.0, 1.0]), desc.radius)[0, 0])
    assert shares[1] > 0.05
    np.testing.assert_allclose(shares[0], shares[1], rtol=0.08)


def test_arrays_handed_to_drjit_are_aligned_so_their_kernels_do_not_vary():
    import drjit as dr

    rng = np.random.default_rng(3)
    for n in (1, 7, 1001):
        raw = rng.normal(size=(n, 3))
        assert all(Vis.aligned(raw[:, k]).ctypes.data % Vis.ALIGN == 0 for k in range(3))
        np.testing.assert_array_equal(Vis.aligned(raw), raw.astype(np.float32))
    # the same computation on points of other counts and other malloc offsets: one kernel, read at align 64
    dr.set_flag(dr.JitFlag.KernelHistory, True)
    try:
        dr.kernel_history()
        for n in (1001, 1003, 517):
            p = Vis.jit_vec3(rng.normal(size=(n, 3))[1:], mi.Point3f)  # a slice: its rows start off the boundary
            dr.eval(dr.norm(p) * 2.0)
        kernels = [e for e in dr.kernel_history() if e["type"] == dr.KernelType.JIT]
    finally:
        dr.set_flag(dr.JitFlag.KernelHistory, False)
    assert len(kernels) == 3 and len({e["hash"] for e in kernels}) == 1
    assert "align 1," not in kernels[0]["ir"].getvalue()
