"""The one table of outcomes (weavecap.errors.OUTCOMES) and the command group's error handling."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest
from click.testing import CliRunner

from weavecap.errors import (OUTCOMES, BackendError, InputError, ParamsError, PhotoError, WeavecapError, outcome,
                             outcome_of_status, worst_exit)


@pytest.mark.parametrize("error, status, code", [
    (None, "ok", 0),
    (InputError("x"), "invalid", 2),
    (ParamsError("x", field="plies"), "invalid", 2),
    (PhotoError("x"), "rejected", 3),
    (BackendError("x"), "invalid", 2),  # a requirement to install: the message says which
    (WeavecapError("x"), "failed", 1),
    (RuntimeError("x"), "failed", 1),
    (KeyboardInterrupt(), "interrupted", 130),
])
def test_each_error_has_one_status_and_one_exit(error, status, code):
    assert (outcome(error).status, outcome(error).exit) == (status, code)
    assert outcome_of_status(status).exit == code
    if isinstance(error, WeavecapError):
        assert error.exit_code == code


def test_each_status_names_one_exit_status():
    statuses = [o.status for _, o in OUTCOMES]
    assert len(set(statuses)) == len(statuses) and len({o.exit for _, o in OUTCOMES}) == len(statuses)


def test_a_batch_exits_with_its_most_severe_outcome():
    """failed (1) > rejected (3) > invalid (2) > ok (0)."""
    assert worst_exit([]) == 0
    assert worst_exit([0, 2, 0]) == 2
    assert worst_exit([2, 3, 0]) == 3
    assert worst_exit([3, 1, 2]) == 1


@pytest.fixture
def broken_command(tmp_path, monkeypatch):
    """A command whose module fails to import (a dependency missing), registered as `broken`."""
    from weavecap.cli import main

    (tmp_path / "weavecap_broken_cmd.py").write_text("import weavecap_no_such_dependency\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setitem(main.COMMANDS, "broken", "weavecap_broken_cmd:broken")
    sys.modules.pop("weavecap_broken_cmd", None)
    return main


def _weavecap_with_broken(tmp_path, *args, debug: bool = False) -> subprocess.CompletedProcess:
    """``weavecap ARGS`` as its console script runs it (the command in a child process), with
    the broken command registered."""
    script = (f"import sys; sys.path.insert(0, {str(tmp_path)!r}); from weavecap.cli import main; "
              "main.COMMANDS['broken'] = 'weavecap_broken_cmd:broken'; main.main(sys.argv[1:])")
    env = {k: v for k, v in os.environ.items() if k != "WEAVECAP_DEBUG"} | ({"WEAVECAP_DEBUG": "1"} if debug else {})
    return subprocess.run([sys.executable, "-c", script, *args], env=env, capture_output=True, text=True, timeout=120)


def test_a_broken_command_module_is_an_unexpected_error_not_an_unknown_command(broken_command, tmp_path):
    done = _weavecap_with_broken(tmp_path, "broken")
    assert done.returncode == 1
    assert "No module named 'weavecap_no_such_dependency'" in done.stderr and "unexpected error" in done.stderr
    assert "No such command" not in done.stderr and "Traceback" not in done.stderr


def test_a_broken_command_shows_its_traceback_with_weavecap_debug(broken_command, tmp_path):
    done = _weavecap_with_broken(tmp_path, "broken", debug=True)
    assert done.returncode == 1
    assert "Traceback" in done.stderr and "ModuleNotFoundError" in done.stderr, done.stderr


def test_help_still_lists_the_other_commands_and_names_the_broken_one(broken_command):
    result = CliRunner().invoke(broken_command.cli, ["--help"])
    assert result.exit_code == 0
    assert "fit" in result.output and "synth" in result.output
    assert "broken" in result.output and "weavecap_no_such_dependency" in result.output


def test_only_an_unknown_name_is_no_such_command(broken_command, tmp_path):
    done = _weavecap_with_broken(tmp_path, "brokn")
    assert done.returncode == 2 and "No such command" in done.stderr
