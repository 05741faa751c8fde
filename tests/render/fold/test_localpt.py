"""LocalPT (supplement §4.2): local inter-reflection only, against closed forms and Mitsuba's path."""

from __future__ import annotations

import numpy as np
import pytest

from weavecap.render.fold.localpt import mi, radiance_leaving

from .shapes import diffuse, directional, grid_faces, heightfield, mesh_shape


def groove(half_width=1.0, length=10.0, n=41, rows=201):
    """A 90° V-groove z = |x| along y, long enough to stand for an infinite one at y = 0."""
    x = np.linspace(-half_width, half_width, n)
    y = np.linspace(-length / 2, length / 2, rows)
    X, Y = np.meshgrid(x, y, indexing="ij")
    return np.stack([X, Y, np.abs(X)], -1).reshape(-1, 3), grid_faces(n, rows)


def scene_of(v, f, albedo, sun=(0, 0, -1), extra=None):
    d = {"type": "scene", "garment": mesh_shape(v, f, bsdf=diffuse(albedo), name="garment"),
         "sun": directional(sun)}
    if extra is not None:
        d["other"] = extra
    return mi.load_dict(d)


def localpt(**props):
    return mi.load_dict({"type": "localpt", **props})


def along_normals(scene, integrator, pts, n, *, spp, seed):
    """Mean radiance of camera-like rays arriving down the normals (for any integrator)."""
    import drjit as dr

    o = np.repeat(pts + 1e-3 * n, spp, axis=0).T.astype(np.float32)
    d = np.repeat(-n, spp, axis=0).T.astype(np.float32)
    sampler = mi.load_dict({"type": "independent"})
    sampler.seed(seed, len(pts) * spp)
    L, valid, _ = integrator.sample(scene, sampler, mi.Ray3f(mi.Point3f(*o), mi.Vector3f(*d)), None, mi.Bool(True))
    L = dr.select(valid, L, 0.0)
    return np.stack([np.asarray(L[k]) for k in range(3)], 1).reshape(len(pts), spp, 3).mean(axis=1)


def on_wall(s):
    """Points at distance s from the apex on the groove's x < 0 wall, and its normal."""
    s = np.asarray(s, float)
    pts = np.stack([-s / np.sqrt(2), np.zeros_like(s), s / np.sqrt(2)], 1)
    return pts, np.tile([1.0, 0.0, 1.0], (len(s), 1)) / np.sqrt(2)


def test_on_a_plane_localpt_is_the_direct_light_alone():
    v, f = heightfield(lambda x, y: 0 * x, size=20.0, n=11)
    rho, sun = 0.6, np.array([0.3, -0.2, -1.0])
    scene = scene_of(v, f, rho, sun=sun)
    rng = np.random.default_rng(0)
    pts = np.column_stack([rng.uniform(-3, 3, (50, 2)), np.zeros(50)])
    view = rng.normal(size=(50, 3))
    view[:, 2] = np.abs(view[:, 2]) + 0.2
    view /= np.linalg.norm(view, axis=1, keepdims=True)
    up = np.tile([0.0, 0.0, 1.0], (50, 1))
    full = radiance_leaving(scene, localpt(radius=5.0), pts, up, view, spp=16, offset=1e-3)
    local = radiance_leaving(scene, localpt(radius=5.0, direct=False), pts, up, view, spp=16, offset=1e-3)
    expected = rho / np.pi * (-sun[2] / np.linalg.norm(sun))  # ρ/π E cos θ, E = 1
    np.testing.assert_allclose(full, expected, rtol=1e-5)
    assert np.all(local == 0.0)


def wall_view_factor(s):
    """2D view factor from a point on one wall of the 90° groove to the whole other wall."""
    p = np.array([-s / np.sqrt(2), s / np.sqrt(2)])
    n = np.array([1.0, 1.0]) / np.sqrt(2)

    def sin_to(q):
        u = (q - p) / np.linalg.norm(q - p)
        return n[0] * u[1] - n[1] * u[0]

    return 0.5 * abs(sin_to(np.array([1.0, 1.0])) - sin_to(np.array([0.0, 0.0])))


def test_one_bounce_in_a_groove_is_the_view_factor_times_the_lit_wall():
    rho = 0.5
    scene = scene_of(*groove(), rho)
    s = np.array([0.2, 0.5, 0.8, 1.1, 1.3])
    pts, n = on_wall(s)
    # max_depth 3: camera → wall A → wall B → light; indirect only: the single inter-reflection
    est = radiance_leaving(scene, localpt(radius=100.0, direct=False, max_depth=3), pts, n, n, spp=20000,
                           seed=3, offset=1e-3)[:, 0]
    lit_wall = rho * np.cos(np.pi / 4) / np.pi  # radiance of the other wall, E = 1 from above
    expected = np.array([rho * lit_wall * wall_view_factor(x) for x in s])
    np.testing.assert_allclose(est, expected, rtol=0.03)  # measured within 1.3 %


def test_with_a_radius_spanning_the_scene_localpt_is_path_tracing():
    rho = 0.8  # several bounces matter, and Russian roulette runs
    scene = scene_of(*groove(), rho, sun=(0.4, 0.1, -1.0))
    pts, n = on_wall([0.3, 0.7, 1.2])
    ours = along_normals(scene, localpt(radius=100.0), pts, n, spp=20000, seed=1)
    path = along_normals(scene, mi.load_dict({"type": "path", "max_depth": 16, "rr_depth": 5}), pts, n,
                         spp=20000, seed=2)
    np.testing.assert_allclose(ours, path, rtol=0.02)
    assert np.all(ours > 0)


def test_the_radius_bounds_the_inter_reflection():
    rho = 0.7
    scene = scene_of(*groove(), rho)
    pts, n = on_wall([0.4, 0.9])
    values = [radiance_leaving(scene, localpt(radius=r, direct=False), pts, n, n, spp=8000, seed=4,
                               offset=1e-3)[:, 0] for r in (0.05, 0.4, 1.0, 100.0)]
    tiny, small, mid, whole = values
    assert np.all(tiny < 0.05 * whole)  # nothing of the other wall is within 0.05 (but near the apex)
    assert np.all(small < mid) and np.all(mid < whole)
    # the point 0.9 from the apex sees no bounce within 0.4 except near the apex: none
    assert small[1] < 0.02 * whole[1]


def test_energy_stays_finite_and_bounded_for_white_and_black_fabrics():
    pts, n = on_wall([0.1, 0.6, 1.3])
    scene_black = scene_of(*groove(), 0.0)
    black = radiance_leaving(scene_black, localpt(radius=100.0, direct=False), pts, n, n, spp=256, offset=1e-3)
    assert np.all(black == 0.0)
    scene_white = scene_of(*groove(), 1.0)
    white = radiance_leaving(scene_white, localpt(radius=100.0), pts, n, n, spp=4000, offset=1e-3)
    assert np.all(np.isfinite(white))
    # an open groove loses light at every bounce: radiance below that of a white furnace (E/π · 1/(1−1)
    # is unbounded, but the groove's walls see the sky over half their hemisphere or more)
    direct = np.cos(np.pi / 4) / np.pi
    assert np.all(white[:, 0] > direct) and np.all(white[:, 0] < 3 * direct)


def test_bounces_stay_on_the_first_hits_shape_unless_asked():
    # a flat garment beside a lit wall of another shape (a body, a chair) within r
    v, f = heightfield(lambda x, y: 0 * x, size=10.0, n=11)
    wall_v = np.array([[0.3, -5, 0], [0.3, 5, 0], [0.3, 5, 1], [0.3, -5, 1]], float)
    wall = mesh_shape(wall_v, np.array([[0, 2, 1], [0, 3, 2]]), bsdf=diffuse(0.9), name="wall")
    scene = scene_of(v, f, 0.7, sun=(1.0, 0.0, -1.0), extra=wall)
    pts = np.array([[0.0, 0.0, 0.0], [-0.2, 1.0, 0.0]])
    n = np.tile([0.0, 0.0, 1.0], (2, 1))
    kwargs = dict(spp=4000, seed=5, offset=1e-3)
    same = radiance_leaving(scene, localpt(radius=1.0, direct=False), pts, n, n, **kwargs)
    anyshape = radiance_leaving(scene, localpt(radius=1.0, direct=False, same_shape=False), pts, n, n, **kwargs)
    assert np.all(same == 0.0)  # a plane alone reflects nothing onto itself
    assert np.all(anyshape > 0.01)


@pytest.mark.parametrize("props, words", [({"radius": 0.0}, "radius"), ({"radius": 1.0, "max_depth": 0}, "max_depth")])
def test_bad_settings_are_refused(props, words):
    with pytest.raises(Exception, match=words):
        localpt(**props)
