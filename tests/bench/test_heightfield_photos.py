"""The independent photo generator (weavecap/bench/heightfield_photos.py): known truth, its own code."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

from weavecap.bench import heightfield_photos as hp


def _imports(module) -> set[str]:
    tree = ast.parse(Path(module.__file__).read_text())
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            names.add(("." * node.level) + (node.module or ""))
        elif isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
    return names


def test_it_shares_no_code_with_the_forward_model():
    imported = _imports(hp)
    assert not any("model" in name or "mitsuba" in name or "drjit" in name for name in imported), imported


def test_each_cell_shows_the_yarn_the_pattern_puts_on_top():
    """Red warps and blue wefts, head-on, no jitter or camera: the centre of cell (i, j) is
    blue where the pattern says weft on top (1), red where warp (0)."""
    pattern = hp.twill(3, 1, 1)
    spec = hp.PhotoSpec("t", pattern, (0.7, 0.05, 0.05), (0.05, 0.05, 0.7), pitch_px=(20.0, 20.0), size_px=(200, 200),
                        jitter_position=0, jitter_width=0, jitter_colour=0, blur_px=0, highlight=0)
    rng = np.random.default_rng(0)
    fabric = hp._Fabric(spec, rng, extent_px=400)
    i, j = np.mgrid[0:8, 0:8]
    u, v = (j + 0.5) * 20.0, (i + 0.5) * 20.0
    rgb = fabric.radiance(u.astype(float), v.astype(float))
    weft_top = rgb[..., 2] > rgb[..., 0]
    states = fabric._state(i, j)
    assert np.array_equal(weft_top, states == 1)


def test_the_bench_set_covers_what_issue_11_asks():
    specs = hp.bench_specs()
    assert len(specs) >= 16 and len({s.name for s in specs}) == len(specs)
    from weavecap.estimate.weave_name import weave_name

    names = [weave_name(s.pattern) for s in specs]
    for wanted in ("plain", "twill 2/1 S", "twill 2/1 Z", "twill 3/1 S", "twill 3/1 Z", "twill 2/2 S", "twill 2/2 Z",
                   "satin 5/2 weft-faced", "satin 5/3 warp-faced", "satin 8/3 weft-faced", "satin 8/5 warp-faced",
                   "basket 2/2"):
        assert wanted in names, (wanted, names)
    assert max(max(s.pattern.shape) for s in specs if weave_name(s.pattern).startswith("custom")) == 8
    assert {s.gaps for s in specs} == {"dark", "backlit"}
    assert max(abs(s.exposure_stops) for s in specs) <= 1 and max(abs(s.rotate_deg) for s in specs) <= 15
    assert all(0.8 <= g <= 1.2 for s in specs for g in s.white_balance)
    assert all(80 <= s.jpeg_quality <= 95 for s in specs)
    near = sum(np.max(np.abs(np.subtract(s.warp_colour, s.weft_colour))) < 0.05 for s in specs)
    assert near >= len(specs) // 3


def test_exposure_and_white_balance_scale_the_scene():
    spec = hp.PhotoSpec("p", np.array([[1, 0], [0, 1]]), (0.4, 0.3, 0.2), (0.2, 0.3, 0.4), size_px=(64, 64),
                        noise=0.0, jpeg_quality=0, blur_px=0.0)
    from weavecap.photo import srgb_to_linear

    base = srgb_to_linear(hp.render_photo(spec).astype(np.float32) / 255)
    off = srgb_to_linear(hp.render_photo(hp.with_camera(spec, exposure_stops=-1.0, white_balance=(1.2, 1.0, 0.8)))
                         .astype(np.float32) / 255)
    ratio = off.reshape(-1, 3).mean(axis=0) / base.reshape(-1, 3).mean(axis=0)
    np.testing.assert_allclose(ratio, np.array([1.2, 1.0, 0.8]) / 2, rtol=0.03)


def test_bad_specs_are_refused():
    with pytest.raises(ValueError, match="cross_section"):
        hp.PhotoSpec("x", np.array([[1, 0], [0, 1]]), (0.5,) * 3, (0.5,) * 3, cross_section="square")
    with pytest.raises(ValueError, match="pattern"):
        hp.PhotoSpec("x", np.array([[2, 0], [0, 1]]), (0.5,) * 3, (0.5,) * 3)


def test_random_weaves_interlace_and_are_their_minimum_repeat():
    from weavecap.estimate.sampling import interlaces
    from weavecap.estimate.weave_name import minimal_repeat

    rng = np.random.default_rng(5)
    for shape in ((4, 4), (6, 6), (3, 6), (8, 8)):
        p = hp.random_weave(rng, shape)
        assert interlaces(p) and minimal_repeat(p).shape == shape
