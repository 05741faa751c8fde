"""§6.3 noise: fitting 2D Gaussians to a residual's spectrum and synthesizing matching noise."""

from __future__ import annotations

import jsonschema
import numpy as np
import pytest

from weavecap.noise import add_noise, fit_noise, spectrum, synthesize
from weavecap.params import _schema

KNOWN = {"gaussians": [{"weight": 4e-4, "mean": [0.0, 1.5], "cov": [[0.02, 0.0], [0.0, 0.02]]},
                       {"weight": 4e-4, "mean": [0.0, -1.5], "cov": [[0.02, 0.0], [0.0, 0.02]]}]}


def test_synthesized_noise_has_the_model_variance_and_frequency():
    tile = synthesize(KNOWN, (256, 256), pitch_px=16, seed=1)
    assert tile.var() == pytest.approx(8e-4, rel=0.01)
    power = np.abs(np.fft.fft2(tile)) ** 2
    fy, fx = np.unravel_index(np.argmax(power), power.shape)
    freq_x = np.fft.fftfreq(256)[fx] * 16  # cycles per pitch
    assert abs(abs(freq_x) - 1.5) < 0.2 and abs(np.fft.fftfreq(256)[fy] * 16) < 0.2


def test_fit_recovers_variance_and_peak_frequency_of_a_known_spectrum():
    residual = synthesize(KNOWN, (256, 256), pitch_px=16, seed=2)
    model = fit_noise(residual, pitch_px=16, components=2, seed=0)
    jsonschema.validate({"gaussians": model["gaussians"]}, _schema()["properties"]["noise"])
    # each known Gaussian found, carrying its own share of the variance (the weights sum to the
    # variance by construction; how they split does not): measured 3.89e-4 / 4.11e-4 for 4e-4
    # each, means within 0.013 cycles per pitch, covariance diagonals 0.0191–0.0204 for 0.02
    found = sorted(model["gaussians"], key=lambda g: g["mean"][1])
    for g, truth in zip(found, sorted(KNOWN["gaussians"], key=lambda g: g["mean"][1])):
        assert g["weight"] == pytest.approx(truth["weight"], rel=0.05)
        np.testing.assert_allclose(g["mean"], truth["mean"], atol=0.03)
        np.testing.assert_allclose(np.diag(g["cov"]), np.diag(truth["cov"]), rtol=0.1)
    # resynthesis at another resolution keeps the variance
    again = synthesize(model, (128, 96), pitch_px=8, seed=3)
    assert again.var() == pytest.approx(residual.var(), rel=0.15)


@pytest.mark.parametrize("residual", [np.zeros((32, 32)), np.full((8, 8), np.nan), np.zeros((1, 1)),
                                      np.array([[np.inf, 0.0], [0.0, 0.0]])], ids=["zero", "nan", "1px", "inf"])
def test_degenerate_residuals_give_no_noise(residual):
    model = fit_noise(residual, pitch_px=10)
    assert model == {"gaussians": []}
    image = np.full((16, 16, 3), 0.5, dtype=np.float32)
    assert np.array_equal(add_noise(image, model, pitch_px=10), image)


def test_same_seed_same_noise_and_tiles_are_periodic():
    a = synthesize(KNOWN, (64, 80), pitch_px=10, seed=5)
    assert np.array_equal(a, synthesize(KNOWN, (64, 80), pitch_px=10, seed=5))
    assert not np.array_equal(a, synthesize(KNOWN, (64, 80), pitch_px=10, seed=6))
    # periodic: the jump across the wrap is like any neighbour difference
    assert np.abs(a[0] - a[-1]).mean() < 3 * np.abs(np.diff(a, axis=0)).mean()


def test_added_noise_keeps_images_finite_and_non_negative():
    image = np.zeros((40, 40, 3), dtype=np.float32)
    noisy = add_noise(image, KNOWN, pitch_px=10, seed=0)
    assert np.isfinite(noisy).all() and noisy.min() >= 0 and noisy.max() > 0
    assert spectrum(KNOWN, (1, 1), 10).shape == (1, 1)
