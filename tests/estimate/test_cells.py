"""Cell canvases, cell errors and windows (weavecap.estimate.cells)."""

import numpy as np
import pytest

from weavecap.estimate.cells import CellGrid, cell_canvas, cell_errors, wrap_window


def test_grid_rejects_bad_boundaries():
    with pytest.raises(ValueError, match="ascending"):
        CellGrid(rows=np.array([0.0, 5.0, 4.0]), cols=np.array([0.0, 1.0]))
    with pytest.raises(ValueError, match="at least two"):
        CellGrid(rows=np.array([0.0]), cols=np.array([0.0, 1.0]))


def test_canvas_of_a_regular_grid_at_its_own_scale_is_the_image():
    rng = np.random.default_rng(0)
    img = rng.random((40, 60, 3)).astype(np.float32)
    grid = CellGrid.regular((2, 3), 10, origin=(10, 20))
    canvas = cell_canvas(img, grid, 10)
    assert canvas.shape == (20, 30, 3)
    np.testing.assert_allclose(canvas, img[10:30, 20:50], atol=1e-6)


def test_canvas_evens_out_irregular_cells():
    """Cells of 8 and 16 px, each filled with its own value, become equal cells of 12 px."""
    img = np.zeros((24, 24, 3), np.float32)
    img[:, 8:] = 1.0
    grid = CellGrid(rows=np.array([0.0, 8.0, 24.0]), cols=np.array([0.0, 8.0, 24.0]))
    canvas = cell_canvas(img, grid, 12)[..., 0]
    means = canvas.reshape(2, 12, 2, 12)[:, 2:10, :, 2:10].mean(axis=(1, 3))
    np.testing.assert_allclose(means, [[0, 1], [0, 1]], atol=1e-6)


def test_colour_matched_error_ignores_gain_and_offset_but_not_structure():
    rng = np.random.default_rng(1)
    photo = rng.random((20, 20, 3))
    assert cell_errors(photo * 0.5 + 0.2, photo, (2, 2), match_colour=True).max() < 1e-12
    assert cell_errors(photo * 0.5 + 0.2, photo, (2, 2)).min() > 1e-3
    assert cell_errors(photo.transpose(1, 0, 2), photo, (2, 2), match_colour=True).min() > 1e-3


def test_wrap_window_tiles_the_repeat():
    pattern = np.array([[1, 0, 0], [0, 1, 1]])
    window = wrap_window(pattern, pattern.shape, 4)
    np.testing.assert_array_equal(window, np.tile(pattern, (2, 2))[:4, :4])
