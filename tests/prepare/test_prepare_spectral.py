"""The spectral choices of preparation (Wu et al. 2025 §4.1, §4.3–4.4) that real photos need.

- the working resolution follows the *finest* strong period (the yarns), not the strongest
  (a twill's diagonal, a satin's lattice of interlacings);
- among equally strong pairs of line families the squarest one is the yarns;
- a lattice line family of the harmonics a few degrees off a yarn family (thin sharp gaps)
  does not take its place: the fine re-check moves to the yarns, and once the pitch is
  measured the Radon is tuned to the yarn frequency;
- a satin whose floats hide one family's yarn boundaries still has its pitch, from the
  lattice of spectral peaks.
"""

from __future__ import annotations

import importlib

import numpy as np
from synthetic import render, satin

from weavecap.prepare import PrepareConfig
from weavecap.prepare.grid import lattice_pitch, lattice_yarns, spectrum_peaks
from weavecap.prepare.illumination import luminance

rectify_mod = importlib.import_module("weavecap.prepare.rectify")


def _stripes(period: float, amplitude: float, angle_deg: float, n: int = 384) -> np.ndarray:
    yy, xx = np.indices((n, n), dtype=float)
    t = np.deg2rad(angle_deg)
    return amplitude * np.cos(2 * np.pi * (xx * np.cos(t) + yy * np.sin(t)) / period)


def test_coarse_pitch_is_the_finest_strong_period():
    # a strong coarse diagonal (a twill line) over a weaker yarn grid of period 10
    img = 1.0 + _stripes(40, 0.4, 35) + _stripes(10, 0.1, 0) + _stripes(10, 0.1, 90)
    p = rectify_mod.coarse_pitch(img.astype(np.float32))
    assert abs(p - 10) < 0.5, p


def test_coarse_pitch_ignores_broad_noise():
    rng = np.random.default_rng(1)
    img = 1.0 + _stripes(16, 0.3, 10) + rng.normal(0, 0.3, (384, 384))
    p = rectify_mod.coarse_pitch(img.astype(np.float32))
    assert abs(p - 16) < 1.0, p


def test_squarest_of_equally_strong_pairs_wins():
    thetas = np.arange(0.0, 180.0, 1.0)

    def bumps(centres_heights):
        return sum(h * np.exp(-0.5 * (((thetas - c + 90) % 180 - 90) / 2.0) ** 2) for c, h in centres_heights)

    pair = 0.01 + bumps([(31, 1.0), (121, 1.0), (2, 0.93), (92, 0.93)])
    assert thetas[rectify_mod._squarest_pair(pair, thetas, tie=0.85)] == 2
    pair = 0.01 + bumps([(31, 1.0), (121, 1.0), (2, 0.5), (92, 0.5)])
    assert thetas[rectify_mod._squarest_pair(pair, thetas, tie=0.85)] == 31


def _radon_grating(theta_deg: float, period: float, n: int = 320) -> np.ndarray:
    """Cosine lines whose Radon variance (skimage's angle convention) peaks at ``theta_deg``."""
    yy, xx = np.indices((n, n), dtype=float) - (n - 1) / 2
    t = np.deg2rad(theta_deg)
    return np.cos(2 * np.pi * (xx * np.cos(t) - yy * np.sin(t)) / period).astype(np.float32)


def test_recheck_moves_off_a_harmonic_lattice_line():
    """Forward-model renders with thin bright gaps (bench sweep, seed 7, #9 and #25): the coarse
    Radon picked a line family of the repeat's lattice at the third harmonic, 3.2° off the weak
    weft family, and the weft pitch came out 64 % wrong."""
    img = _radon_grating(3.0, 8) + 0.5 * _radon_grating(96.0, 8) + 0.25 * _radon_grating(92.8, 8 / 3)
    edge = rectify_mod._disc(rectify_mod._laplacian_edges(img), 320)
    first, second = rectify_mod._recheck_pair(edge, [92.8, 3.0], PrepareConfig())
    assert abs(first - 96.0) < 0.2 and abs(second - 3.0) < 0.2


def test_recheck_keeps_an_ambiguous_choice():
    img = _radon_grating(3.0, 8) + 0.5 * _radon_grating(96.0, 8) + 0.48 * _radon_grating(92.8, 8)
    edge = rectify_mod._disc(rectify_mod._laplacian_edges(img), 320)
    first, _ = rectify_mod._recheck_pair(edge, [92.8, 3.0], PrepareConfig())
    assert abs(first - 92.8) < 0.3


def test_measured_pitch_tunes_the_radon_to_the_yarns():
    """With the pitch measured, a harmonic lattice line stronger than the weak yarn family under
    the plain Laplacian no longer wins (forward-model render, seed 7, #25)."""
    img = _radon_grating(3.0, 8) + 0.3 * _radon_grating(96.0, 8) + 0.25 * _radon_grating(92.8, 8 / 2.2)
    lap = rectify_mod._disc(rectify_mod._laplacian_edges(img), 320)
    assert rectify_mod._radon_variance(lap, np.array([92.8]))[0] > rectify_mod._radon_variance(lap, np.array([96.0]))[0]
    ang = rectify_mod.dominant_angles(img, pitch_px=8.0, band=True)
    assert abs(ang["horizontal_deg"] - (90.0 - 96.0)) < 0.3, ang
    assert abs(ang["vertical_deg"] - 87.0) < 0.3, ang


def test_lattice_pitch_of_an_ideal_satin():
    px, py, n = 12.0, 5.0, 5
    pts = [(a / (n * px), b / (n * py), 1.0) for a in range(0, 11) for b in range(-10, 11)
           if (a - 2 * b) % n == 0 and (a, b) != (0, 0) and (a > 0 or b > 0)]
    peaks = np.array(pts)
    p, share = lattice_pitch(peaks, known_pitch=px, axis=1, tol=1e-4)
    assert abs(p - py) < 1e-6 and share == 1.0
    p, _ = lattice_pitch(peaks, known_pitch=py, axis=0, tol=1e-4)
    assert abs(p - px) < 1e-6


def test_lattice_pitch_of_a_rendered_satin():
    img, truth = render("satin_5", size=(320, 320), pitch_px=(11.0, 6.0), noise=0.01, seed=4)
    grey = luminance(img)
    peaks = spectrum_peaks(grey, max_side=320)
    p, share = lattice_pitch(peaks, known_pitch=11.0, axis=1, tol=0.75 / 320)
    assert p is not None and abs(p / 6.0 - 1) < PrepareConfig().lattice_pitch_tol and share >= 0.85


def test_lattice_pitch_needs_a_lattice():
    rng = np.random.default_rng(2)
    peaks = np.column_stack([rng.uniform(0, 0.3, 12), rng.uniform(-0.3, 0.3, 12), rng.uniform(0.1, 1, 12)])
    p, _ = lattice_pitch(peaks, known_pitch=9.0, axis=1, tol=0.002)
    assert p is None


def test_satin_with_hidden_weft_boundaries_gets_its_weft_pitch_from_the_lattice():
    import cv2

    from weavecap.prepare import Prepared, Rejected, prepare_photo

    img, _ = render("satin_5", size=(384, 384), pitch_px=(11.0, 6.0), angle_deg=3, noise=0.01, seed=4)
    # blur along y only: the weft boundaries (6 px apart) fade, the interlacings stay
    img = cv2.GaussianBlur(img, (0, 0), sigmaX=0.3, sigmaY=2.5)
    r = prepare_photo(img)
    assert isinstance(r, Prepared), getattr(r, "reason", "")
    assert r.checks["grid_strength"][1] < PrepareConfig().min_grid_strength  # the projection is flat
    warp, weft = (p / r.rectification.scale for p in r.grid.pitch_px)
    assert abs(warp / 11 - 1) < 0.02 and abs(weft / 6 - 1) < 0.02
    assert tuple(r.grid.yarns) == (5, 5)
    # without the lattices (the spectral one, and the autocorrelation's) the same photo has no grid
    assert isinstance(prepare_photo(img, PrepareConfig(lattice_min_known_strength=1.01, lattice_woven_score=1.01)),
                      Rejected)


def test_lattice_pitch_of_a_rib_counts_its_hidden_yarns_from_the_crossings():
    """A 2 × 8 rib (wefts floating over four warps) has the lattice of a plain weave of warps four
    times as wide; the crossings of the warp gaps with the weft gaps tell the warps apart
    (forward-model render, seed 11, #34: 44.6 px found for 12.8 px)."""
    px, py = 10.0, 14.0
    lattice = [(a / (8 * px), (b - a / 2) / py, 1.0 / a ** 2) for a in range(1, 7) for b in range(-1, 3)
               if (b - a / 2) != 0]
    crossings = [(1 / px, 1 / py, 0.3), (2 / px, 1 / py, 0.2)]
    p, share = lattice_pitch(np.array(lattice + crossings), known_pitch=py, axis=0, tol=1e-4)
    assert p is not None and abs(p / px - 1) < 1e-6 and share == 1.0


def test_spectrum_peaks_do_not_move_with_rounding_noise():
    """A perturbation of one part in a million finds the same peaks: under OpenCV 5 a float32
    local maximum compared with the float64 power dropped every peak that rounded up, and the
    real W103 twill was rejected for want of its lattice."""
    img, _ = render("satin_5", size=(256, 256), pitch_px=(11.0, 6.0), noise=0.01, seed=4)
    grey = luminance(img).astype(np.float64)
    rng = np.random.default_rng(0)
    a = spectrum_peaks(grey, max_side=256)
    for _ in range(3):
        b = spectrum_peaks(grey * (1 + 1e-6 * rng.standard_normal(grey.shape)), max_side=256)
        assert a.shape == b.shape and np.allclose(a[:, :2], b[:, :2], atol=1e-4)


def test_lattice_pitch_finds_sub_bin_units():
    """Peaks a fraction of a bin off the lattice still give the pitch to a fraction of a percent:
    the unit is fitted over every peak on it, not read off the one it was found from."""
    px, py, n = 16.9, 16.1, 4
    rng = np.random.default_rng(3)
    pts = [(a / (n * px) + rng.normal(0, 2e-4), b / (n * py) + rng.normal(0, 2e-4), 1.0 / (a * a + b * b))
           for a in range(1, 6) for b in range(-5, 6) if (a - b) % n == 0 and b != 0]
    p, share = lattice_pitch(np.array(pts), known_pitch=py, axis=0, tol=0.75 / 147)
    assert p is not None and abs(p / px - 1) < 0.01, p


def test_lattice_yarns_of_an_ideal_satin_and_twill():
    """The fewest yarns whose lines m·k/n hold the interlacings' peaks are the repeat, along
    both axes (a 7-end satin of step 3, a 2/1 twill)."""
    for n, move in ((7, 3), (3, 1)):
        px, py = 30.0, 10.0
        pts = [(a / (n * px), b / (n * py), 1.0) for a in range(0, 15) for b in range(-14, 15)
               if (a - move * b) % n == 0 and (a, b) != (0, 0) and (a > 0 or b > 0)]
        peaks = np.array(pts)
        assert lattice_yarns(peaks, pitch=px, axis=0, tol=1e-4) == n
        assert lattice_yarns(peaks, pitch=py, axis=1, tol=1e-4) == n


def test_lattice_yarns_see_a_repeat_the_photo_holds_once():
    """A 7-end satin of wide warps (36 px) in a 384 px wide photo: 10.7 warps, one repeat and a
    half, too few for a DMF (it compares shifts up to half the photo); the spectral lattice of
    the interlacings still counts 7 warps (and 7 wefts), as in the real FabricNET W127."""
    img, _ = render(satin(7, 3), size=(320, 384), pitch_px=(36.0, 12.0), noise=0.01, seed=1)
    grey = luminance(img)
    peaks = spectrum_peaks(grey, max_side=320)
    assert lattice_yarns(peaks, pitch=36.0, axis=0, tol=0.75 / 320) == 7
    assert lattice_yarns(peaks, pitch=12.0, axis=1, tol=0.75 / 320) == 7


def test_lattice_yarns_need_a_lattice():
    rng = np.random.default_rng(2)
    peaks = np.column_stack([rng.uniform(0, 0.3, 12), rng.uniform(-0.3, 0.3, 12), rng.uniform(0.1, 1, 12)])
    assert lattice_yarns(peaks, pitch=9.0, axis=0, tol=0.002) is None
