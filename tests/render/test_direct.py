"""``--mode direct`` (weavecap.render.direct) is one bounce of the path tracer, with less noise,
and takes the samples its image needs (weavecap.render.run.adaptive_passes)."""

from __future__ import annotations

import numpy as np
import pytest

from weavecap import params
from weavecap.fixtures import path as fixture_path
from weavecap.render import direct  # noqa: F401  (registers "fabric_direct")
from weavecap.render import run as R
from weavecap.render.mesh import load_mesh

from .test_integrator import SKY, render


def test_a_diffuse_plane_under_a_sky_and_a_sun_has_its_closed_form():
    """Albedo 0.5 under a sky of 0.8 and a sun of irradiance 2 at 60° from the normal:
    0.5 × 0.8 + 0.5 / π × 2 × cos 60°, by MIS of the sky's and the BSDF's samples."""
    sun = {"sun": {"type": "directional", "direction": [0.0, -np.sin(np.pi / 3), -0.5],
                   "irradiance": {"type": "rgb", "value": 2.0}}}
    image = render({"type": "diffuse", "reflectance": {"type": "rgb", "value": 0.5}}, emitters={**SKY, **sun},
                   integrator_props={"type": "fabric_direct"}, spp=64)
    assert image.mean() == pytest.approx(0.4 + 0.5 / np.pi, rel=0.01)


def test_gaps_show_the_backdrop_and_let_a_back_light_through():
    """A plane 30 % holes before a backdrop of 1 and lit from behind: what lies behind is
    added by its share (as in weavecap_path)."""
    back = {"back": {"type": "directional", "direction": [0.0, 0.0, 1.0], "irradiance": {"type": "rgb", "value": 1.0}}}
    image = render({"type": "test_half_null", "null": 0.3}, emitters=back,
                   integrator_props={"type": "fabric_direct", "background": 1.0}, spp=4)
    assert image.mean() == pytest.approx(0.3 * 1.0 + 0.3 * 0.0, abs=1e-3)  # the back light passes the holes, unseen


@pytest.fixture(scope="module")
def drape():
    return params.load(fixture_path("params", "satin_5.json")), load_mesh(fixture_path("meshes", "drape.obj"))


@pytest.mark.parametrize("light", ["sun", "both"])
def test_direct_is_the_path_tracers_first_bounce_with_less_noise(drape, light):
    """The drape under the sun and its sky, and under a capture rig (ambient, backdrop through
    the gaps): the same garment mean as weavecap_path at max_depth 2 (within the noise), and
    at equal spp a smaller error against it at many samples."""
    from weavecap.render import modes

    fabric, mesh = drape
    modes.register_mode(modes.Mode("path_first_bounce", "test", bsdf=modes.MODES["direct"].bsdf,
                                   integrator=modes._path(2)))
    try:
        opts = dict(size=(40, 30), view=(30.0, 20.0), light=light, pitch_mm=1.0, fold="off")
        truth = R.render_fabric(fabric, mesh, R.RenderOptions(mode="path_first_bounce", spp=512, seed=1, **opts)).image
        ours = R.render_fabric(fabric, mesh, R.RenderOptions(mode="direct", spp=512, seed=2, **opts)).image
        path8 = R.render_fabric(fabric, mesh, R.RenderOptions(mode="path_first_bounce", spp=8, seed=3, **opts)).image
        ours8 = R.render_fabric(fabric, mesh, R.RenderOptions(mode="direct", spp=8, seed=4, **opts)).image
    finally:
        modes.MODES.pop("path_first_bounce")
    assert ours.mean() == pytest.approx(truth.mean(), rel=0.005)  # measured: within 0.05 %
    # measured: 0.61 of its MSE under the sun (one light and the sky), 0.09 under the rig
    assert np.mean((ours8 - truth) ** 2) < 0.7 * np.mean((path8 - truth) ** 2)


def test_noise_level_is_the_standard_error_in_lightness():
    """Two images of a mid grey (L* 50) with Gaussian noise of σ in linear value: the noise
    of their mean is σ / √2 per image, in L* its slope dL*/dY times that."""
    rng = np.random.default_rng(0)
    y, sigma = 0.1842, 0.004  # L* 50
    a, b = (np.clip(y + sigma * rng.standard_normal((200, 200, 1)), 0, 1).repeat(3, axis=-1) for _ in range(2))
    slope = 116.0 / 3.0 * y ** (-2.0 / 3.0)
    assert R.noise_level(a, b) == pytest.approx(slope * sigma / np.sqrt(2.0), rel=0.05)
    assert R.noise_level(a, a) == 0.0
    where = np.zeros(a.shape[:2], bool)
    where[:50] = True  # only these pixels count: the rest noise-free, like a background
    a[50:], b[50:] = 0.5, 0.5
    assert R.noise_level(a, b, where) == pytest.approx(slope * sigma / np.sqrt(2.0), rel=0.08)


def test_the_default_samples_until_the_noise_is_below_what_was_asked(drape):
    """Adaptive sampling (the default): the image ends at or under the noise asked for, and
    twice that noise takes a quarter to a half of the samples (noise ∝ 1/√spp)."""
    fabric, mesh = drape
    options = R.RenderOptions(mode="direct", spp=None, size=(40, 30), view=(30.0, 20.0), light="sun", pitch_mm=1.0,
                              fold="off")
    info = R.render_fabric(fabric, mesh, options).info
    assert R.AUTO_MIN_SPP <= info["spp"] < R.AUTO_MAX_SPP and info["noise_l"] <= R.NOISE_L
    scene = R.prepare_render(fabric, mesh, options).scene
    _, spp, _ = R.adaptive_passes(scene, 0, noise_l=R.NOISE_L)
    _, spp_double, noise = R.adaptive_passes(scene, 0, noise_l=2 * R.NOISE_L)
    assert spp == info["spp"] and noise <= 2 * R.NOISE_L
    assert 2 * spp_double <= spp <= 6 * spp_double  # measured: 96 and 32
