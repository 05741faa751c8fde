"""The command line stays thin: each module of cli/ parses, calls one library function and
reports, in at most 120 lines (what the work does lives in weavecap/)."""

from __future__ import annotations

from pathlib import Path

CLI = Path(__file__).resolve().parents[1] / "cli"


def test_every_cli_module_is_at_most_120_lines():
    lengths = {p.name: len(p.read_text().splitlines()) for p in CLI.glob("*.py")}
    assert len(lengths) > 10 and "render.py" in lengths
    assert {name: n for name, n in lengths.items() if n > 120} == {}
