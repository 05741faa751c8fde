"""``weavecap train-renderer`` end to end on a tiny case: data, weights, record, resume."""

from __future__ import annotations

import numpy as np
from click.testing import CliRunner

from weavecap.cli.main import cli
from weavecap.render.woven import infer


def test_train_renderer_tiny_run_resumes_and_refuses_other_settings(tmp_path):
    runner = CliRunner()
    work, out = tmp_path / "work", tmp_path / "weights"
    args = ["train-renderer", "--no-fold", "--work", str(work), "-o", str(out), "--fabrics", "2", "--steps", "3", "-q"]
    result = runner.invoke(cli, args)
    assert result.exit_code == 0, result.output
    arrays, record = infer.load_weights(out / "woven.npz")
    assert record["steps"] == 3 and record["materials"] == 4 and record["held_out_materials"] == 2
    assert np.isfinite(record["held_out_errors"]["all"]["rel_mae"])
    assert all(np.isfinite(a).all() for a in arrays.values())
    # a second run finds the data and the finished checkpoint: the same weights
    again = runner.invoke(cli, args + ["--force"])
    assert again.exit_code == 0, again.output
    arrays2, record2 = infer.load_weights(out / "woven.npz")
    assert all(np.array_equal(arrays[k], arrays2[k]) for k in arrays)
    assert record2["data_seconds"] == record["data_seconds"] > 0  # the shards' own seconds, made once
    # existing weights are not overwritten without --force; other settings are refused
    assert runner.invoke(cli, args).exit_code == 2
    other = runner.invoke(cli, args[:-3] + ["--steps", "5", "--force", "-q"])
    assert other.exit_code == 2 and "other settings" in other.output
