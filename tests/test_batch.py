"""weavecap.batch through `weavecap fit`: one outcome per photo, as the table says, and resuming
past failures (tests/test_fit_cli.py covers results, rejected photos and interruptions)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from click.testing import CliRunner

from weavecap import batch
from weavecap.cli.main import cli
from weavecap.pipeline import FitJob

PHOTOS = Path(__file__).resolve().parents[1] / "fixtures" / "photos"


def run(*args):
    return CliRunner().invoke(cli, ["fit", *map(str, args)], catch_exceptions=False)


def lines(out: Path) -> list[dict]:
    return [json.loads(line) for line in (out / "summary.jsonl").read_text().splitlines()]


def test_folders_are_named_after_the_inputs_and_repeated_stems_numbered(tmp_path):
    sources = [Path("a/x.png"), Path("b/x.png"), Path("y.jpg"), Path("c/x.tif")]
    assert batch.folders(sources, tmp_path) == [tmp_path / "x", tmp_path / "x-2", tmp_path / "y", tmp_path / "x-3"]
    assert batch.folders(sources[:1], tmp_path) == [tmp_path]


def test_a_pattern_that_does_not_fit_one_photo_is_invalid_there_exit_2_and_writes_nothing(tmp_path):
    """--pattern 2x2 on a plain (2x2) and a 2/1 twill (3x3): the plain is fitted with it, the
    twill's line says invalid (exit 2, as a single photo would) and its folder stays empty."""
    pattern = tmp_path / "plain.txt"
    pattern.write_text("1 0\n0 1\n")
    photos = [tmp_path / "plain.png", tmp_path / "twill.png"]
    shutil.copy(PHOTOS / "plain.png", photos[0])
    shutil.copy(PHOTOS / "twill_2_1.png", photos[1])
    out = tmp_path / "out"
    result = run(*photos, "-o", out, "--pattern", pattern, "--quality", "draft", "-q")
    assert result.exit_code == 2, result.output
    summary = lines(out)
    assert [(s["status"], s["exit"]) for s in summary] == [("ok", 0), ("invalid", 2)]
    assert "3 wefts x 3 warps" in summary[1]["reason"] and "twill.png: invalid" in result.output  # shown even with -q
    assert (out / "plain" / "params.json").is_file() and not (out / "twill").exists()

    again = run(*photos, "-o", out, "--pattern", pattern, "--quality", "draft")
    assert again.exit_code == 2 and "already done (ok)" in again.output
    assert [(s["photo"], s["status"]) for s in lines(out)] == [(str(photos[0]), "ok"), (str(photos[1]), "invalid")]

    single = run(photos[1], "-o", tmp_path / "one", "--pattern", pattern, "--quality", "draft")
    assert single.exit_code == 2 and "3 wefts x 3 warps" in single.output
    assert not (tmp_path / "one").exists()


def test_a_failed_photo_is_retried_on_resume_and_keeps_one_summary_line(tmp_path, monkeypatch):
    """An unexpected error writes a failed report naming the photo; running again tries it
    again (instead of refusing the folder) and replaces its summary line."""
    photos = [tmp_path / "a.png", tmp_path / "b.png"]
    for p in photos:
        shutil.copy(PHOTOS / "plain.png", p)
    calls = []

    def broken(self, source, folder):
        calls.append(source)
        raise RuntimeError("boom")

    monkeypatch.setattr(FitJob, "run", broken)
    out = tmp_path / "out"
    for attempt in (1, 2):
        result = run(*photos, "-o", out)
        assert result.exit_code == 1, result.output
        assert len(calls) == 2 * attempt
        summary = lines(out)
        assert [s["photo"] for s in summary] == [str(p) for p in photos]
        assert all(s["status"] == "failed" and s["reason"] == "unexpected error: RuntimeError: boom" for s in summary)
        report = json.loads((out / "a" / "report.json").read_text())
        assert report["status"] == "failed" and len(report["input"]["sha256"]) == 64


def test_a_dask_attempt_counts_its_starts_and_ends_failed_after_the_retry(tmp_path, monkeypatch):
    """On a Dask worker an input is started at most RETRIES + 1 times: a start whose worker died
    leaves its count behind; the next start past the retries writes the failed record without
    running the input; a finished attempt leaves no count (so a queued input that was never
    started has lost none of its tries)."""
    runs = []
    monkeypatch.setattr(FitJob, "run", lambda self, source, folder: runs.append(source) or {"status": "ok"})
    job, folder = FitJob(), tmp_path / "item"
    photo = tmp_path / "a.png"
    photo.write_bytes(b"a photo")  # an input that exists (a missing one is invalid before it runs)
    assert batch.counted_attempt(job, str(photo), str(folder)) == ({"status": "ok"}, "ok")
    assert runs == [str(photo)] and not folder.exists()  # nothing written, nothing left behind

    folder.mkdir()
    (folder / batch.STARTS).write_text(str(batch.RETRIES + 1))  # started twice, each time its worker died
    record, status = batch.counted_attempt(job, str(photo), str(folder))
    assert status == "failed" and runs == [str(photo)]
    assert "died on each of 2 tries" in record["reason"]
    assert json.loads((folder / job.record).read_text())["status"] == "failed"
    assert not (folder / batch.STARTS).exists()
