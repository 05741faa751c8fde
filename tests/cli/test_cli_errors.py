"""The command line as a user meets it: exit statuses, messages without tracebacks, outputs
never clobbered, and the help, doctor and a tiny synth run working."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from weavecap.cli.main import cli
from weavecap.photo import load_photo

PLAIN = Path(__file__).resolve().parents[2] / "fixtures" / "params" / "plain.json"
TINY = ["--size", "32", "--tiles", "1x1", "--spp", "1"]


def run(*args: str):
    """Invoke ``weavecap ARGS`` in-process; the result's output holds stdout and stderr."""
    return CliRunner().invoke(cli, [str(a) for a in args])


def run_subprocess(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    """Run ``python -m weavecap.cli.main ARGS`` as a separate process, as a shell user would."""
    env = {k: v for k, v in os.environ.items() if k != "WEAVECAP_DEBUG"}  # no tracebacks on purpose
    return subprocess.run([sys.executable, "-m", "weavecap.cli.main", *map(str, args)], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300)


def test_bad_params_exit_2_naming_field_and_range(bad_params, tmp_path):
    """Every bad params file: exit 2, the message names the field, value and range; no traceback."""
    out = tmp_path / "x.png"
    result = run("synth", bad_params.path, "-o", out)
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output
    assert bad_params.field in result.output
    for word in bad_params.words:
        assert word in result.output, f"{word!r} missing from: {result.output}"
    assert not out.exists()


def test_missing_params_file_exits_2(tmp_path):
    """A params file that does not exist: exit 2 and the path in the message."""
    missing = tmp_path / "nope.json"
    result = run("synth", missing, "-o", tmp_path / "x.png")
    assert result.exit_code == 2
    assert str(missing) in result.output and "not found" in result.output


@pytest.mark.parametrize("name", ["x.jpg", "x.bmp", "x"])
def test_unsupported_output_extension_exits_2(name, tmp_path):
    """An output the command cannot write (JPEG, BMP, no extension): exit 2, before any work."""
    result = run("synth", PLAIN, "-o", tmp_path / name, *TINY)
    assert result.exit_code == 2, result.output
    assert ".png" in result.output and ".exr" in result.output  # says what it can write
    assert not (tmp_path / name).exists()


def test_synth_renders_under_every_capture_rig(tmp_path):
    """``--light`` takes every rig the fit knows, ``lamp`` included, and the render is written."""
    from weavecap.model.scene import RIGS

    for rig in RIGS:
        out = tmp_path / f"{rig}.png"
        result = run("synth", PLAIN, "-o", out, *TINY, "--light", rig)
        assert result.exit_code == 0, (rig, result.output)
        assert load_photo(out).rgb.max() > 0, rig


def test_existing_output_is_kept_without_force(tmp_path):
    """An existing output is not overwritten without --force: exit 2 and the file unchanged."""
    out = tmp_path / "x.png"
    out.write_bytes(b"precious")
    result = run("synth", PLAIN, "-o", out, *TINY)
    assert result.exit_code == 2
    assert "--force" in result.output
    assert out.read_bytes() == b"precious"


BAD_OPTIONS = [
    ["--tiles", "0x2"], ["--tiles", "four"], ["--size", "0"], ["--spp", "0"], ["--light", "side"],
    ["--fov", "500", "--camera", "perspective"],
    ["--rotate", "nan"], ["--rotate", "inf"], ["--fov", "nan", "--camera", "perspective"],
]


@pytest.mark.parametrize("option", BAD_OPTIONS, ids=lambda option: " ".join(option))
def test_bad_option_values_exit_2(option, tmp_path):
    """Option values out of their range are usage errors (exit 2) with no traceback."""
    result = run("synth", PLAIN, "-o", tmp_path / "x.png", *TINY, *option)
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output
    assert not (tmp_path / "x.png").exists()


def test_help_lists_commands_and_examples():
    """`weavecap --help` lists synth and doctor and shows examples; `--version` works."""
    result = run("--help")
    assert result.exit_code == 0
    assert "synth" in result.output and "doctor" in result.output and "Examples:" in result.output
    version = run("--version")
    assert version.exit_code == 0 and "weavecap" in version.output


def test_synth_help_documents_its_options():
    """`weavecap synth --help` documents every option of the issue, with examples."""
    result = run("synth", "--help")
    assert result.exit_code == 0
    for option in ("--output", "--tiles", "--size", "--light", "--spp", "--rotate", "--seed", "--force", "Examples:"):
        assert option in result.output


def test_unknown_command_exits_2():
    """A misspelt command is a usage error."""
    assert run("synthesise").exit_code == 2


def test_doctor_reports_the_backend():
    """`weavecap doctor` shows the variant and the libLLVM it found."""
    result = run("doctor")
    assert result.exit_code == 0, result.output
    assert "variant" in result.output and "libllvm_path" in result.output


def test_tiny_synth_writes_a_deterministic_png(tmp_path):
    """A tiny synth run writes a 32×32 PNG; the same params and seed give the same bytes."""
    first, second = tmp_path / "a.png", tmp_path / "b.png"
    for out in (first, second):
        result = run("synth", PLAIN, "-o", out, *TINY, "--seed", "3")
        assert result.exit_code == 0, result.output
    image = load_photo(first).rgb
    assert image.shape == (32, 32, 3) and np.isfinite(image).all() and image.max() > 0
    assert first.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert first.read_bytes() == second.read_bytes()


def test_real_process_exit_statuses(tmp_path):
    """As a separate process: a bad file exits 2 with one message on stderr; --force overwrites."""
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({**json.loads(PLAIN.read_text()), "plies": 70}))
    proc = run_subprocess("synth", bad, "-o", "x.png", cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    assert "plies" in proc.stderr and "[1, 7]" in proc.stderr and "Traceback" not in proc.stderr

    (tmp_path / "x.png").write_bytes(b"old")
    proc = run_subprocess("synth", PLAIN, "-o", "x.png", *TINY, "--force", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "x.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
