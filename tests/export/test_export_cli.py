"""``weavecap export`` as a user runs it: outputs, refusing to overwrite, --force, --pattern."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from click.testing import CliRunner

from weavecap import params, wif
from weavecap.cli.main import cli

ROOT = Path(__file__).resolve().parents[2]
FIXTURE = ROOT / "fixtures" / "params"


def run(*args):
    return CliRunner().invoke(cli, ["export", *map(str, args)], catch_exceptions=False)


def test_export_wif_writes_the_draft(tmp_path):
    out = tmp_path / "out"
    result = run(FIXTURE / "satin_5.json", "-o", out, "--format", "wif", "--json", "-q")
    assert result.exit_code == 0, result.output
    assert json.loads(result.output) == {"files": [str(out / "satin_5.wif")]}
    np.testing.assert_array_equal(wif.read_wif(out / "satin_5.wif").pattern, params.load(FIXTURE / "satin_5.json").pattern)


def test_export_never_overwrites_without_force(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "plain.wif").write_text("keep")
    result = run(FIXTURE / "plain.json", "-o", out, "--format", "wif")
    assert result.exit_code == 2 and "--force" in result.output
    assert (out / "plain.wif").read_text() == "keep"
    assert run(FIXTURE / "plain.json", "-o", out, "--format", "wif", "--force").exit_code == 0
    assert (out / "plain.wif").read_text().startswith("[WIF]")


def test_export_takes_a_known_pattern_and_a_name(tmp_path):
    draft = tmp_path / "twill.wif"
    wif.save_wif(params.load(FIXTURE / "twill_3_1.json"), draft)
    out = tmp_path / "out"
    assert run(FIXTURE / "plain.json", "-o", out, "--format", "wif", "--pattern", draft, "--name", "mine",
               "-q").exit_code == 0
    np.testing.assert_array_equal(wif.read_wif(out / "mine.wif").pattern,
                                  params.load(FIXTURE / "twill_3_1.json").pattern)


def test_a_fit_folder_exports_under_its_folder_name(tmp_path):
    folder = tmp_path / "swatch"
    folder.mkdir()
    params.save(params.load(FIXTURE / "plain.json"), folder / "params.json")
    assert run(folder / "params.json", "-o", tmp_path / "out", "--format", "wif", "-q").exit_code == 0
    assert (tmp_path / "out" / "swatch.wif").is_file()


def test_bad_formats_and_outputs_are_usage_errors(tmp_path):
    result = run(FIXTURE / "plain.json", "-o", tmp_path, "--format", "wif,obj")
    assert result.exit_code == 2 and "'obj' is not a format" in result.output
    a_file = tmp_path / "file"
    a_file.write_text("")
    result = run(FIXTURE / "plain.json", "-o", a_file, "--format", "wif")
    assert result.exit_code == 2 and "is a file" in result.output
