"""Preparation of what real cloth does that the procedural benches did not: colour stripes and
checks, herringbones, colour-and-weave effects; each kind of non-weave rejected with its own
reason and a diagnosis picture; the lattice of the autocorrelation and the colour repeat on
cases with a known answer."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from synthetic import render

from weavecap.prepare import Prepared, Rejected, prepare_photo
from weavecap.prepare.colours import colour_period
from weavecap.prepare.lattice import cell_of, real_gcd, weave_lattice

NAVY, CREAM, GREEN = (0.05, 0.06, 0.2), (0.8, 0.75, 0.6), (0.1, 0.35, 0.1)


def _pitch_error(r: Prepared, truth_px: tuple[float, float]) -> float:
    found = [p / r.rectification.scale for p in r.grid.pitch_px]
    return max(abs(f / t - 1) for f, t in zip(found, truth_px))


def test_a_cream_stripe_on_a_navy_plain_weave_keeps_its_grid():
    """Two cream warps in every eight of a navy plain weave: the brightness is the stripe's,
    the projections of the brightness are not periodic at the yarns (periodicity 0.05 across
    the warps) and the stripe's edges turned the angle search 5.5° off. Seen colour-blind
    (each channel over its own local mean) the yarns are found; the colour repeat is the
    stripe's."""
    img, _ = render("plain", size=(480, 640), pitch_px=(12.0, 12.0), noise=0.01, blur=0.6, jpeg=90,
                    warp_stripes=[NAVY] * 6 + [CREAM] * 2, weft_rgb=NAVY)
    r = prepare_photo(img)
    assert isinstance(r, Prepared), r.reason
    assert r.checks["colour_blind"]
    assert abs(r.rectification.rotation_deg) < 0.5
    assert _pitch_error(r, (12.0, 12.0)) < 0.02
    assert r.colour_repeat.yarns == (1, 8)
    assert r.colour_repeat.spread_de[1] > 20 and r.colour_repeat.spread_de[0] == 0


def test_a_check_keeps_its_yarn_pitch_and_gives_its_colour_repeat():
    img, _ = render("plain", size=(480, 640), pitch_px=(12.0, 12.0), noise=0.01, blur=0.6, jpeg=90,
                    warp_stripes=[CREAM] * 6 + [GREEN] * 6, weft_stripes=[CREAM] * 6 + [GREEN] * 6)
    r = prepare_photo(img)
    assert isinstance(r, Prepared)
    assert _pitch_error(r, (12.0, 12.0)) < 0.02
    assert r.colour_repeat.yarns == (12, 12)
    # one colour per yarn of the repeat: six of one colour, six of the other
    greener = r.colour_repeat.warp_colours[:, 1] / r.colour_repeat.warp_colours.sum(axis=1)
    assert sorted(np.round(greener > np.median(greener)).astype(int)) == [0] * 6 + [1] * 6


def _herringbone(leg: int) -> np.ndarray:
    """A 2/2 herringbone: the twill's diagonal reverses every ``leg`` warps (wefts × warps)."""
    cols = [[1 if (i - j) % 4 < 2 else 0 for i in range(4)] for j in range(leg)]
    cols += [[1 if (i + j) % 4 < 2 else 0 for i in range(4)] for j in range(leg)]
    return np.array(cols, np.uint8).T


@pytest.mark.parametrize("leg, angle", [(4, 0.0), (6, 8.0), (12, -5.0)])
def test_a_herringbone_is_a_woven_grid(leg, angle):
    pattern = _herringbone(leg)
    img, truth = render(pattern, size=(480, 640), pitch_px=(9.0, 9.0), angle_deg=angle, noise=0.01, blur=0.6,
                        jpeg=90)
    r = prepare_photo(img)
    assert isinstance(r, Prepared), r.reason
    assert _pitch_error(r, (9.0, 9.0)) < 0.02
    assert r.grid.yarns == truth.yarns  # (4, 2 × leg): the reversal's whole repeat


@pytest.mark.parametrize("kind, code", [("uniform", "uniform"), ("noise", "no_grid"), ("felt", "no_grid"),
                                        ("too_fine", "too_fine"), ("close_up", "no_grid")])
def test_each_kind_of_non_weave_is_rejected_with_its_reason_and_a_diagnosis(kind, code):
    rng = np.random.default_rng(5)
    if kind == "uniform":
        img = np.full((200, 200, 3), 0.4, np.float32)
    elif kind == "noise":
        img = rng.uniform(0, 1, (256, 256, 3)).astype(np.float32)
    elif kind == "felt":  # smooth random fibres: texture, no lattice
        img = cv2.GaussianBlur(rng.uniform(0, 1, (256, 256)).astype(np.float32), (0, 0), 4)
        img = np.repeat(img[..., None], 3, axis=2)
    elif kind == "too_fine":  # a weave under the sampling limit
        img, _ = render("plain", size=(200, 200), pitch_px=2.2, supersample=4)
    else:  # a close-up of three yarns: no period shows four times
        img, _ = render("plain", size=(200, 200), pitch_px=70.0)
    r = prepare_photo(img)
    assert isinstance(r, Rejected), kind
    assert r.code == code and len(r.reason) > 40
    picture = r.diagnosis(img)
    assert picture.shape[1] >= 900 and picture.shape[0] > 300 and picture.dtype == np.float32
    assert float(picture.std()) > 0.05  # panels and words, not a blank page


def test_a_colour_and_weave_effect_does_not_double_the_pitch():
    """White wefts on grey warps of a plain weave whose brightness repeats over two warps:
    the projection across the warps repeats over two of them, the autocorrelation's lattice
    (one warp across, one weft along) says one."""
    img, _ = render("plain", size=(480, 640), pitch_px=(20.0, 28.0), noise=0.01, blur=0.8, jpeg=90,
                    warp_stripes=[(0.3, 0.3, 0.32), (0.12, 0.12, 0.13)], weft_rgb=(0.85, 0.85, 0.8))
    r = prepare_photo(img)
    assert isinstance(r, Prepared)
    assert _pitch_error(r, (20.0, 28.0)) < 0.02


@pytest.mark.parametrize("pattern", ["plain", "twill_2_1", "satin_5"])
def test_the_lattice_cell_is_the_yarn_pitch_of_plain_twill_and_satin(pattern):
    img, _ = render(pattern, size=(384, 384), pitch_px=(11.0, 14.0), noise=0.01)
    lat = weave_lattice(img, 12.0, min_unit_px=4.0)
    assert lat is not None and lat.score >= 0.5
    assert lat.cell[0] == pytest.approx(11.0, rel=0.03) and lat.cell[1] == pytest.approx(14.0, rel=0.03)
    # the interlacings of a plain weave and a twill: one warp across and one weft along
    assert lat.oblique or pattern == "satin_5"  # this satin's gaps match at every yarn: rectangular


def test_real_gcd_and_cell_on_known_vectors():
    assert real_gcd(np.array([48.0, 24.2]), tol=1.5, min_unit=4, max_multiple=6) == pytest.approx(24.1, abs=0.1)
    assert real_gcd(np.array([0.3, 30.0]), tol=1.5, min_unit=4, max_multiple=6) == pytest.approx(30.0)
    assert real_gcd(np.array([0.2, 0.4]), tol=1.5, min_unit=4, max_multiple=6) is None
    # a 5-end satin of step 2: lattice basis (2, 1) and (1, -2) yarns, yarns 24 × 10 px
    basis = np.array([[48.0, 10.0], [24.0, -20.0]])
    assert cell_of(basis, tol=1.5, min_unit=4.0) == (pytest.approx(24.0), pytest.approx(10.0))


def test_colour_period_of_yarn_sequences():
    rng = np.random.default_rng(0)
    solid = np.tile([[0.3, 0.2, 0.1]], (30, 1)) * (1 + rng.normal(0, 0.01, (30, 3)))
    assert colour_period(solid)[0] == 1
    stripe = np.array([NAVY] * 5 + [CREAM] * 3 + [NAVY] * 5 + [CREAM] * 3 + [NAVY] * 5 + [CREAM] * 3)
    n, colours = colour_period(stripe)
    assert n == 8 and np.allclose(sorted(colours[:, 0]), [NAVY[0]] * 5 + [CREAM[0]] * 3)


def test_a_no_grid_rejection_names_the_test_that_failed():
    """The sentence never says the lattice fits too little where it fits well: it names the
    projection that has no period, and whichever of the lattice's tests failed with its figure
    and bound (a satin's floats hide one axis; a lattice that fits but has no cell there)."""
    from weavecap.prepare.lattice import Lattice
    from weavecap.prepare.config import PrepareConfig
    from weavecap.prepare.pipeline import no_grid_reason

    config = PrepareConfig()
    basis = np.array([[24.0, 19.0], [-24.0, 29.0]])
    fits = Lattice(basis=basis, cell=(24.0, None), score=0.9, peaks=np.zeros((0, 3)))
    weak = Lattice(basis=basis, cell=(24.0, 9.6), score=0.2, peaks=np.zeros((0, 3)))
    pitches, strengths, periodic = [24.0, None], [0.6, 0.02], [True, False]
    said = no_grid_reason(pitches, strengths, periodic, fits, config)
    assert "across the wefts (periodicity 0.02, at least 0.2" in said and "across the warps" not in said.split("(")[0]
    assert "fit 0.900" in said and "no cell along that axis" in said and "fits only" not in said
    said = no_grid_reason(pitches, strengths, periodic, weak, config)
    assert "fits only 0.200 (at least 0.35 needed)" in said
    said = no_grid_reason([None, None], [0.05, 0.04], [False, False], fits, config)
    assert "across the warps nor across the wefts (periodicity 0.04" in said and "lattice" not in said
    assert "shifts" in no_grid_reason(pitches, strengths, periodic, None, config)
    # an axis periodic by the spectral lattice alone: the figure quoted is the flat axis's
    said = no_grid_reason([9.6, None], [0.05, 0.12], [True, False], weak, config)
    assert "across the wefts (periodicity 0.12" in said
