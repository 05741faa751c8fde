"""The parameter initializer (§5.3): shipped weights, ranges, speed, defaults, training data."""

import json

import numpy as np
import pytest

from weavecap.estimate.initializer import (CELL_PX, INPUT_PX, N_OUTPUTS, OUTPUT_KEYS, RECORD_FILE, WEIGHTS_FILE,
                                           build_network, default_values, from_vector, input_windows,
                                           load_predictor, range_arrays, to_vector, weights_dir)
from weavecap.params import FIT_RANGES


@pytest.fixture(scope="module")
def predictor():
    p = load_predictor()
    assert p is not None, f"no shipped weights in {weights_dir()}; run `weavecap train-initializer`"
    return p


def test_shipped_weights_are_small_plain_data_with_a_record():
    folder = weights_dir()
    assert (folder / WEIGHTS_FILE).stat().st_size <= 20 * 2 ** 20
    import torch

    state = torch.load(folder / WEIGHTS_FILE, weights_only=True)  # no pickle of code
    assert all(isinstance(v, torch.Tensor) for v in state.values())
    record = json.loads((folder / RECORD_FILE).read_text())
    assert record["outputs"] == list(OUTPUT_KEYS)
    assert record["counts"]["images"] >= 2000
    assert {"data", "train"} <= set(record["seconds"])
    assert set(record["heldout_errors"]) == set(OUTPUT_KEYS)


def test_vector_layout_round_trips():
    values = default_values()
    for key, (lo, hi) in FIT_RANGES.items():
        v = np.atleast_1d(values[key])
        assert np.all((lo <= v) & (v <= hi))
    assert from_vector(to_vector(values)) == values
    lo, hi = range_arrays()
    assert lo.shape == hi.shape == (N_OUTPUTS,)


def test_outputs_stay_in_table1_ranges_whatever_the_input():
    net = build_network().eval()
    import torch

    with torch.no_grad():
        out = net(torch.randn(4, 4, INPUT_PX, INPUT_PX) * 100).numpy()
    lo, hi = range_arrays()
    assert np.all(out >= lo) and np.all(out <= hi)


def test_inference_is_in_range(predictor, twill_fabric):
    from estimate_data import photo_of

    from weavecap.estimate.cells import cell_canvas

    photo, grid, shift = photo_of(twill_fabric, cell_px=CELL_PX)
    canvas = cell_canvas(photo, grid, CELL_PX)
    pattern = np.roll(twill_fabric.pattern, shift, axis=(0, 1))
    assert input_windows(canvas, pattern).shape[1:] == (4, INPUT_PX, INPUT_PX)
    values = predictor.predict(canvas, pattern)
    for key in OUTPUT_KEYS:
        lo, hi = FIT_RANGES[key]
        assert np.all((lo <= np.atleast_1d(values[key])) & (np.atleast_1d(values[key]) <= hi))
    # what a photo shows plainly: the radii, and which yarn is the lighter one
    assert abs(values["warp.radius"] - twill_fabric.warp.radius) < 1.2
    assert abs(values["weft.radius"] - twill_fabric.weft.radius) < 1.2
    assert np.mean(values["weft.body_reflection"]) > np.mean(values["warp.body_reflection"])


def test_missing_or_mismatched_weights_mean_defaults(tmp_path):
    assert load_predictor(tmp_path) is None
    (tmp_path / WEIGHTS_FILE).write_bytes(b"")
    (tmp_path / RECORD_FILE).write_text(json.dumps({"outputs": ["plies"]}))
    assert load_predictor(tmp_path) is None
