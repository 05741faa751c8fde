"""The library of named weaves the fit tries as starts (weavecap.estimate.sampling.regular_weaves)."""

from __future__ import annotations

import numpy as np
import pytest

from weavecap.estimate.sampling import interlaces, named_weaves, regular_weaves, satin, twill
from weavecap.estimate.weave_name import equal_up_to_shift, weave_name


@pytest.mark.parametrize("shape, count", [((2, 2), 1), ((3, 3), 4), ((5, 5), 12), ((2, 6), 1), ((4, 11), 0), ((2, 3), 0)])
def test_every_named_weave_of_a_shape_once(shape, count):
    weaves = regular_weaves(shape)
    assert len(weaves) == count
    for i, p in enumerate(weaves):
        assert p.shape == shape and interlaces(p)
        assert not any(equal_up_to_shift(p, q) for q in weaves[i + 1:])


def test_the_library_holds_the_satins_and_twills_by_name():
    eight = regular_weaves((8, 8))
    for pattern in (satin(8, 3), 1 - satin(8, 5), twill(3, 5, step=-1), twill(6, 2)):
        assert any(equal_up_to_shift(pattern, p) for p in eight)
    names = {weave_name(p).split()[0] for p in eight}
    assert names == {"twill", "satin", "basket"}
    assert not any(np.array_equal(p, 1 - p) for p in eight)


def test_a_named_weave_is_recognised_at_any_phase_and_a_custom_one_is_not():
    from weavecap.fit.rounds import is_named_weave

    assert is_named_weave(np.roll(satin(8, 3), (2, 5), axis=(0, 1)))
    assert is_named_weave(1 - twill(2, 3, step=-1))
    custom = satin(5, 2)
    custom[0, 1] ^= 1  # one cell off a satin
    assert not is_named_weave(custom)
    assert not is_named_weave(np.array([[0, 1, 1], [1, 0, 0]], dtype=np.uint8))
    # what the report names is named here too: a tiled plain weave, an extended satin
    assert is_named_weave(np.tile(np.array([[1, 0], [0, 1]], dtype=np.uint8), (2, 2)))
    assert is_named_weave(np.array([np.roll([1, 1, 0, 0, 0], 3 * i) for i in range(5)], dtype=np.uint8))


@pytest.mark.parametrize("shape, names", [
    ((4, 8), {"herringbone 1/3, legs of 4 warps", "herringbone 2/2, legs of 4 warps", "herringbone 3/1, legs of 4 warps",
              "basket 2/4"}),
    ((2, 2), {"plain"}), ((2, 6), {"rib 3 (warps doubled)"})])
def test_the_named_library_adds_broken_twills_and_hopsacks(shape, names):
    weaves = named_weaves(shape)
    assert {weave_name(p) for p in weaves} == names
    for i, p in enumerate(weaves):
        assert p.shape == shape and interlaces(p)
        assert not any(equal_up_to_shift(p, q) for q in weaves[i + 1:])
    assert all(any(equal_up_to_shift(r, p) for p in weaves) for r in regular_weaves(shape))
