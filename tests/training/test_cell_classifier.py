"""Training data and training of the cell classifier: the generator's weaves and labels, shards,
a tiny run end to end. The shipped weights' accuracy is asserted in tests/estimate."""

from __future__ import annotations

import numpy as np
import pytest

from weavecap.estimate.cell_classifier import CELL_PX, load_classifier
from weavecap.estimate.cell_photos import WEAVE_KINDS, cell_sample, random_weave
from weavecap.estimate.sampling import interlaces
from weavecap.estimate.weave_name import weave_family, weave_name
from weavecap.training.cell_classifier import CellTrainConfig, fit_temperature, make_shard, run


def test_every_weave_kind_is_drawn_and_interlaces():
    rng = np.random.default_rng(0)
    families = {}
    for kind in WEAVE_KINDS:
        for _ in range(6):
            p = random_weave(rng, kind)
            assert interlaces(p) and max(p.shape) <= 24
            families.setdefault(kind, set()).add(weave_family(weave_name(p)))
    assert families["plain"] == {"plain"} and families["satin"] == {"satin"}
    assert families["herringbone"] <= {"twill"} and families["point_twill"] <= {"twill"}


def test_labels_are_the_states_on_the_crossings_and_mixed_half_a_cell_off():
    rng = np.random.default_rng(4)
    weave = np.array([[1, 0], [0, 1]], np.uint8)
    sure = mixed = 0
    for _ in range(30):
        canvas, labels = cell_sample(rng, cells=(6, 6), weave=weave)
        assert canvas.shape == (6 * CELL_PX, 6 * CELL_PX, 3) and 0 <= canvas.min() and canvas.max() <= 1
        if np.all((labels == 0) | (labels == 1)):
            sure += 1
            # a plain weave: the states alternate from cell to cell
            assert np.all(labels[:, 1:] != labels[:, :-1]) and np.all(labels[1:] != labels[:-1])
        else:  # half a cell off: a plain weave's cells then cover both states
            mixed += 1
            assert np.mean((labels > 0) & (labels < 1)) > 0.5
    assert sure > mixed > 0


def test_shards_are_deterministic():
    config = CellTrainConfig(seed=2, images=8, shard_images=4, heldout_shards=1, cells=6, forward_share=0.25,
                             per_geometry=1)
    a, b = make_shard(config, 1), make_shard(config, 1)
    np.testing.assert_array_equal(a["image"], b["image"])
    np.testing.assert_array_equal(a["labels"], b["labels"])
    assert a["image"].dtype == np.uint8 and a["image"].shape == (4, 6 * CELL_PX, 6 * CELL_PX, 3)
    assert sum(k.startswith("forward:") for k in a["kind"]) == 1


def test_temperature_is_the_scale_that_calibrates():
    rng = np.random.default_rng(1)
    z = rng.normal(0, 3, 20000)
    labels = (rng.random(z.size) < 1 / (1 + np.exp(-z / 2.5))).astype(float)
    assert fit_temperature(z, labels) == pytest.approx(2.5, rel=0.08)


def test_a_tiny_run_writes_weights_that_load_with_their_record(tmp_path):
    config = CellTrainConfig(seed=1, images=12, shard_images=4, heldout_shards=1, cells=6, epochs=1,
                             forward_share=0.0)
    record = run(tmp_path / "work", tmp_path / "out", config)
    assert record["heldout"]["images"] == 4 and record["temperature"] > 0
    loaded = load_classifier(tmp_path / "out")
    assert loaded is not None and loaded.record["parameters"] == record["parameters"]
    canvas, labels = cell_sample(np.random.default_rng(0), cells=(5, 7))
    assert loaded.logits(canvas, labels.shape).shape == (5, 7)
    # the data are made once: a second run makes no shard
    messages = []
    run(tmp_path / "work", tmp_path / "out", config, progress=messages.append)
    assert not any(m.startswith("data:") for m in messages)
