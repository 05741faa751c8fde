"""Colour pre-estimation (§5.2) and CIELAB differences."""

import numpy as np
import pytest
from estimate_data import photo_of

from weavecap.estimate.cells import cell_canvas
from weavecap.estimate.colour import delta_e, estimate_colours, linear_to_lab



def test_lab_of_known_colours():
    np.testing.assert_allclose(linear_to_lab([1.0, 1.0, 1.0]), [100, 0, 0], atol=0.01)
    np.testing.assert_allclose(linear_to_lab([0.0, 0.0, 0.0]), [0, 0, 0], atol=1e-9)
    np.testing.assert_allclose(linear_to_lab([0.2140, 0.2140, 0.2140])[0], 53.4, atol=0.1)  # sRGB 128 grey
    assert delta_e([0.2, 0.3, 0.4], [0.2, 0.3, 0.4]) == 0.0
    assert delta_e([1.0, 0.0, 0.0], [0.0, 1.0, 0.0]) > 100


@pytest.mark.parametrize("which", ["twill", "custom"])
def test_colours_of_a_known_fabric(which, twill_fabric, custom_fabric):
    """Given the pattern and the other parameters, warp and weft colours come back within
    ΔE 5 of the truth and the specular colour is seen."""
    fabric = twill_fabric if which == "twill" else custom_fabric
    photo, grid, shift = photo_of(fabric, cell_px=16)
    aligned = fabric.replace({"pattern": np.roll(fabric.pattern, shift, axis=(0, 1)),
                              "warp.body_reflection": (0.9, 0.9, 0.9), "weft.body_reflection": (0.1, 0.1, 0.1)})
    colours = estimate_colours(cell_canvas(photo, grid, 16), aligned, cell_px=16)
    assert delta_e(colours.warp, fabric.warp.body_reflection) <= 5.0
    assert delta_e(colours.weft, fabric.weft.body_reflection) <= 5.0
    assert colours.specular_visible
    assert delta_e(colours.specular, fabric.specular.reflection) <= 10.0
    assert colours.values()["warp.body_subsurface"] == colours.warp
