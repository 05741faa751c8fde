"""Standard errors of fitted parameters (weavecap.fit.uncertainty) on repeats with known noise."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.ndimage import gaussian_filter

from weavecap import params
from weavecap.fit.uncertainty import DETERMINED_SE, correlation_area, standard_errors
from weavecap.model.render import render_numpy
from weavecap.model.scene import View, build_scene

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "params"


def test_correlation_area_of_white_blurred_and_grey_noise():
    rng = np.random.default_rng(0)
    white = rng.normal(size=(128, 128, 3))
    assert correlation_area(white, 8) == pytest.approx(1.0, abs=0.3)
    # white noise blurred by σ has a Gaussian autocorrelation of σ√2: area 4πσ²
    assert correlation_area(gaussian_filter(white, (2, 2, 0), mode="wrap"), 8) == pytest.approx(4 * np.pi * 4, rel=0.15)
    grey = np.repeat(white[..., :1], 3, axis=2)  # the three channels move together
    assert correlation_area(grey, 8) == pytest.approx(3.0, rel=0.1)
    assert correlation_area(np.zeros((8, 8, 3)), 2) == 1.0


@pytest.fixture(scope="module")
def twill():
    fabric = params.load(FIXTURES / "twill_2_1.json")
    c = 16
    image = render_numpy(build_scene(fabric, View(tiles=(1, 1), size=c * max(fabric.shape), spp=4)))
    return fabric, image


def test_errors_scale_with_the_noise_and_name_what_the_photo_cannot_show(twill):
    fabric, image = twill
    rng = np.random.default_rng(1)
    low = standard_errors(fabric, image + rng.normal(0, 0.005, image.shape), blur_px=0.0)
    high = standard_errors(fabric, image + rng.normal(0, 0.02, image.shape), blur_px=0.0)
    for key in ("warp.body_reflection", "specular.roughness", "shadowing.ply"):
        assert high[key] / low[key] == pytest.approx(4.0, rel=0.25), key
    # the yarn radii and the roughness shape every pixel; the exit lobe's ior and the
    # attenuation barely move a render over their narrow Table 1 ranges
    for key in ("warp.radius", "weft.radius", "specular.roughness", "warp.body_reflection"):
        assert low[key] <= DETERMINED_SE, (key, low[key])
    for key in ("specular.ior_exit", "specular.attenuation"):
        assert low[key] > DETERMINED_SE, (key, low[key])
    assert all(np.isfinite(v) and v >= 0 for v in low.values())


def test_a_black_fabric_leaves_colours_undetermined_without_failing(twill):
    fabric, _ = twill
    black = fabric.replace({"warp.body_reflection": (0.0,) * 3, "weft.body_reflection": (0.0,) * 3,
                            "warp.body_subsurface": (0.0,) * 3, "weft.body_subsurface": (0.0,) * 3,
                            "specular.reflection": (0.0,) * 3, "specular.transmission": (0.0,) * 3,
                            "specular.transmission_exit": (0.0,) * 3})
    target = np.zeros((48, 48, 3), np.float32)
    errors = standard_errors(black, target, blur_px=1.0)
    assert set(errors) >= {"warp.body_reflection", "specular.ior"}
    assert all(not np.isnan(v) for v in errors.values())
    assert errors["specular.ior"] > DETERMINED_SE
