"""The render bench (weavecap.bench.render, ``weavecap bench --render``): its sections measure
what they say, side by side, and report it as tables; other renderers can add sections."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from weavecap.cli.main import cli
from weavecap.fixtures import path as fixture_path
from weavecap.bench import render as bench


@pytest.fixture
def tiny(monkeypatch):
    monkeypatch.setattr(bench, "SIZE", (64, 36))
    monkeypatch.setattr(bench, "SPP", 2)


def test_measure_times_both_renderers_on_the_same_scene(tiny):
    """Both renderers report cold and warm times; the reference its bake; memory both ways."""
    row = bench.measure(fixture_path("meshes", "sine_low.obj"))
    assert row["triangles"] == 384 and row["bake_s"] > 0 and row["texels_per_yarn"] >= 16
    for name in ("diffuse", "reference"):
        assert row[f"{name}_cold_s"] > 0 and row[f"{name}_warm_s"] > 0
    assert 50 < row["diffuse_peak_rss_mb"] <= row["peak_rss_mb"]
    assert row["texture_filter"] in ("linear", "nearest")


def test_tables_and_sections():
    """The tables show every row's figures; a registered section is run and shown."""
    rows = [{"mesh": "towel", "triangles": 2048, "diffuse_cold_s": 5.0, "diffuse_warm_s": 4.0,
             "reference_cold_s": 12.0, "reference_warm_s": 10.0, "bake_s": 2.5, "diffuse_peak_rss_mb": 300,
             "peak_rss_mb": 500, "ratio_cold": 2.4, "ratio_warm": 2.5}]
    text = bench.reference_table(rows)
    assert "| towel | 2048 | 5.0 / 4.0 s | 12.0 / 10.0 s | 2.40× / 2.50× | 2.5 s | 300 / 500 MB |" in text
    extra = bench.Section("extra", "An extra section", lambda quick, progress: [{"x": 1}],
                          lambda rows: f"{len(rows)} row")
    saved = list(bench.SECTIONS)
    try:
        bench.register_section(extra)
        assert bench.SECTIONS[-1] is extra
        results = {"extra": extra.run(True, None)}
        assert "### An extra section\n\n1 row" in bench.tables(results)
    finally:
        bench.SECTIONS[:] = saved


def test_bench_sections_are_chosen_by_their_flags(monkeypatch, tmp_path):
    """`weavecap bench --render` runs the render sections only and writes render.json."""
    calls = []
    monkeypatch.setattr(bench, "run", lambda quick, progress: calls.append(quick) or {"reference": []})
    result = CliRunner().invoke(cli, ["bench", "--render", "--quick", "-o", str(tmp_path)])
    assert result.exit_code == 0, result.output
    assert calls == [True] and (tmp_path / "render.json").is_file() and not (tmp_path / "results.json").exists()
