"""Training data for the initializer (§5.3): tiny shards, determinism, resumable layout.
No training here: the tests use the shipped weights."""

import numpy as np
import pytest
from click.testing import CliRunner

from weavecap.estimate.initializer import INPUT_PX, N_OUTPUTS, range_arrays
from weavecap.estimate.sampling import FAMILIES, interlaces, random_fabric, random_pattern
from weavecap.training.initializer import TrainConfig, generate_data, make_shard
from weavecap.params import FIT_RANGES


def test_random_fabrics_cover_table1_and_every_family():
    rng = np.random.default_rng(0)
    seen = set()
    for _ in range(60):
        family, pattern = random_pattern(rng)
        seen.add(family)
        assert interlaces(pattern)
        fabric = random_fabric(rng, pattern)
        for key, (lo, hi) in FIT_RANGES.items():
            assert np.all((lo <= np.atleast_1d(fabric.get(key))) & (np.atleast_1d(fabric.get(key)) <= hi)), key
    assert seen == set(FAMILIES)


def test_shards_are_deterministic_and_well_formed():
    config = TrainConfig(seed=3, geometries=4, per_geometry=2, shard_geometries=2, heldout_shards=1)
    a, b = make_shard(config, 1), make_shard(config, 1)
    assert a["x"].shape == (4, 4, INPUT_PX, INPUT_PX) and a["y"].shape == (4, N_OUTPUTS)
    np.testing.assert_array_equal(a["x"], b["x"])
    np.testing.assert_array_equal(a["y"], b["y"])
    lo, hi = range_arrays()
    assert np.all(a["y"] >= lo) and np.all(a["y"] <= hi)
    assert not np.array_equal(make_shard(config, 0)["y"], a["y"])


def test_data_generation_resumes_from_existing_shards(tmp_path):
    config = TrainConfig(seed=1, geometries=2, per_geometry=1, shard_geometries=1, heldout_shards=1)
    messages = []
    first = generate_data(tmp_path, config, progress=messages.append)
    assert len(messages) == 2 and first > 0
    again = generate_data(tmp_path, config, progress=messages.append)
    assert len(messages) == 2 and again == pytest.approx(first)  # nothing rendered twice


def test_config_needs_a_held_out_shard():
    with pytest.raises(ValueError, match="too few"):
        TrainConfig(geometries=10, shard_geometries=50)


def test_command_refuses_to_overwrite_weights_or_mix_runs(tmp_path):
    from weavecap.cli.main import cli

    out = tmp_path / "weights"
    out.mkdir()
    (out / "initializer.pt").write_bytes(b"x")
    result = CliRunner().invoke(cli, ["train-initializer", "--work", str(tmp_path / "w"), "-o", str(out)])
    assert result.exit_code == 2 and "--force" in result.output
    work = tmp_path / "w2"
    work.mkdir()
    (work / "config.json").write_text('{"seed": 99}')
    result = CliRunner().invoke(cli, ["train-initializer", "--work", str(work), "-o", str(tmp_path / "o")])
    assert result.exit_code == 2 and "other settings" in result.output
