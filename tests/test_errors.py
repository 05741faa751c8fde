"""The one table of outcomes (weavecap.errors.OUTCOMES) and the command group's error handling."""

from __future__ import annotations

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
    monkeypatch.delenv("WEAVECAP_DEBUG", raising=False)
    sys.modules.pop("weavecap_broken_cmd", None)
    return main


def test_a_broken_command_module_is_an_unexpected_error_not_an_unknown_command(broken_command, capsys):
    with pytest.raises(SystemExit) as info:
        broken_command.main(["broken"])
    err = capsys.readouterr().err
    assert info.value.code == 1
    assert "No module named 'weavecap_no_such_dependency'" in err and "unexpected error" in err
    assert "No such command" not in err and "Traceback" not in err


def test_a_broken_command_shows_its_traceback_with_weavecap_debug(broken_command, monkeypatch):
    monkeypatch.setenv("WEAVECAP_DEBUG", "1")
    with pytest.raises(ModuleNotFoundError, match="weavecap_no_such_dependency"):
        broken_command.main(["broken"])


def test_help_still_lists_the_other_commands_and_names_the_broken_one(broken_command):
    result = CliRunner().invoke(broken_command.cli, ["--help"])
    assert result.exit_code == 0
    assert "fit" in result.output and "synth" in result.output
    assert "broken" in result.output and "weavecap_no_such_dependency" in result.output


def test_only_an_unknown_name_is_no_such_command(broken_command, capsys):
    with pytest.raises(SystemExit) as info:
        broken_command.main(["brokn"])
    assert info.value.code == 2 and "No such command" in capsys.readouterr().err
