"""The colour-free split of the surface BSDF (Eq. 7–8 for our model) is exact."""

from __future__ import annotations

import numpy as np
import pytest

from weavecap import params
from weavecap.estimate.sampling import random_fabric
from weavecap.fixtures import path as fixture_path
from weavecap.render.bsdf import SurfaceTextures, eval_surface, shading_of
from weavecap.render.surface import BACK, FACE, bake
from weavecap.render.woven import terms

mi, dr = terms._backend()


def _directions(rng, n, up):
    v = rng.normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    if up:
        v[:, 2] = np.abs(v[:, 2])
    return v


def _vec(a):
    return mi.Vector3f(*np.ascontiguousarray(a.T, dtype=np.float32))


@pytest.fixture(scope="module")
def twill():
    rng = np.random.default_rng(3)
    fabric = random_fabric(rng, np.array([[1, 1, 0], [0, 1, 1], [1, 0, 1]], dtype=np.uint8))
    return fabric, bake(fabric, texels_per_yarn=8, supersamples=2)


@pytest.mark.parametrize("side", [FACE, BACK])
def test_channels_times_colours_equal_the_surface_bsdf(twill, side):
    """Σ coefficient × channel equals eval_surface with the fabric's own colours at random
    points, both sides, light above and below (to float32 precision)."""
    fabric, maps = twill
    rng = np.random.default_rng(side)
    n = 4000
    textures = SurfaceTextures(maps)
    f = lambda a: mi.Float(np.ascontiguousarray(a, dtype=np.float32))  # noqa: E731
    point = textures.lookup(f(rng.random(n)), f(rng.random(n)), mi.Bool(side == BACK))
    wi, wo = _directions(rng, n, True), _directions(rng, n, False)
    shading, colours = shading_of(fabric)
    full = np.array(eval_surface(shading, colours, point, _vec(wi), _vec(wo))).T
    seven = np.stack([np.array(t) for t in terms.point_terms(shading, point, _vec(wi), _vec(wo))], axis=-1)
    channels = terms.split_by_yarn(seven, np.array(point.warp))
    rebuilt = terms.combine(channels, terms.colour_coefficients(terms.fabric_colours(fabric)))
    assert np.abs(full).max() > 0.1
    np.testing.assert_allclose(rebuilt, full, atol=2e-5 * np.abs(full).max())
    # a light on the viewer's side never lights the channels that need it below the yarn
    off = [i for i in range(len(terms.CHANNELS)) if i not in terms.REFLECTION_CHANNELS]
    assert np.abs(channels[wo[:, 2] > 0][:, off]).max() == 0.0


def test_coefficients_are_linear_in_the_colours():
    """Doubling nothing but the body colours doubles only the body channels' coefficients;
    m_r moves weight between body reflection and transmission."""
    fabric = params.load(fixture_path("params", "plain.json"))
    base = terms.fabric_colours(fabric)
    coef = terms.colour_coefficients(base)
    half = dict(base, warp_reflection=tuple(0.5 * np.asarray(base["warp_reflection"])))
    coef_half = terms.colour_coefficients(half)
    changed = [i for i in range(len(terms.CHANNELS)) if not np.allclose(coef[i], coef_half[i])]
    assert [terms.CHANNELS[i] for i in changed] == ["body_r_warp", "body_r_tau_warp"]
    np.testing.assert_allclose(coef_half[changed], 0.5 * coef[changed])
