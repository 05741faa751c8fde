"""§6.3 noise: fitting 2D Gaussians to a residual's spectrum and synthesizing matching noise."""

from __future__ import annotations

import jsonschema
import numpy as np
import pytest

from weavecap.noise import add_noise, fit_noise, irregularity, spectrum, synthesize
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
    for image in (np.zeros((40, 40, 3), np.float32), np.full((40, 40, 3), 0.5, np.float32)):
        noisy = add_noise(image, LOUD, pitch_px=10, seed=0)
        assert np.isfinite(noisy).all() and noisy.min() >= 0
    assert add_noise(np.zeros((40, 40, 3), np.float32), LOUD, pitch_px=10, seed=0).max() == 0  # black stays black
    assert spectrum(KNOWN, (1, 1), 10).shape == (1, 1)


#: a noise loud enough to clip: a relative standard deviation of 1.4
LOUD = {"gaussians": [{"weight": 1.0, "mean": [0.0, 1.0], "cov": [[0.05, 0.0], [0.0, 0.05]]}]}


def test_noise_is_relative_so_the_exposure_does_not_change_the_look():
    """The same capture shown a stop brighter gets the same grain a stop brighter: the noise
    multiplies the image (its weights are variances of relative brightness)."""
    rng = np.random.default_rng(0)
    image = rng.uniform(0.05, 0.4, (64, 64, 3)).astype(np.float32)
    once = add_noise(image, KNOWN, pitch_px=8, seed=3)
    np.testing.assert_allclose(add_noise(2 * image, KNOWN, pitch_px=8, seed=3), 2 * once, rtol=1e-5)
    assert np.std(once / image - 1) == pytest.approx(np.sqrt(8e-4), rel=0.1)


def _repeats(tile: np.ndarray, times: tuple[int, int]) -> np.ndarray:
    return np.tile(tile, (times[0], times[1], 1))


def test_irregularity_is_what_differs_between_repeats_relative_to_the_photo():
    """A photo of 8 × 6 repeats of a 3 × 2 weave at 10 px a cell: the render plus a misfit that
    repeats with the weave (the model's error, not an irregularity), times (1 + a known relative
    noise) and a slow light falloff. The irregularity is the known noise: the misfit and
    the falloff are not in it, and its variance is the noise's whatever the exposure."""
    c, repeat, times = 10, (3, 2), (8, 6)
    rng = np.random.default_rng(1)
    render = _repeats(rng.uniform(0.2, 0.4, (repeat[0] * c, repeat[1] * c, 1)), times).repeat(3, axis=2)
    known = synthesize(KNOWN, render.shape[:2], pitch_px=c, seed=4)
    misfit = _repeats(0.1 * rng.standard_normal((repeat[0] * c, repeat[1] * c, 1)), times)
    y = np.linspace(-1, 1, render.shape[0])[:, None, None]
    photo = (render + misfit) * (1 + known[..., None]) * (1 + 0.2 * y)
    fabric = (render + misfit).mean(axis=2)
    truth = known * fabric / fabric.mean()  # the noise as the photo shows it, relative to its brightness
    for exposure in (1.0, 4.0):
        found = irregularity(exposure * photo, exposure * render, cell_px=c, repeat=repeat)
        assert np.corrcoef(found.ravel(), truth.ravel())[0, 1] > 0.9  # measured 0.93
        assert found.var() == pytest.approx(truth.var(), rel=0.2)  # measured 1.15 times
    # the whole residual, as fitted before, is mostly the misfit and the falloff
    whole = (photo - render).mean(axis=2) / np.mean(photo)
    assert whole.var() > 20 * found.var()


def test_irregularity_of_a_repeat_seen_once_is_the_residual_itself():
    """A cell of the repeat seen once has no mean over repeats to take away: its residual is
    kept; a black photo has none."""
    c, repeat = 8, (4, 4)
    rng = np.random.default_rng(2)
    render = np.full((2 * c, 2 * c, 3), 0.3)
    photo = render + 0.01 * rng.standard_normal(render.shape[:2])[..., None]
    found = irregularity(photo, render, cell_px=c, repeat=repeat)
    assert found.std() > 0.5 * 0.01 / 0.3
    assert not irregularity(np.zeros_like(photo), render, cell_px=c, repeat=repeat).any()
