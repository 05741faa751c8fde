"""Training data: summed-area footprints against brute force, point queries, shards."""

from __future__ import annotations

import numpy as np
import pytest

from weavecap.estimate.sampling import random_fabric
from weavecap.render.bsdf import SurfaceTextures, eval_surface, shading_of
from weavecap.render.surface import FACE, bake
from weavecap.render.woven import footprint, terms
from weavecap.training import woven as data

mi, dr = terms._backend()


def test_box_mean_equals_brute_force_on_a_periodic_image():
    """Box means of any size and place (sub-texel, across the seam, many repeats) equal a
    dense average of the tiled image."""
    rng = np.random.default_rng(0)
    image = rng.random((5, 7, 2))
    sat, mean = footprint.periodic_sat(image)
    for x, y, half in [(1.3, 2.2, 0.2), (0.1, 4.9, 1.7), (-5.5, 12.3, 9.3), (2.5, 2.5, 3.5), (3.0, 1.0, 14.0)]:
        g = (np.arange(700) + 0.5) / 700 * 2 - 1
        xs, ys = np.meshgrid(x + g * half, y + g * half)
        dense = image[np.floor(ys).astype(int) % 5, np.floor(xs).astype(int) % 7].reshape(-1, 2).mean(axis=0)
        got = footprint.box_mean(sat, mean, np.array([x]), np.array([y]), np.array([half]))[0]
        np.testing.assert_allclose(got, dense, atol=3e-3)
    # whole repeats average to the mean exactly
    got = footprint.box_mean(sat, mean, np.array([0.37]), np.array([1.9]), np.array([17.5]))[0]
    np.testing.assert_allclose(got, image.mean(axis=(0, 1)), atol=1e-12)


@pytest.fixture(scope="module")
def plain():
    rng = np.random.default_rng(7)
    fabric = random_fabric(rng, np.array([[1, 0], [0, 1]], dtype=np.uint8))
    return fabric, bake(fabric, texels_per_yarn=4, supersamples=2)


def test_footprints_match_monte_carlo_over_texels(plain):
    """A tiny case: the queries of one material equal brute-force Monte-Carlo footprints —
    uniform points in the box, each the surface model at the texel it falls in (a separate
    path: Dr.Jit evaluation per sample, no tables) — within the Monte-Carlo error."""
    fabric, maps = plain
    config = data.DataConfig(fabrics=1, grid=2, footprints=6, points=0)
    q = data.material_queries(fabric, maps, FACE, config, np.random.default_rng(1))
    shading, _ = shading_of(fabric)
    h, w = maps.shape
    rng = np.random.default_rng(2)
    n = 6000
    for i in range(0, len(q["inputs"]), 5):
        s, t, size = q["inputs"][i, :3]
        wi, wo = q["inputs"][i, 3:6], q["inputs"][i, 6:9]
        ds = (rng.random(n) - 0.5) * size / 2
        dt = (rng.random(n) - 0.5) * size / 2
        x, y = footprint.fabric_to_texel(s + ds, t + dt, (h, w))
        index = (np.floor(y).astype(int) % h) * w + (np.floor(x).astype(int) % w)
        point = terms.texel_point(maps, FACE, mi.UInt32(index.astype(np.uint32)))
        vec = lambda d: mi.Vector3f(*(mi.Float(np.full(n, c, dtype=np.float32)) for c in d))  # noqa: E731
        seven = np.stack([np.array(v) for v in terms.point_terms(shading, point, vec(wi), vec(wo))], axis=-1)
        mc = terms.split_by_yarn(seven, np.array(point.warp))
        stderr = mc.std(axis=0) / np.sqrt(n)
        assert np.all(np.abs(q["targets"][i] - mc.mean(axis=0)) <= 5 * stderr + 1e-5), (i, size)


def test_point_queries_are_the_reference_lookup(plain):
    """Point queries (size 0) are eval_surface at the linearly interpolated maps."""
    fabric, maps = plain
    rng = np.random.default_rng(4)
    n = 500
    s, t = rng.random(n), rng.random(n)
    wi, wo = data.direction_pairs(rng, 16)
    wi, wo = wi[:n], wo[:n]
    textures = SurfaceTextures(maps)
    shading, colours = shading_of(fabric)
    got = terms.combine(data.point_queries(shading, textures, FACE, s, t, wi, wo),
                        terms.colour_coefficients(terms.fabric_colours(fabric)))
    f = lambda a: mi.Float(np.ascontiguousarray(a, dtype=np.float32))  # noqa: E731
    point = textures.lookup(f(s), f(t), mi.Bool(False))
    want = np.array(eval_surface(shading, colours, point, mi.Vector3f(*(f(wi[:, k]) for k in range(3))),
                                 mi.Vector3f(*(f(wo[:, k]) for k in range(3))))).T
    np.testing.assert_allclose(got, want, atol=1e-5 * max(1.0, np.abs(want).max()))


def test_directions_are_stratified_and_split_by_side():
    rng = np.random.default_rng(0)
    wi, wo = data.direction_pairs(rng, 6)
    assert wi.shape == wo.shape == (72, 3)
    np.testing.assert_allclose(np.linalg.norm(wi, axis=1), 1.0, atol=1e-12)
    assert (wi[:, 2] >= 0).all() and (wo[:36, 2] >= 0).all() and (wo[36:, 2] <= 0).all()
    # one direction in each stratum of the disk's square
    xy = wi[:36, :2]
    assert np.abs(xy.mean(axis=0)).max() < 0.15


def test_shards_are_seeded_and_resumable(tmp_path):
    """Two fabrics in two shards: a second run makes nothing and counts the first run's
    seconds; a deleted shard comes back bit for bit (its seconds aside); held-out fabrics are
    marked."""
    config = data.DataConfig(fabrics=2, shard_fabrics=1, grid=2, footprints=3, points=1, texels_per_yarn=4)
    made = []
    first = data.generate(tmp_path, config, progress=made.append)
    assert len(made) == 2 and first > 0
    again = data.generate(tmp_path, config, progress=made.append)
    assert len(made) == 2 and again == first
    path = data.shard_path(tmp_path, 1)
    before = dict(np.load(path))
    path.unlink()
    data.generate(tmp_path, config)
    after = dict(np.load(path))
    assert before.keys() == after.keys()
    for key in set(before) - {"seconds"}:
        np.testing.assert_array_equal(before[key], after[key])
    assert [data.is_held_out(config, i) for i in range(2)] == [False, True]
    for key in ("targets", "features", "baseline", "inputs"):
        assert np.isfinite(after[key].astype(np.float64)).all()


@pytest.mark.parametrize("side", [FACE, 1])
def test_drjit_box_filter_equals_numpy(plain, side):
    """The renderer's box filter (Dr.Jit, float32 tables) reads the same map statistics as the
    training data (numpy, float64): points, sub-texel to many-repeat boxes, any centre."""
    from weavecap.render.woven.infer import footprint_filter

    _, maps = plain
    h, w = maps.shape
    rng = np.random.default_rng(side)
    n = 3000
    x, y = rng.uniform(-50, 80, n), rng.uniform(-30, 60, n)
    half = np.exp(rng.uniform(np.log(0.05), np.log(80), n))
    half[:100] = 0.0
    image = footprint.feature_image(maps, side)
    sat, mean = footprint.periodic_sat(image)
    want = footprint.footprint_features(image, sat, mean, x, y, half)
    f = lambda a: mi.Float(np.ascontiguousarray(a, dtype=np.float32))  # noqa: E731
    got = footprint_filter(maps).mean(f(x), f(y), f(half), mi.Bool(np.full(n, side == 1)))
    got = np.stack([np.array(g) for g in got], axis=-1)
    np.testing.assert_allclose(got, want, atol=2e-3)
