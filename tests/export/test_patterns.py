"""Known patterns from files (``--pattern``), in the library and through fit and synth."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from weavecap import params, wif
from weavecap.cli.main import cli
from weavecap.errors import InputError
from weavecap.patterns import load_pattern

ROOT = Path(__file__).resolve().parents[2]
FIXTURE = ROOT / "fixtures" / "params"
TWILL = params.load(FIXTURE / "twill_2_1.json").pattern


def run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args], catch_exceptions=False)


def test_the_same_pattern_from_json_wif_and_text(tmp_path):
    draft = tmp_path / "twill.wif"
    wif.save_wif(params.load(FIXTURE / "twill_2_1.json"), draft)
    text = tmp_path / "twill.txt"
    text.write_text("\n".join(" ".join(map(str, row)) for row in TWILL) + "\n")
    for path in (FIXTURE / "twill_2_1.json", draft, text):
        np.testing.assert_array_equal(load_pattern(path), TWILL)


@pytest.mark.parametrize("content, words", [
    ("1 0\n0 2\n", ("0 and 1",)),
    ("1 0\n0\n", ("rectangle",)),
    ("", ("non-empty",)),
    ("one two\n", ("rows of 0 and 1",)),
    ("\n".join(["0 1 " * 33] * 2), ("2 wefts × 66 warps", "64")),
])
def test_bad_text_patterns_are_input_errors(tmp_path, content, words):
    path = tmp_path / "p.txt"
    path.write_text(content)
    with pytest.raises(InputError) as err:
        load_pattern(path)
    for word in words:
        assert word in str(err.value)


def test_a_missing_pattern_file_says_what_it_may_be(tmp_path):
    with pytest.raises(InputError, match="cannot read the pattern file.*wif"):
        load_pattern(tmp_path / "nope.wif")


def test_synth_renders_the_draft_instead_of_the_params_pattern(tmp_path):
    """synth A.json --pattern plain.wif is, bit for bit, synth of A with plain weave."""
    draft = tmp_path / "plain.wif"
    wif.save_wif(params.load(FIXTURE / "plain.json"), draft)
    plain_twill = tmp_path / "twill_as_plain.json"
    params.save(params.load(FIXTURE / "twill_2_1.json").replace({"pattern": [[1, 0], [0, 1]]}), plain_twill)
    small = ("--size", "48", "--tiles", "2x2", "--spp", "1", "-q")
    a = run("synth", FIXTURE / "twill_2_1.json", "--pattern", draft, "-o", tmp_path / "a.exr", *small)
    b = run("synth", plain_twill, "-o", tmp_path / "b.exr", *small)
    c = run("synth", FIXTURE / "twill_2_1.json", "-o", tmp_path / "c.exr", *small)
    assert a.exit_code == b.exit_code == c.exit_code == 0, a.output + b.output + c.output
    from weavecap.photo import load_photo

    img = {k: load_photo(tmp_path / f"{k}.exr").rgb for k in "abc"}
    np.testing.assert_array_equal(img["a"], img["b"])
    assert np.abs(img["a"] - img["c"]).mean() > 0.01  # the twill looks different


@pytest.mark.parametrize("command", [
    ("synth", FIXTURE / "plain.json", "-o", "{out}/x.png"),
    ("fit", ROOT / "fixtures" / "photos" / "plain.png", "-o", "{out}/fit"),
])
def test_a_bad_draft_exits_2_naming_the_section_and_writes_nothing(tmp_path, command, shared):
    args = [str(a).format(out=tmp_path) for a in command]
    result = run(*args, "--pattern", shared("wif", "bad", "missing_tieup.wif"))
    assert result.exit_code == 2, result.output
    assert "[TIEUP]" in result.output and "Traceback" not in result.output
    assert list(tmp_path.iterdir()) == []


def test_fit_keeps_a_known_draft_fixed(tmp_path):
    draft = tmp_path / "twill.wif"
    wif.save_wif(params.load(FIXTURE / "twill_2_1.json"), draft)
    out = tmp_path / "fit"
    result = run("fit", ROOT / "fixtures" / "photos" / "twill_2_1.png", "-o", out, "--pattern", draft,
                 "--quality", "draft", "--budget", "2", "-q")
    assert result.exit_code == 0, result.output
    report = json.loads((out / "report.json").read_text())
    assert report["fit"]["pattern_fixed"] is True
    np.testing.assert_array_equal(params.load(out / "params.json").pattern, TWILL)


def test_render_shows_the_draft_instead_of_the_params_pattern(tmp_path):
    """render A.json --pattern plain.wif is, bit for bit, render of A with plain weave."""
    from weavecap.fixtures import path as fixture_path

    draft = tmp_path / "plain.wif"
    wif.save_wif(params.load(FIXTURE / "plain.json"), draft)
    plain_twill = tmp_path / "twill_as_plain.json"
    params.save(params.load(FIXTURE / "twill_2_1.json").replace({"pattern": [[1, 0], [0, 1]]}), plain_twill)
    mesh = fixture_path("meshes", "swatch.obj")
    small = ("--size", "24x24", "--spp", "2", "--pitch-mm", "20", "-q")
    a = run("render", FIXTURE / "twill_2_1.json", mesh, "--pattern", draft, "-o", tmp_path / "a.exr", *small)
    b = run("render", plain_twill, mesh, "-o", tmp_path / "b.exr", *small)
    assert a.exit_code == b.exit_code == 0, a.output + b.output
    from weavecap.photo import load_photo

    np.testing.assert_array_equal(load_photo(tmp_path / "a.exr").rgb, load_photo(tmp_path / "b.exr").rgb)
