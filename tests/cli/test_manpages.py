"""The man pages in man/ are what the click commands generate: a changed option or help text
without `make man` fails here, naming the stale page and the command that fixes it."""

from __future__ import annotations

from pathlib import Path

from weavecap.cli import manpages
from weavecap.cli.main import COMMANDS, cli

MAN = Path(__file__).resolve().parents[2] / "man"
FIX = "regenerate with `make man` (python -m weavecap.cli.manpages man)"


def test_man_folder_is_up_to_date(tmp_path):
    """Every page in man/ equals a fresh generation, and no page is missing or left over."""
    manpages.write(tmp_path)
    fresh = {p.name: p.read_text() for p in tmp_path.glob("*.1")}
    committed = {p.name: p.read_text() for p in MAN.glob("*.1")} if MAN.is_dir() else {}
    missing = sorted(set(fresh) - set(committed))
    extra = sorted(set(committed) - set(fresh))
    stale = sorted(name for name in set(fresh) & set(committed) if fresh[name] != committed[name])
    assert not missing, f"man/ lacks {missing}; {FIX}"
    assert not extra, f"man/ has pages of commands that no longer exist: {extra}; {FIX}"
    assert not stale, f"stale man pages: {['man/' + n for n in stale]}; {FIX}"


def test_generation_is_deterministic():
    """Two generations are identical (no dates or other run-dependent text)."""
    assert manpages.generate() == manpages.generate()


def test_every_loadable_command_has_a_complete_page():
    """A page per command, with the sections a man reader expects and the help's examples."""
    pages = manpages.generate()
    loadable = [name for name in COMMANDS if cli.get_command(None, name) is not None]
    assert {"weavecap.1"} | {f"weavecap-{n}.1" for n in loadable} == set(pages)
    for name, text in pages.items():
        for section in ("NAME", "SYNOPSIS", "DESCRIPTION", "OPTIONS", "EXIT STATUS", "EXAMPLES", "SEE ALSO"):
            assert f".SH {section}\n" in text, f"{name} lacks {section}"
    synth = pages["weavecap-synth.1"]
    for option in ("\\-\\-tiles", "\\-\\-spp", "\\-\\-force", "\\-o, \\-\\-output"):
        assert option in synth
    assert "weavecap synth fixtures/params/twill_2_1.json \\-o twill.png" in synth
    assert '"weavecap ' in synth.splitlines()[0]  # the version stands where a date would


def test_roff_escaping():
    """Hyphens, backslashes and lines starting with a dot cannot be read as roff requests."""
    assert manpages.escape("a-b\\c\n.x\n'y") == "a\\-b\\ec\n\\&.x\n\\&'y"


def test_write_removes_pages_of_removed_commands(tmp_path):
    """A page of a command that no longer exists is deleted; other files are left alone."""
    (tmp_path / "weavecap-gone.1").write_text("old")
    (tmp_path / "README").write_text("keep")
    manpages.write(tmp_path)
    assert not (tmp_path / "weavecap-gone.1").exists()
    assert (tmp_path / "README").read_text() == "keep"
    assert (tmp_path / "weavecap.1").is_file()
