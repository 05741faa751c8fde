"""Pattern pre-estimation (§5.1) on synthetic photos with a known pattern."""

import numpy as np
from estimate_data import photo_of

from weavecap.estimate.cells import cell_canvas
from weavecap.estimate.forward import RepeatRenderer
from weavecap.estimate.pattern import anneal_pattern, estimate_pattern, twill_start
from weavecap.estimate.preestimate import default_fabric
from weavecap.estimate.weave_name import equal_up_to_shift


CELL = 12


def test_twill_start_fills_any_shape():
    start = twill_start((4, 7))
    assert start.shape == (4, 7) and set(np.unique(start)) == {0, 1}


def test_known_parameters_find_the_pattern_from_twill(custom_fabric):
    """With the photo's own parameters, batched T = 0 annealing finds the 10×5 pattern (one no
    training family makes) from a twill start, in far fewer renders than one per cell."""
    photo, grid, shift = photo_of(custom_fabric, cell_px=CELL)
    canvas = cell_canvas(photo, grid, CELL)
    rr = RepeatRenderer(custom_fabric.replace({"pattern": twill_start(custom_fabric.shape)}), cell_px=CELL)
    result = anneal_pattern(canvas, rr)
    np.testing.assert_array_equal(result.pattern, np.roll(custom_fabric.pattern, shift, axis=(0, 1)))
    assert result.renders < custom_fabric.pattern.size
    assert np.all(result.margin > 0)  # every cell prefers its state to being flipped alone


def test_default_parameters_find_pattern_and_radii(twill_fabric):
    """From defaults (grey, Table 1 middles), the pattern comes out exact up to a shift and the
    radii close to the truth."""
    fabric = twill_fabric.replace({"warp.radius": 2.0, "weft.radius": 4.0})
    photo, grid, _ = photo_of(fabric, cell_px=CELL)
    rr = RepeatRenderer(default_fabric(twill_start(fabric.shape)), cell_px=CELL)
    result, rounds = estimate_pattern(cell_canvas(photo, grid, CELL), rr, start=np.ones(fabric.shape, np.uint8))
    assert equal_up_to_shift(result.pattern, fabric.pattern)
    assert abs(rr.fabric.warp.radius - 2.0) <= 0.5 and abs(rr.fabric.weft.radius - 4.0) <= 0.5
    assert 2 <= rounds <= 3
