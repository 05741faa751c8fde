"""Unit tests of the preparation stages (Wu et al. 2025 §4) on small synthetic weaves.

The synthetic photos come from ``synthetic.py`` beside this file (procedural, known truth).
"""

from __future__ import annotations

import numpy as np
import pytest
from synthetic import PATTERNS, render, residual_geometry

from weavecap.errors import ParamsError
from weavecap.prepare import PrepareConfig, Rejected, prepare_photo, rectify, regularize
from weavecap.prepare.grid import axis_pitch, boundaries, folded_strength, refine_repeat, repeat_along
from weavecap.prepare.illumination import flatten_illumination
from weavecap.prepare.period import superposed_dmf


# ------------------------------------------------------------------ illumination

def test_flatten_illumination_removes_vignetting():
    img, _ = render("plain", size=(192, 192), pitch_px=8, vignette=0.6)
    flat, gain = flatten_illumination(img, sigma_px=16)
    assert flat.shape == img.shape and gain.shape == img.shape[:2]
    q = 48

    def corner_ratio(a):
        g = a.mean(axis=2)
        return g[:q, :q].mean() / g[72:120, 72:120].mean()

    assert corner_ratio(img) < 0.75
    assert abs(corner_ratio(flat) - 1) < 0.1


# ------------------------------------------------------------------ rectification (§4.1)

@pytest.mark.parametrize("angle", [-40.0, -12.5, 0.0, 7.0, 33.0])
def test_rectify_turn_sign_and_accuracy(angle):
    img, truth = render("twill_2_1", size=(256, 256), pitch_px=9, angle_deg=angle, noise=0.01, seed=1)
    r = rectify(img)
    assert r is not None
    # the photo is the fabric turned clockwise by `angle`: undoing it is a CCW turn of +angle
    assert abs(r.rotation_deg - angle) < 0.5
    g = residual_geometry(r.homography, truth, img.shape[:2])
    assert abs(g["turn_deg"]) < 0.5 and g["skew"] < 0.01
    assert r.homography.shape == (3, 3) and abs(r.rotation_deg) <= 45


def test_rectify_undoes_perspective():
    img, truth = render("plain", size=(320, 320), pitch_px=8, angle_deg=15, pitch_deg=10, yaw_deg=-8, seed=2)
    r = rectify(img)
    before = residual_geometry(np.eye(3), truth, img.shape[:2])["perspective"]
    after = residual_geometry(r.homography, truth, img.shape[:2])
    assert before > 0.05
    assert after["perspective"] < 0.01 and after["skew"] < 0.01


def test_rectify_flat_image_gives_none():
    assert rectify(np.full((64, 64, 3), 0.5, np.float32)) is None


# ------------------------------------------------------------------ period (§4.3) and grid (§4.4)

def test_dmf_dips_at_the_repeat():
    x = np.arange(300)
    row = np.sin(2 * np.pi * x / 10) + 0.5 * np.sin(2 * np.pi * x / 30)
    img = np.tile(row, (20, 1))
    d = superposed_dmf(img, axis=1)
    assert d[30] < 0.01 and d[10] > 0.1 and d[15] > 1.0
    n, depth = repeat_along(d, 10.0)
    assert n == 3 and abs(refine_repeat(d, 10.0, n) - 30) < 0.2 and depth > 0.9


def test_repeat_along_reports_no_dip():
    rng = np.random.default_rng(0)
    d = superposed_dmf(rng.normal(size=(40, 200)), axis=1)
    n, depth = repeat_along(d, 8.0)
    assert n is None and depth < 0.3


def test_axis_pitch_and_boundaries_of_a_profile():
    x = np.arange(400, dtype=float)
    pitch = 9.3
    prof = np.cos(2 * np.pi * (x - 2.0) / pitch)  # valleys at 2 + pitch/2 + k pitch
    per, s = axis_pitch(prof, min_period=2, max_period=100)
    assert abs(per - pitch) / pitch < 0.01 and s > 0.9
    b = boundaries(prof, per)
    expect = 2.0 + pitch / 2 + pitch * np.arange(len(b))
    assert np.max(np.abs(b - expect[: len(b)])) < 0.5
    assert folded_strength(np.random.default_rng(0).normal(size=400), pitch) < 0.1


def test_regularize_keeps_whole_repeats_and_removes_noise():
    clean, _ = render("twill_3_1", size=(256, 256), pitch_px=8, seed=3, supersample=1)
    noisy = clean + np.random.default_rng(0).normal(0, 0.05, clean.shape).astype(np.float32)
    r = regularize(noisy, pitch_px=(8.0, 8.0), repeat_px=(32.0, 32.0), origin_px=(0.0, 0.0))
    assert r.method == "kpca" and r.repeats >= 6 and r.components > 0
    y0, x0, y1, x1 = r.box
    assert r.image.shape[:2] == (round(y1 - y0), round(x1 - x0))
    y0, x0 = int(round(y0)), int(round(x0))
    ref = clean[y0:y0 + r.image.shape[0], x0:x0 + r.image.shape[1]]
    noisy_c = noisy[y0:y0 + r.image.shape[0], x0:x0 + r.image.shape[1]]
    assert np.abs(r.image - ref).mean() < 0.7 * np.abs(noisy_c - ref).mean()


def test_regularize_without_repeat_is_gaussian_only():
    img, _ = render("plain", size=(96, 96), pitch_px=8)
    r = regularize(img, pitch_px=(8.0, 8.0), repeat_px=(None, 16.0))
    assert r.method == "gaussian" and r.note


# ------------------------------------------------------------------ rejection

@pytest.mark.parametrize("kind", ["uniform", "noise", "too_fine", "blobs"])
def test_non_weaves_are_rejected_with_a_reason(kind):
    rng = np.random.default_rng(5)
    if kind == "uniform":
        img = np.full((200, 200, 3), 0.4, np.float32)
    elif kind == "noise":
        img = rng.uniform(0, 1, (256, 256, 3)).astype(np.float32)
    elif kind == "too_fine":
        img, _ = render("plain", size=(200, 200), pitch_px=2.2, supersample=4)
    else:  # felt-like: smooth random blobs
        import cv2
        img = cv2.GaussianBlur(rng.uniform(0, 1, (256, 256)).astype(np.float32), (0, 0), 4)
        img = np.repeat(img[..., None], 3, axis=2)
    r = prepare_photo(img)
    assert isinstance(r, Rejected), kind
    assert r.reason and r.code in {"uniform", "no_texture", "too_fine", "not_woven", "no_grid", "few_yarns"}


def test_a_given_repeat_is_used_in_place_of_the_one_the_photo_shows():
    """A photo shows a repeat's look, which can be shorter than the fabric's: a repeat known
    from elsewhere (``weavecap fit --pattern``) is used, over the same pitch, and the photo's own
    is recorded; one longer than the photo, or not a multiple of the repeat the photo shows, is
    refused with the counts."""
    img, _ = render("twill_3_1", size=(256, 256), pitch_px=10, seed=2)
    own = prepare_photo(img)
    given = prepare_photo(img, repeat=(4, 8))
    assert own.grid.yarns == (4, 4) and given.grid.yarns == (4, 8)
    assert given.checks["repeat_in_photo"] == [4, 4] and given.checks["repeat_from"] == ["given", "given"]
    assert given.grid.repeat_px[1] == pytest.approx(2 * own.grid.repeat_px[1], rel=0.01)
    assert given.grid.repeat_px[0] == pytest.approx(own.grid.repeat_px[0], rel=0.01)
    with pytest.raises(ParamsError, match="repeats over 40 wefts, but the photo shows only 25 whole wefts") as err:
        prepare_photo(img, repeat=(40, 4))
    assert err.value.field == "pattern"
    with pytest.raises(ParamsError, match="the photo's repeat is 4 wefts x 4 warps, which does not divide it"):
        prepare_photo(img, repeat=(6, 4))  # the photo repeats over 4 wefts: no fabric repeats over 6


def test_config_is_plain_data():
    c = PrepareConfig()
    assert c.gaussian_sigma_pitch == 1 / 16 and c.min_pitch_px == 3.5
    with pytest.raises(Exception):
        c.min_pitch_px = 1.0  # frozen


def test_patterns_cover_the_issue():
    assert {"plain", "twill_2_1", "satin_5", "satin_8", "basket_2_2", "custom_6x4"} <= set(PATTERNS)
