"""``weavecap prepare`` through click's CliRunner: outputs, schema, rejection, errors."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import jsonschema
import numpy as np
import pytest
from click.testing import CliRunner

from weavecap.cli.main import cli
from weavecap.photo import load_photo, save_png

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "prepare"))
from synthetic import render  # noqa: E402

SCHEMA = Path(__file__).resolve().parents[2] / "weavecap" / "schemas" / "report.schema.json"  # the contract's copy
OUTPUTS = ["rectified.png", "regularized.png", "grid.png", "prepare.json"]


def _run(*args):
    return CliRunner().invoke(cli, ["prepare", *map(str, args)], catch_exceptions=False)


@pytest.fixture(scope="module")
def weave_png(tmp_path_factory) -> Path:
    img, _ = render("twill_2_1", size=(256, 256), pitch_px=9, angle_deg=-10, noise=0.01, seed=4)
    path = tmp_path_factory.mktemp("photo") / "twill.png"
    save_png(path, img)
    return path


def test_writes_outputs_valid_against_the_report_schema(weave_png, tmp_path):
    res = _run(weave_png, "-o", tmp_path / "out")
    assert res.exit_code == 0, res.output
    for name in OUTPUTS:
        assert (tmp_path / "out" / name).stat().st_size > 0
    doc = json.loads((tmp_path / "out" / "prepare.json").read_text())
    assert doc["status"] == "ok"
    schema = json.loads(SCHEMA.read_text())
    for part in ("rectification", "grid"):
        jsonschema.validate(doc[part], schema["properties"][part])
    assert abs(doc["rectification"]["rotation_deg"] - (-10)) < 0.5  # fabric turned CW by 10° in the photo
    assert doc["grid"]["yarns"] == [3, 3]
    assert np.array(doc["rectification"]["homography"]).shape == (3, 3)
    assert len(doc["grid"]["pitch_px"]) == 2 and len(doc["grid"]["repeat_px"]) == 2
    assert "rectifying" in res.stderr


def test_a_given_pattern_sets_the_repeat_and_one_the_photo_cannot_hold_exits_2(weave_png, tmp_path):
    """The 3x3 twill given as a 3x6 pattern: grid.png and prepare.json show the 3x6 repeat,
    and say the photo's own; a 3x30 pattern is longer than the photo: exit 2, nothing written."""
    wide = tmp_path / "wide.txt"
    wide.write_text("1 1 0 1 1 0\n0 1 1 0 1 1\n1 0 1 1 0 1\n")
    res = _run(weave_png, "-o", tmp_path / "out", "--pattern", wide)
    assert res.exit_code == 0, res.output
    doc = json.loads((tmp_path / "out" / "prepare.json").read_text())
    assert doc["grid"]["yarns"] == [3, 6] and doc["checks"]["repeat_in_photo"] == [3, 3]
    assert "the photo showing 3 × 3" in res.stderr
    long = tmp_path / "long.txt"
    long.write_text(("1 1 0 " * 10 + "\n") + ("0 1 1 " * 10 + "\n") + ("1 0 1 " * 10 + "\n"))
    res = _run(weave_png, "-o", tmp_path / "long", "--pattern", long)
    assert res.exit_code == 2 and "repeats over 30 warps" in res.output
    assert not (tmp_path / "long").exists()


def test_json_prints_prepare_json_or_the_rejection(weave_png, tmp_path):
    """--json, as for every command: the record written (prepare.json) on standard output; a
    rejected photo's reason and checks, exit 3, the same record written beside diagnosis.png."""
    res = _run(weave_png, "-o", tmp_path / "out", "--json", "-q")
    assert res.exit_code == 0 and res.stderr == ""
    assert json.loads(res.stdout) == json.loads((tmp_path / "out" / "prepare.json").read_text())
    noise = tmp_path / "noise.png"
    save_png(noise, np.random.default_rng(0).uniform(0, 1, (200, 200, 3)).astype(np.float32))
    res = _run(noise, "-o", tmp_path / "rejected", "--json")
    doc = json.loads(res.stdout)
    assert res.exit_code == 3 and doc["status"] == "rejected" and doc["reason"] in res.stderr and doc["checks"]
    assert doc["input"]["path"] == str(noise)
    assert json.loads((tmp_path / "rejected" / "prepare.json").read_text()) == doc
    assert sorted(p.name for p in (tmp_path / "rejected").iterdir()) == ["diagnosis.png", "prepare.json"]


def test_quiet_prints_nothing(weave_png, tmp_path):
    res = _run(weave_png, "-o", tmp_path / "out", "-q")
    assert res.exit_code == 0 and res.output == ""


def test_refuses_to_overwrite_without_force(weave_png, tmp_path):
    assert _run(weave_png, "-o", tmp_path, "-q").exit_code == 0
    before = (tmp_path / "prepare.json").read_bytes()
    res = _run(weave_png, "-o", tmp_path, "-q")
    assert res.exit_code == 2 and "--force" in res.output
    assert (tmp_path / "prepare.json").read_bytes() == before
    assert _run(weave_png, "-o", tmp_path, "-q", "--force").exit_code == 0


def test_rejection_exits_3_with_a_diagnosis_in_place_of_the_old_set(tmp_path):
    noise = np.random.default_rng(0).uniform(0, 1, (200, 200, 3)).astype(np.float32)
    save_png(tmp_path / "noise.png", noise)
    out = tmp_path / "out"
    out.mkdir()
    (out / "prepare.json").write_text("{}")
    (out / "rectified.png").write_bytes(b"an earlier run's")
    res = _run(tmp_path / "noise.png", "-o", out, "--force")
    assert res.exit_code == 3
    assert "rejected" in res.output and "noise.png" in res.output and "Traceback" not in res.output
    assert "diagnosis.png" in res.output
    record = json.loads((out / "prepare.json").read_text())
    assert record["status"] == "rejected" and record["reason"] and record["code"] in ("no_grid", "no_texture")
    assert load_photo(out / "diagnosis.png").width >= 900  # the photo, its spectrum, the projections
    assert not (out / "rectified.png").exists()  # the earlier set is gone, not mixed with this one


def test_missing_and_unreadable_photos(tmp_path):
    res = _run(tmp_path / "nope.jpg", "-o", tmp_path / "o")  # a missing file is a usage error, as for fit
    assert res.exit_code == 2 and "nope.jpg: no such photo" in res.output and "Traceback" not in res.output
    bad = tmp_path / "bad.jpg"
    bad.write_bytes(b"not a jpeg at all")
    res = _run(bad, "-o", tmp_path / "o")
    assert res.exit_code == 3 and "bad.jpg" in res.output


def test_output_that_is_a_file_is_a_usage_error(weave_png, tmp_path):
    f = tmp_path / "file"
    f.write_text("x")
    res = _run(weave_png, "-o", f)
    assert res.exit_code == 2 and "is a file" in res.output


def test_help_has_examples():
    res = CliRunner().invoke(cli, ["prepare", "--help"])
    assert res.exit_code == 0 and "Examples" in res.output and "weavecap prepare" in res.output
