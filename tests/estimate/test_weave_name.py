"""Weave names for people, invariant to cyclic shifts and repeats (weavecap.estimate.weave_name)."""

import numpy as np
import pytest
from estimate_data import FIXTURES

from weavecap import params
from weavecap.estimate.sampling import herringbone, point_twill, satin, twill
from weavecap.estimate.weave_name import (equal_up_to_shift, minimal_repeat, shift_agreement, weave_family,
                                          weave_name)



@pytest.mark.parametrize("name, expected", [
    ("plain", "plain"), ("twill_2_1", "twill 2/1 S"), ("twill_3_1", "twill 3/1 S"),
    ("satin_5", "satin 5/2 weft-faced"), ("basket_2_2", "basket 2/2"), ("custom_4x6", "custom 4×6")])
def test_fixture_weaves_are_named(name, expected):
    assert weave_name(params.load(FIXTURES / f"{name}.json").pattern) == expected


@pytest.mark.parametrize("pattern, expected", [
    (twill(2, 2, step=-1), "twill 2/2 Z"), (twill(1, 3), "twill 1/3 S"), (1 - satin(8, 3), "satin 8/3 warp-faced"),
    (np.kron(np.array([[1, 0], [0, 1]]), np.ones((2, 1), int)), "rib 2 (wefts doubled)"),
    (np.ones((2, 3), int), "custom 1×1 (yarns that never interlace)"),
    # a satin's derivative: two raised cells a row, each row moved 3 (the W108 photo's fit)
    (np.array([[0, 1, 1, 0, 0], [1, 0, 0, 0, 1], [0, 0, 1, 1, 0], [1, 1, 0, 0, 0], [0, 0, 0, 1, 1]]),
     "satin 5/3 extended 2/3"),
    (np.array([np.roll([1, 1, 1, 0, 0, 0, 0, 0], 3 * i) for i in range(8)]), "satin 8/3 extended 3/5"),
    (np.array([np.roll([1, 1, 0, 0, 0], i) for i in range(5)]), "twill 2/3 S"),
    (np.array([np.roll([1, 0, 1, 0, 0], 2 * i) for i in range(5)]), "custom 5×5")])
def test_more_weaves(pattern, expected):
    assert weave_name(pattern) == expected


@pytest.mark.parametrize("name", ["twill_2_1", "satin_5", "basket_2_2", "custom_4x6"])
def test_names_do_not_depend_on_shift_or_repeats(name):
    p = params.load(FIXTURES / f"{name}.json").pattern
    for shift in [(1, 0), (0, 2), (3, 1)]:
        assert weave_name(np.roll(p, shift, axis=(0, 1))) == weave_name(p)
    assert weave_name(np.tile(p, (2, 3))) == weave_name(p)


def test_comparisons_up_to_shift():
    p = twill(3, 2)
    q = np.roll(p, (2, 1), axis=(0, 1))
    assert equal_up_to_shift(p, q) and not equal_up_to_shift(p, 1 - p)
    agree, shift = shift_agreement(p, q)
    assert agree == 1.0 and np.array_equal(np.roll(q, shift, axis=(0, 1)), p)
    r = q.copy()
    r[0, 0] ^= 1
    assert shift_agreement(p, r)[0] == pytest.approx(24 / 25)
    assert minimal_repeat(np.tile(p, (2, 2))).shape == (5, 5)


@pytest.mark.parametrize("pattern, expected", [
    (herringbone(twill(2, 2), 4), "herringbone 2/2, legs of 4 warps"),
    (np.roll(1 - herringbone(twill(2, 2), 6), (1, 3), axis=(0, 1)), "herringbone 2/2, legs of 6 warps"),
    (herringbone(twill(1, 2), 5).T, "herringbone 1/2, legs of 5 wefts"),
    (point_twill(twill(3, 1), 6), "point twill 3/1, legs of 6 warps"),
    (np.kron(np.array([[1, 0], [0, 1]]), np.ones((2, 3), int)), "basket 2/3"),
    (np.kron(np.array([[1, 0], [0, 1]]), np.ones((3, 3), int)), "basket 3/3")])
def test_broken_twills_and_hopsacks_are_named_with_their_parameters(pattern, expected):
    assert weave_name(pattern) == expected


@pytest.mark.parametrize("name, family", [
    ("plain", "plain"), ("twill 2/1 S", "twill"), ("herringbone 2/2, legs of 4 warps", "twill"),
    ("point twill 1/3, legs of 4 wefts", "twill"), ("satin 5/3 extended 2/3", "satin"), ("basket 2/3", "basket"),
    ("rib 2 (wefts doubled)", "rib"), ("custom 4×6", "custom"), ("custom 1×1 (yarns that never interlace)", "custom")])
def test_every_name_has_a_family(name, family):
    assert weave_family(name) == family
