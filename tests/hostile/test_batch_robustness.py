"""Promise: a batch goes on past bad inputs and ends with its worst status; its worker
processes never outlive it."""

from __future__ import annotations

import json
import shutil
import signal
import time

import psutil
import pytest

from .conftest import PLAIN_PHOTO, files_under, noise_photo, shell, weavecap


def summary(out) -> list[dict]:
    return [json.loads(line) for line in (out / "summary.jsonl").read_text().splitlines()]


def test_a_missing_file_and_a_folder_among_the_inputs_do_not_stop_the_batch(sandbox):
    """Either stopped the whole batch before any work; now each is an ``invalid`` line and the
    others run (a rejected photo here: the batch ends 3, the worst)."""
    photo = noise_photo(sandbox / "in" / "noise.png")
    folder = sandbox / "in" / "a-folder"
    folder.mkdir()
    missing = sandbox / "in" / "missing.png"
    out = sandbox / "out"
    result = weavecap("fit", missing, folder, photo, "-o", out, "-q")
    assert result.exit_code == 3, result.output
    lines = summary(out)
    assert [(line["photo"], line["status"], line["exit"]) for line in lines] == [
        (str(missing), "invalid", 2), (str(folder), "invalid", 2), (str(photo), "rejected", 3)]
    assert "no such photo" in lines[0]["reason"] and "is a folder" in lines[1]["reason"]
    assert files_under(out) == {"summary.jsonl", "noise/report.json", "noise/diagnosis.png"}  # nothing for the bad paths
    again = weavecap("fit", missing, folder, photo, "-o", out, "-q")  # resumes; the bad ones tried again
    assert again.exit_code == 3 and len(summary(out)) == 3


def test_a_render_batch_goes_on_past_a_missing_params_file(sandbox):
    from .conftest import PLAIN, SWATCH

    out = sandbox / "out"
    result = weavecap("render", sandbox / "in" / "nope.json", sandbox / "in", PLAIN, SWATCH, "-o", out,
                      "--size", "16x9", "--mode", "direct", "--spp", "1", "--pitch-mm", "2", "-q")
    assert result.exit_code == 2, result.output
    assert [line["status"] for line in summary(out)] == ["invalid", "invalid", "ok"]
    assert (out / "plain" / "render.png").is_file()


def children(pid: int) -> list[psutil.Process]:
    try:
        return psutil.Process(pid).children(recursive=True)
    except psutil.NoSuchProcess:
        return []


def alive(procs: list[psutil.Process]) -> list[psutil.Process]:
    def running(p):
        try:
            return p.status() != psutil.STATUS_ZOMBIE
        except psutil.NoSuchProcess:
            return False

    return [p for p in procs if running(p)]


@pytest.mark.parametrize("how", ["kill -9", "Ctrl-C"])
def test_jobs_workers_die_with_their_parent(sandbox, how):
    """Killed, the parent left its --jobs workers fitting on (~620 MB each) for nobody."""
    photos = [sandbox / "in" / f"p{k}.png" for k in range(2)]
    for photo in photos:
        shutil.copy(PLAIN_PHOTO, photo)
    proc = shell("fit", *photos, "-o", sandbox / "out", "--jobs", "2", "--quality", "draft", start_new_session=True)
    workers: list[psutil.Process] = []
    try:
        deadline = time.monotonic() + 120
        while proc.poll() is None and time.monotonic() < deadline:
            workers = [p for p in children(proc.pid) if "multiprocessing" in " ".join(p.cmdline())
                       and "spawn_main" in " ".join(p.cmdline())]
            if len(workers) >= 2:
                break
            time.sleep(0.1)
        assert len(workers) >= 2 and proc.poll() is None, "the workers did not start"
        time.sleep(1.0)  # inside their initializer or already fitting
        proc.send_signal(signal.SIGKILL if how == "kill -9" else signal.SIGINT)
        proc.wait(timeout=10)
        gone_by = time.monotonic() + 5
        while alive(workers) and time.monotonic() < gone_by:
            time.sleep(0.1)
        assert not alive(workers), [p.pid for p in alive(workers)]
    finally:  # whatever happened, leave no process of this test behind
        for p in alive(children(proc.pid) + workers):
            p.kill()
        if proc.poll() is None:
            proc.kill()
