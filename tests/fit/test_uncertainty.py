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

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "params"


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
    for key in ("specular.roughness", "shadowing.ply", "warp.radius"):
        assert high[key] / low[key] == pytest.approx(4.0, rel=0.25), key
    # the yarn radii and the roughness shape every pixel; the exit lobe's ior and the
    # attenuation barely move a render over their narrow Table 1 ranges
    for key in ("warp.radius", "weft.radius", "specular.roughness", "shadowing.ply"):
        assert low[key] <= DETERMINED_SE, (key, low[key])
    for key in ("specular.ior_exit", "specular.attenuation"):
        assert low[key] > DETERMINED_SE, (key, low[key])
    assert all(v >= 0 and not np.isnan(v) for v in low.values())


def test_no_photo_separates_the_body_colours_from_their_mix(twill):
    """m_r R^B and (1 − m_r) S^B are all a render shows: moving m_r with both colours rescaled
    renders the same image, so even a noise-free photo leaves the colours and m_r open."""
    fabric, image = twill
    m, d = fabric.specular.coefficient, -0.1
    moved = {"specular.coefficient": m + d}
    for yarn in ("warp", "weft"):
        moved[f"{yarn}.body_reflection"] = tuple(np.asarray(fabric.get(f"{yarn}.body_reflection")) * m / (m + d))
        moved[f"{yarn}.body_subsurface"] = tuple(np.asarray(fabric.get(f"{yarn}.body_subsurface")) * (1 - m) / (1 - m - d))
    other = render_numpy(build_scene(fabric.replace(moved), View(tiles=(1, 1), size=image.shape[0], spp=4)))
    assert np.abs(other - image).max() < 1e-5
    errors = standard_errors(fabric, image + np.random.default_rng(2).normal(0, 1e-4, image.shape), blur_px=0.0)
    for key in ("specular.coefficient", "warp.body_reflection", "weft.body_subsurface"):
        assert errors[key] > DETERMINED_SE, (key, errors[key])
    assert errors["warp.radius"] < 0.01 * DETERMINED_SE


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
