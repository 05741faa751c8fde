"""Promise: the exit status says what happened, as the README's table says — 2 for what the
user must fix (an input, an option, an unwritable -o, a missing library), 3 for a rejected
photo, 1 only for what is weavecap's fault — and problems a user can see coming are found
before any work."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest

from weavecap.errors import OUTCOMES

from .conftest import PLAIN, ROOT, SWATCH, files_under, noise_photo, weavecap


def test_the_readmes_table_is_the_code():
    """Each row of README.md's "Exit status" table (status, word in summary.jsonl) is an
    outcome of weavecap/errors.py's OUTCOMES, and every written outcome has its row."""
    text = (ROOT / "README.md").read_text().split("## Exit status", 1)[1].split("\n## ", 1)[0]
    rows = {int(m[1]): m[2] for m in re.finditer(r"^\| (\d+) \|[^|]*\| `(\w+)`", text, re.M)}
    written = {o.exit: o.status for _, o in OUTCOMES if o.status != "interrupted"}
    assert rows == written
    assert "130" in text and "143" in text  # interrupted: Ctrl-C, SIGTERM


UNWRITABLE = {
    "fit": lambda s, out: ["fit", noise_photo(s / "in" / "a.png"), "-o", out],
    "synth": lambda s, out: ["synth", PLAIN, "-o", out / "x.png"],
    "render": lambda s, out: ["render", PLAIN, SWATCH, "-o", out / "x.png"],
    "render-batch": lambda s, out: ["render", PLAIN, PLAIN, SWATCH, "-o", out],
    "export": lambda s, out: ["export", PLAIN, "-o", out, "--format", "wif"],
    "prepare": lambda s, out: ["prepare", noise_photo(s / "in" / "a.png"), "-o", out],
}


@pytest.mark.parametrize("command", UNWRITABLE)
@pytest.mark.parametrize("where", ["under-a-file", "proc"])
def test_an_unwritable_output_is_refused_before_any_work(sandbox, command, where):
    """A fit found it after 46.8 s of work, as exit 1 "unexpected PermissionError". (Root
    writes anywhere a mode allows, so the unwritable places here are a path under a file and
    /proc, which refuse everyone.)"""
    (sandbox / "a-file").write_text("")
    out = sandbox / "a-file" / "out" if where == "under-a-file" else Path("/proc/weavecap-test/out")
    args = UNWRITABLE[command](sandbox, out)
    before = files_under(sandbox)
    started = time.perf_counter()
    result = weavecap(*args)
    assert result.exit_code == 2, result.output
    assert "choose another -o" in result.output and "Traceback" not in result.output
    assert time.perf_counter() - started < 5 and files_under(sandbox) == before


def test_an_unreadable_photo_is_rejected_exit_3_as_the_man_page_says(sandbox, monkeypatch):
    """click's own check made a chmod-000 photo a usage error (exit 2). The file system is
    played by monkeypatch here (root reads any file): what a user without read permission
    meets, os.access saying no and open() raising EACCES."""
    photo = noise_photo(sandbox / "in" / "locked.png")
    real_access, real_read = os.access, Path.read_bytes

    def access(path, mode, *args, **kwargs):
        return False if Path(path) == photo else real_access(path, mode, *args, **kwargs)

    def read_bytes(self):
        if self == photo:
            raise PermissionError(13, "Permission denied", str(self))
        return real_read(self)

    monkeypatch.setattr(os, "access", access)
    monkeypatch.setattr(Path, "read_bytes", read_bytes)
    result = weavecap("fit", photo, "-o", sandbox / "out", "-q")
    assert result.exit_code == 3, result.output
    assert "cannot be read (Permission denied); check its permissions" in result.output


@pytest.mark.skipif(os.geteuid() == 0, reason="root reads files whatever their mode")
def test_an_unreadable_photo_is_rejected_exit_3_for_real(sandbox):
    photo = noise_photo(sandbox / "in" / "locked.png")
    photo.chmod(0)
    result = weavecap("fit", photo, "-o", sandbox / "out", "-q")
    assert result.exit_code == 3 and "Permission denied" in result.output


def test_an_old_libllvm_named_by_the_user_is_exit_2_with_the_fix(tmp_path):
    """Dr.Jit aborts the process on libLLVM 15 (SIGABRT, no message): refused before it is
    loaded, naming the variable and a library that works."""
    old = tmp_path / "libLLVM-15.so.1"
    old.write_bytes(b"")
    env = {**os.environ, "DRJIT_LIBLLVM_PATH": str(old)}
    proc = subprocess.run([sys.executable, "-m", "weavecap.cli.main", "synth", PLAIN, "-o", tmp_path / "x.png"],
                          env=env, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2, proc.stderr
    assert "DRJIT_LIBLLVM_PATH names libLLVM 15" in proc.stderr and "19 or newer" in proc.stderr
    assert not (tmp_path / "x.png").exists()


IMPORT_FIRST = """
import drjit                                  # before weavecap: Dr.Jit picks its libLLVM now
from weavecap.backend import mitsuba
from weavecap.errors import BackendError
try:
    mi = mitsuba()
    import drjit as dr
    print("rendered", dr.minimum(mi.Float([1, 2, 3]), 2.0))   # llvm.minimum aborted libLLVM 15
except BackendError as error:
    print("refused", error)
"""


def test_importing_drjit_before_weavecap_never_aborts():
    """Where Dr.Jit's own search finds an old system libLLVM (this machine has 14 and 15), the
    process ended in SIGABRT; now it works (a libLLVM >= 19 was found first) or says how to fix it."""
    env = {k: v for k, v in os.environ.items() if k != "DRJIT_LIBLLVM_PATH"}
    proc = subprocess.run([sys.executable, "-c", IMPORT_FIRST], env=env, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.startswith(("rendered [1, 2, 2]", "refused Dr.Jit was imported before weavecap"))
    if proc.stdout.startswith("refused"):
        assert "Import weavecap before drjit" in proc.stdout


def test_importing_weavecap_first_makes_drjit_load_a_working_libllvm():
    env = {k: v for k, v in os.environ.items() if k != "DRJIT_LIBLLVM_PATH"}
    code = "import weavecap\n" + IMPORT_FIRST
    proc = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0 and proc.stdout.startswith("rendered [1, 2, 2]"), proc.stdout + proc.stderr[-2000:]
