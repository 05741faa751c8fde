"""``weavecap fit`` as a user runs it: outputs, batches with a bad photo, resuming, --force."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import jsonschema
import numpy as np
import pytest
from click.testing import CliRunner

from weavecap.cli.main import cli

ROOT = Path(__file__).resolve().parents[2]
PHOTOS = ROOT / "fixtures" / "photos"
SCHEMAS = ROOT / "weavecap" / "schemas"


def run(*args):
    return CliRunner().invoke(cli, ["fit", *map(str, args)], catch_exceptions=False)


@pytest.fixture(scope="module")
def batch(tmp_path_factory):
    """Three photos, the middle one corrupt, fitted at draft quality."""
    folder = tmp_path_factory.mktemp("batch")
    photos = [folder / "a_twill.png", folder / "b_corrupt.png", folder / "c_plain.png"]
    shutil.copy(PHOTOS / "twill_2_1.png", photos[0])
    photos[1].write_bytes((PHOTOS / "plain.png").read_bytes()[:3000])  # truncated PNG
    shutil.copy(PHOTOS / "plain.png", photos[2])
    out = folder / "out"
    result = run(*photos, "-o", out, "--quality", "draft", "--seed", "1", "-v")
    return photos, out, result


def test_batch_with_a_corrupt_photo_gives_two_results_three_lines_and_exit_3(batch):
    photos, out, result = batch
    assert result.exit_code == 3, result.output
    lines = [json.loads(line) for line in (out / "summary.jsonl").read_text().splitlines()]
    assert [line["photo"] for line in lines] == [str(p) for p in photos]
    assert [line["status"] for line in lines] == ["ok", "rejected", "ok"]
    assert "b_corrupt.png" in lines[1]["reason"]
    for line, name in ((lines[0], "a_twill"), (lines[2], "c_plain")):  # how faithful, at a glance
        fit = json.loads((out / name / "report.json").read_text())["fit"]
        assert line["light"] == fit["light"]["rig"] and line["sharpness"] == fit["fidelity"]["sharpness"]
        assert line["delta_e"] == fit["fidelity"]["delta_e"] and set(line["delta_e"]) == {"warp", "weft"}
        assert line["clipped"] == fit["fidelity"]["clipped"] and set(line["clipped"]) == {"warp", "weft"}
        # the fabric's own colours, away from the fitted light (the photos' light is neutral)
        assert line["neutral_delta_e"] == fit["fidelity"]["neutral_delta_e"]
        assert max(line["neutral_delta_e"].values()) < 2, line["neutral_delta_e"]  # measured 0.6
    for name in ("a_twill", "c_plain"):
        for file in ("params.json", "report.json", "compare.png", "rectified.png", "grid.png", "loss.png"):
            assert (out / name / file).is_file(), (name, file)
    assert not (out / "b_corrupt" / "params.json").exists()
    assert "Traceback" not in result.output
    assert "a_twill.png: twill" in result.output and "sharpness" in result.output and " light, " in result.output
    for stage in ("loading", "preparing", "deciding the pattern", "pre-estimating", "fitting (draft",
                  "measuring how well"):  # a line for every stage of a photo's capture (-v)
        assert f"c_plain.png: {stage}" in result.output, stage


def _follow(out: Path, schemas: Path) -> None:
    report_schema = json.loads((schemas / "report.schema.json").read_text())
    params_schema = json.loads((schemas / "params.schema.json").read_text())
    for name in ("a_twill", "c_plain"):
        report = json.loads((out / name / "report.json").read_text())
        jsonschema.validate(report, report_schema)
        jsonschema.validate(json.loads((out / name / "params.json").read_text()), params_schema)
        assert report["status"] == "ok" and report["timings_s"]["total"] > 0
    rejected = json.loads((out / "b_corrupt" / "report.json").read_text())
    jsonschema.validate(rejected, report_schema)
    assert rejected["status"] == "rejected"


def test_reports_and_params_follow_the_schemas(batch):
    _follow(batch[1], SCHEMAS)


def test_reports_and_params_follow_the_shared_contracts(batch, shared):
    _follow(batch[1], shared("contracts"))


def test_the_fit_finds_the_plain_weave(batch):
    _, out, _ = batch
    report = json.loads((out / "c_plain" / "report.json").read_text())
    assert report["grid"]["yarns"] == [2, 2]
    assert report["weave"] == "plain"
    assert report["fit"]["psnr_db"] > 20


def test_running_again_resumes_without_redoing_finished_photos(batch):
    """Finished photos — fitted or rejected — are skipped; the exit status still reports them."""
    photos, out, _ = batch
    before = {n: (out / n / "report.json").stat().st_mtime_ns for n in ("a_twill", "b_corrupt", "c_plain")}
    result = run(*photos, "-o", out, "--quality", "draft", "--seed", "1")
    assert result.exit_code == 3
    assert "already done" in result.output
    assert {n: (out / n / "report.json").stat().st_mtime_ns for n in before} == before
    lines = [json.loads(line) for line in (out / "summary.jsonl").read_text().splitlines()]
    assert [line["photo"] for line in lines] == [str(p) for p in photos]  # none listed twice


def test_results_are_not_overwritten_without_force(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "params.json").write_text("precious")
    result = run(PHOTOS / "plain.png", "-o", out, "--quality", "draft")
    assert result.exit_code == 2
    assert "--force" in result.output
    assert (out / "params.json").read_text() == "precious"


@pytest.mark.parametrize("args, message", [
    (["missing.jpg"], "no such photo"),
    ([str(PHOTOS / "plain.png"), "--pattern", "nope.txt"], "cannot read the pattern file"),
    ([str(PHOTOS / "plain.png"), "--quality", "ultra"], "ultra"),
])
def test_bad_arguments_exit_2_naming_the_problem(tmp_path, args, message):
    result = run(*args, "-o", tmp_path / "out")
    assert result.exit_code == 2
    assert message in result.output
    assert not (tmp_path / "out").exists()


def test_a_bad_pattern_file_names_the_fix(tmp_path):
    pattern = tmp_path / "p.txt"
    pattern.write_text("1 0\n0 2\n")
    result = run(PHOTOS / "plain.png", "--pattern", pattern, "-o", tmp_path / "out")
    assert result.exit_code == 2
    assert "0 and 1" in result.output


def test_the_fits_line_says_when_the_camera_clipped_a_familys_colour():
    """From 5% of a family's cell centres clipped (``fit.fidelity.clipped``), the line names the
    family and what to do; under it, or where no figure was taken, nothing."""
    from weavecap.cli.lines import clipping_note

    def record(clipped):
        return {"fit": {"fidelity": {"clipped": clipped}}}

    note = clipping_note(record({"warp": 0.0, "weft": 0.156}))
    assert "16% of the weft yarns' centres" in note and "shoot a stop darker" in note
    assert clipping_note(record({"warp": 0.049, "weft": 0.0})) == ""
    assert clipping_note(record({"warp": None, "weft": 0.0})) == "" and clipping_note({"fit": {"fidelity": {}}}) == ""


def test_the_fits_line_says_when_the_fabric_lacks_the_photos_colour_under_a_neutral_light():
    """Beyond a faithful capture's ΔE 10 (``fit.fidelity.neutral_delta_e``) the line names the
    family, how far and the light's gain; within it, or where no figure was taken, nothing."""
    from weavecap.cli.lines import colour_note

    def record(neutral, gain=(7.74, 2.04, 0.73)):
        return {"fit": {"fidelity": {"neutral_delta_e": neutral}, "light": {"gain": list(gain)}}}

    note = colour_note(record({"warp": 24.6, "weft": 26.9}))
    assert "weft yarns are ΔE 26.9 off" in note and "gain 7.74/2.04/0.73" in note
    grey = colour_note(record({"warp": 16.4, "weft": 17.5}, gain=(4.54, 4.54, 4.54)))
    assert "weft yarns are ΔE 17.5 off" in grey and "gain" not in grey  # not the light's doing
    assert colour_note(record({"warp": 10.0, "weft": 2.0})) == ""
    assert colour_note(record({"warp": None, "weft": None})) == "" and colour_note({"fit": {"fidelity": {}}}) == ""


def test_the_fits_line_says_when_the_photos_cells_did_not_settle_the_weave():
    """An undecided pattern decision (``pre_estimation.decision.decided`` false) gives a line with
    its evidence, the weave it spoke for and what to do; a sure one, none, or none made, nothing."""
    from weavecap.cli.lines import weave_note

    def record(decided, evidence=0.034):
        return {"weave": "twill 7/1 Z", "pre_estimation": {"decision": {
            "weave": "satin 8/3 warp-faced", "evidence_nats_per_cell": evidence, "decided": decided}}}

    note = weave_note(record(False))
    assert "0.03 nats a cell for satin 8/3 warp-faced; 0.4 would decide it" in note
    assert "twill 7/1 Z is the fit's best guess" in note and "--pattern" in note
    assert weave_note(record(True, 0.9)) == ""
    assert weave_note({"weave": "plain", "pre_estimation": {}}) == "" and weave_note({"weave": "plain"}) == ""


def _pattern_file(path: Path, pattern: np.ndarray) -> Path:
    path.write_text("\n".join(" ".join(map(str, row)) for row in pattern) + "\n")
    return path


def test_a_given_pattern_sets_the_repeat_the_photo_shows_shorter(tmp_path):
    """The user's pattern is the fabric's repeat, though the photo shows a shorter one: the
    twill 3/1 fixture given as the twill tiled twice along the warps is fitted on a 4×8 repeat
    (measured 30.8 dB and sharpness 0.92; 31.9 dB given its own 4×4); a pattern longer than
    the photo is refused (exit 2, nothing written), saying so."""
    twill = np.array(json.loads((ROOT / "fixtures" / "params" / "twill_3_1.json").read_text())["pattern"])
    wide = _pattern_file(tmp_path / "wide.txt", np.tile(twill, (1, 2)))
    out = tmp_path / "wide"
    result = run(PHOTOS / "twill_3_1.png", "--pattern", wide, "-o", out, "--quality", "draft")
    assert result.exit_code == 0, result.output
    report = json.loads((out / "report.json").read_text())
    assert report["grid"]["yarns"] == [4, 8] and report["grid"]["repeat_in_photo"] == [4, 4]
    assert report["grid"]["repeat_given"] and report["weave"] == "twill 3/1 S"
    assert np.array_equal(json.loads((out / "params.json").read_text())["pattern"], np.tile(twill, (1, 2)))
    assert report["fit"]["psnr_db"] > 29.5 and report["fit"]["fidelity"]["sharpness"] > 0.85

    tall = _pattern_file(tmp_path / "tall.txt", np.tile(twill, (10, 1)))
    result = run(PHOTOS / "twill_3_1.png", "--pattern", tall, "-o", tmp_path / "tall", "--quality", "draft")
    assert result.exit_code == 2 and "Traceback" not in result.output
    assert "repeats over 40 wefts" in result.output and "pattern" in result.output
    assert not (tmp_path / "tall").exists()


def test_an_interrupted_batch_resumes_where_it_stopped(batch, tmp_path, monkeypatch):
    """Ctrl-C during the third photo; the next run does only what is left, listing each once."""
    from weavecap.pipeline import FitJob

    photos, out, _ = batch
    work = tmp_path / "out"
    shutil.copytree(out / "a_twill", work / "a_twill")  # finished before the interruption
    bad = [tmp_path / "b_corrupt.png", tmp_path / "c_corrupt.png"]
    for p in bad:
        p.write_bytes(b"not an image")
    todo = [photos[0], *bad]
    real = FitJob.run

    def interrupted(self, photo, *args):
        if photo.endswith("c_corrupt.png"):
            raise KeyboardInterrupt
        return real(self, photo, *args)

    monkeypatch.setattr(FitJob, "run", interrupted)
    result = run(*todo, "-o", work, "--quality", "draft")
    assert result.exit_code == 130 and "interrupted" in result.output
    assert [json.loads(x)["photo"] for x in (work / "summary.jsonl").read_text().splitlines()] == \
        [str(p) for p in todo[:2]]
    monkeypatch.setattr(FitJob, "run", real)
    result = run(*todo, "-o", work, "--quality", "draft")
    assert result.exit_code == 3
    assert [json.loads(x)["photo"] for x in (work / "summary.jsonl").read_text().splitlines()] == \
        [str(p) for p in todo]
    assert json.loads((work / "c_corrupt" / "report.json").read_text())["status"] == "rejected"


def test_a_photo_preparation_refuses_gets_its_diagnosis_picture(tmp_path):
    """A rejected photo's folder holds report.json (why) and diagnosis.png (what the grid search
    saw: the photo, its spectrum, the projections, the reason), no params.json."""
    from weavecap.photo import load_photo, save_png

    save_png(tmp_path / "noise.png", np.random.default_rng(0).uniform(0, 1, (200, 200, 3)).astype(np.float32))
    result = run(tmp_path / "noise.png", "-o", tmp_path / "out", "--quality", "draft")
    assert result.exit_code == 3 and "Traceback" not in result.output
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    assert report["status"] == "rejected" and report["reason"]
    assert load_photo(tmp_path / "out" / "diagnosis.png").width >= 900
    assert not (tmp_path / "out" / "params.json").exists()
