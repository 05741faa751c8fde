"""Promise: a folder holds one run's complete results or none. A result set is staged whole and
installed with its record (``report.json``, ``render.json``, ``prepare.json``) last; an old set
this run does not replace is removed, never left beside the new record; a run killed at any
moment leaves either the old set whole, or no record — and running again resumes."""

from __future__ import annotations

import hashlib
import json
import subprocess
import sys
from pathlib import Path

import pytest

from weavecap.pipeline import OUTPUT_FILES

from .conftest import PLAIN, files_under, noise_photo, weavecap

#: a run of write_result_set in its own process that dies (SIGKILL) at the K-th rename, or
#: while writing its second file (K = -1); the files hold the run's name
KILLED = """
import json, os, signal, sys
from weavecap import io
folder, run, k = sys.argv[1], sys.argv[2], int(sys.argv[3])
installed = []
real_replace = os.replace
def replace(source, destination):
    if io.STAGING not in str(destination):  # a rename into the folder itself
        installed.append(destination)
        if len(installed) == k + 1:
            os.kill(os.getpid(), signal.SIGKILL)
    return real_replace(source, destination)
io.os.replace = replace
def writer(die=False):
    def write(path):
        if die:
            os.kill(os.getpid(), signal.SIGKILL)
        path.write_text(run)
    return write
files = {"params.json": writer(), "compare.png": writer(die=k == -1), "loss.png": writer()}
record = json.dumps({"status": "ok", "run": run, "input": {"sha256": ""}})
io.write_result_set(folder, files, record=("report.json", record), outputs=%r)
""" % (OUTPUT_FILES,)


def killed_write(folder: Path, run: str, k: int) -> None:
    proc = subprocess.run([sys.executable, "-c", KILLED, str(folder), run, str(k)], capture_output=True, text=True)
    assert proc.returncode == -9, proc.stderr


def finished_set(folder: Path, run: str, photo_sha: str = "0" * 64) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    for name in ("params.json", "compare.png", "loss.png"):
        (folder / name).write_text(run)
    (folder / "report.json").write_text(json.dumps({"status": "ok", "run": run, "input": {"sha256": photo_sha}}))


def visible(folder: Path) -> dict[str, str]:
    return {p.name: p.read_text() for p in folder.iterdir() if p.is_file()}


def test_force_onto_a_folder_whose_new_photo_is_rejected_leaves_no_old_fabric(sandbox):
    """The old params.json and compare.png go with their report.json: a `*/params.json` glob
    no longer finds the previous photo's fabric under the rejected one's report."""
    out = sandbox / "out"
    finished_set(out, "old")
    (out / "notes.txt").write_text("the user's own file")  # not a weavecap output: kept
    result = weavecap("fit", noise_photo(sandbox / "in" / "noise.png"), "-o", out, "--force", "-q")
    assert result.exit_code == 3, result.output
    assert files_under(out) == {"report.json", "diagnosis.png", "notes.txt"}  # the rejected photo's own set
    assert json.loads((out / "report.json").read_text())["status"] == "rejected"


@pytest.mark.parametrize("k", [-1, 0, 1, 2, 3])
def test_a_run_killed_at_any_moment_leaves_the_old_set_or_no_record(tmp_path, k):
    """k = -1: killed while writing its files; k: killed at the k-th rename into the folder
    (params, compare, loss, then the record)."""
    folder = tmp_path / "photo"
    finished_set(folder, "old")
    killed_write(folder, "new", k)
    files = visible(folder)
    if "report.json" in files:  # the old set, whole and alone
        assert json.loads(files.pop("report.json"))["run"] == "old"
        assert set(files.values()) == {"old"} and set(files) == {"params.json", "compare.png", "loss.png"}
    else:  # no record: unfinished, and marked so for the next run
        assert any(p.name.startswith(".weavecap-partial-") for p in folder.iterdir())


def test_an_interrupted_write_resumes_without_force(sandbox):
    """Killed while installing its outputs (params.json in place, no report.json), the folder
    is taken up again by the next run, which leaves one complete set and no staging folder."""
    out = sandbox / "out"
    photo = noise_photo(sandbox / "in" / "noise.png")
    killed_write(out, "interrupted", 1)
    assert (out / "params.json").exists() and not (out / "report.json").exists()
    result = weavecap("fit", photo, "-o", out, "-q")
    assert result.exit_code == 3, result.output
    assert files_under(out) == {"report.json", "diagnosis.png"}
    record = json.loads((out / "report.json").read_text())
    assert record["status"] == "rejected"
    assert record["input"]["sha256"] == hashlib.sha256(photo.read_bytes()).hexdigest()


def test_files_that_are_no_finished_result_are_still_refused_without_force(sandbox):
    """Outputs without a record and without weavecap's staging folder are not known to be
    weavecap's: refused, saying what is there."""
    out = sandbox / "out"
    out.mkdir()
    (out / "params.json").write_text("precious")
    result = weavecap("fit", noise_photo(sandbox / "in" / "noise.png"), "-o", out)
    assert result.exit_code == 2 and "holds params.json but no finished report.json" in result.output
    assert (out / "params.json").read_text() == "precious"


def test_a_failed_render_record_replaces_the_whole_old_set(tmp_path):
    """A failure's record is a result set too: the old image does not stay beside it."""
    from weavecap.batch import write_record
    from weavecap.render.job import RenderJob

    folder = tmp_path / "look"
    folder.mkdir()
    (folder / "render.png").write_text("old image")
    (folder / "render.json").write_text(json.dumps({"status": "ok"}))
    job = RenderJob.__new__(RenderJob)  # its outputs and record names are class attributes
    write_record(job, folder, job.failure_record(str(PLAIN), "failed", "unexpected error: boom", 1.0))
    assert visible(folder).keys() == {"render.json"}
    assert json.loads((folder / "render.json").read_text())["status"] == "failed"
