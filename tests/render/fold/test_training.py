"""BLIDF training: data made by LocalPT, resumable and seeded; the CLI that runs it."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from weavecap.render.fold import blidf as B
from weavecap.training import fold as T


TINY = T.TrainConfig(pool=40, lights=4, per_light=12, block=2, hat_points=2, paths=4, neighbours=8, epochs=2,
                     batch=64, fabrics=("plain",))


def tiny_meshes():
    from weavecap.render.shapes import sine_folds

    return [T.FoldMesh("tiny_sine", sine_folds(amplitude=0.012, width=0.1, height=0.05, rows=11, name="tiny_sine"))]


def test_data_are_seeded_resumable_and_train_into_loadable_weights(tmp_path):
    meshes = tiny_meshes()
    first = tmp_path / "a"
    T.generate_data(first, meshes, TINY)
    shards = sorted((first / "data").glob("*.npz"))
    assert len(shards) == TINY.blocks == 2
    a = np.load(shards[0])
    assert a["target"].shape == (2 * 2 * TINY.per_light, 3) and np.all(np.isfinite(a["target"]))
    assert np.all(a["target"] >= 0) and np.all((a["vbar"] >= 0) & (a["vbar"] <= 1))
    # the same seed makes the same data; a shard that exists is not made again
    second = tmp_path / "b"
    T.generate_data(second, meshes, TINY)
    b = np.load(sorted((second / "data").glob("*.npz"))[0])
    for key in ("features", "target", "vbar", "vertex"):
        np.testing.assert_array_equal(a[key], b[key])
    stamp = shards[0].stat().st_mtime_ns
    T.generate_data(first, meshes, TINY)
    assert shards[0].stat().st_mtime_ns == stamp
    net, seconds, errors = T.train(first, meshes, TINY)
    assert (first / "checkpoint.pt").is_file() and seconds > 0
    model = T.write_weights(tmp_path / "w.json", net, meshes, TINY, data_seconds=1.0, train_seconds=seconds,
                            errors=errors, radii=T.mesh_radii(first, meshes, TINY))
    again = B.BLIDF.load(tmp_path / "w.json")
    assert again.parameters == model.parameters == 1500
    assert again.record["config"]["lights"] == 4 and again.record["meshes"][0]["name"] == "tiny_sine"
    # resuming after the last epoch trains no more and gives the same network
    net2, _, errors2 = T.train(first, meshes, TINY)
    assert errors2 == errors


def test_every_row_gets_the_shares_and_albedo_of_its_vertexs_other_side():
    # two lights of three vertices: rows are light by light, side 0 then side 1 of the same vertices
    vertex = np.array([4, 7, 9, 4, 7, 9, 1, 2, 3, 1, 2, 3])
    side = np.array([0, 0, 0, 1, 1, 1, 0, 0, 0, 1, 1, 1])
    vbar = np.arange(24, dtype=float).reshape(12, 2)
    albedo = np.tile([[0.5, 0.4, 0.3]], (12, 1))
    albedo[[1, 9]] = 0.0  # these rows' sides found no neighbourhood
    out = T.both_sides({"vertex": vertex, "side": side, "vbar": vbar, "albedo": albedo})
    other = np.array([3, 4, 5, 0, 1, 2, 9, 10, 11, 6, 7, 8])
    np.testing.assert_array_equal(out["vbar"], np.concatenate([vbar, vbar[other]], axis=1))
    np.testing.assert_array_equal(out["albedo"][1], albedo[4])  # a crest: the valley behind it
    np.testing.assert_array_equal(out["albedo"][9], albedo[6])
    np.testing.assert_array_equal(out["albedo"][[0, 2, 3, 10]], albedo[[0, 2, 3, 10]])
    shuffled = vertex.copy()
    shuffled[[3, 4]] = shuffled[[4, 3]]  # side 1's rows of the first light in another order
    with pytest.raises(ValueError, match="side 0 and side 1"):
        T.both_sides({"vertex": shuffled, "side": side, "vbar": vbar, "albedo": albedo})


def test_too_few_lights_to_hold_one_block_out_are_refused():
    with pytest.raises(ValueError, match="at least two"):
        T.TrainConfig(lights=4, block=8)


def test_train_renderer_command(tmp_path):
    from weavecap.cli.main import cli

    runner = CliRunner()
    result = runner.invoke(cli, ["train-renderer", "--no-woven", "--no-fold"])
    assert result.exit_code == 2 and "nothing to train" in result.output
    target = tmp_path / "out" / B.WEIGHTS_FILE
    target.parent.mkdir()
    target.write_text("{}")
    result = runner.invoke(cli, ["train-renderer", "-o", str(target.parent), "--work", str(tmp_path / "w")])
    assert result.exit_code == 2 and "--force" in result.output  # nothing overwritten without --force,
    assert json.loads(target.read_text()) == {} and not (tmp_path / "w").exists()  # checked before any work
