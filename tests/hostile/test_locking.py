"""Promise: one run at a time on an ``-o`` folder. A second run on a folder another run holds
is refused at once (exit 2) naming the holder, and writes nothing; the lock dies with its
process; a single output file another run wrote meanwhile is not overwritten without --force."""

from __future__ import annotations

import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from weavecap.errors import InputError
from weavecap.io import LOCK, atomic_path, folder_lock

from .conftest import PLAIN, SWATCH, files_under, noise_photo, params_with, weavecap

HOLD = """
import sys, time
from weavecap.io import folder_lock
with folder_lock(sys.argv[1]):
    print("held", flush=True)
    time.sleep(600)
"""


@pytest.mark.parametrize("command", ["fit", "export", "prepare", "render"])
def test_a_second_run_on_a_held_folder_is_refused_and_writes_nothing(sandbox, command):
    photo = noise_photo(sandbox / "in" / "a.png")
    out = sandbox / "out"
    args = {"fit": ["fit", photo, noise_photo(sandbox / "in" / "b.png", 1)],
            "export": ["export", PLAIN, "--format", "wif"],
            "prepare": ["prepare", photo],
            "render": ["render", PLAIN, params_with(sandbox / "in", "other.json"), SWATCH]}[command]
    with folder_lock(out):
        before = files_under(sandbox)
        started = time.perf_counter()
        result = weavecap(*args, "-o", out)
        seconds = time.perf_counter() - started
        assert files_under(sandbox) == before
    assert result.exit_code == 2, result.output
    assert "another weavecap run is writing into this folder" in result.output and "wait for it" in result.output
    assert seconds < 5  # refused at once, not after the work


def test_the_holder_is_named_and_the_lock_dies_with_its_process(sandbox):
    """A run killed with -9 leaves no stale lock: the next run goes ahead."""
    out = sandbox / "out"
    holder = subprocess.Popen([sys.executable, "-c", HOLD, str(out)], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "held"
        with pytest.raises(InputError, match=rf"pid {holder.pid} on .*since"):
            with folder_lock(out):
                pass
    finally:
        holder.send_signal(signal.SIGKILL)
        holder.wait()
    assert (out / LOCK).exists()  # left by the killed run, unlocked
    result = weavecap("fit", noise_photo(sandbox / "in" / "a.png"), "-o", out, "-q")
    assert result.exit_code == 3, result.output
    assert files_under(out) == {"report.json", "diagnosis.png"}  # the lock file goes when its run ends


def test_a_folder_the_lock_made_goes_again_when_nothing_was_written(sandbox):
    with pytest.raises(InputError):
        with folder_lock(sandbox / "out" / "deep"):
            raise InputError("refused after the lock was taken")
    assert files_under(sandbox) == set() and not (sandbox / "out").exists()


def test_an_output_file_written_meanwhile_is_kept_without_force(tmp_path):
    """synth/render -o FILE check for an existing file before their work and again, without
    a gap, when they put the file in place (a link, which fails where a file exists)."""
    target = tmp_path / "x.png"
    with pytest.raises(InputError, match="appeared while this run worked"):
        with atomic_path(target, overwrite=False) as tmp:
            tmp.write_bytes(b"mine")
            target.write_bytes(b"the other run's")
    assert target.read_bytes() == b"the other run's"
    assert [p.name for p in tmp_path.iterdir()] == ["x.png"]  # no temporary file left
    with atomic_path(target) as tmp:  # --force
        tmp.write_bytes(np.zeros(3).tobytes())
    assert target.read_bytes() == np.zeros(3).tobytes()
