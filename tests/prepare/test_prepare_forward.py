"""Preparation on renders of weavecap's own forward model (its test data).

The forward model draws plies and fibres along each yarn, lights the gaps from behind and
gives warps and wefts their own colours and radii; the repeat must still come out as the
pattern's, in yarns. (``scripts/bench_prepare.py --forward N`` measures the same on more.)
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from forward import forward_photo, measure_forward, minimum_repeat

from weavecap.estimate.sampling import satin, twill
from weavecap.photo import load_photo
from weavecap.prepare import Prepared, prepare_photo
from weavecap.prepare.period import cell_repeat, complement_repeats

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures"


# ------------------------------------------------------------------ the cell DMF (§4.3)

def _cells(pattern: np.ndarray, tiles: tuple[int, int], rng: np.random.Generator) -> np.ndarray:
    """Cell features of a tiled pattern: which yarn is on top (in several features), plus noise
    and a stripe along every weft whose phase is not the repeat's (a ply)."""
    p = np.tile(pattern, tiles).astype(float)
    ny, nx = p.shape
    ply = np.sin(2 * np.pi * np.arange(nx) / 2.7)[None, :] * rng.uniform(0.5, 1.0, (ny, 1))
    feats = [p, 1 - p, 0.6 * p + 0.4 * ply, ply]
    return np.stack(feats, axis=2) + rng.normal(0, 0.15, (ny, nx, len(feats)))


@pytest.mark.parametrize("pattern", [twill(2, 1, step=1), satin(5, 2), satin(8, 3), twill(4, 3, step=1),
                                     np.array([[1, 0, 0, 1, 1, 0], [0, 1, 1, 0, 0, 1], [1, 1, 0, 0, 1, 0],
                                               [0, 0, 1, 1, 0, 1]])])
def test_cell_repeat_finds_the_pattern_repeat(pattern):
    rng = np.random.default_rng(3)
    cells = _cells(pattern, (4, 4), rng)
    found = [cell_repeat(cells, axis=a, max_yarns=48, tol=0.1, z=3.0, min_depth=0.15)[0] for a in (0, 1)]
    assert tuple(found) == pattern.shape


def test_cell_repeat_of_a_herringbone_is_its_reversal_not_its_twill_step():
    """A herringbone (2/2 twill reversing every 12 warps) whose cells do not tell a warp float
    from a weft float (Brodatz D16): shifted by two warps a leg matches itself, but the
    reversals undo that a few warps on; only the reversal period dips at all its multiples."""
    cols = np.concatenate([np.arange(12), np.arange(12)[::-1]])
    p = np.tile(twill(2, 2, step=1)[:, cols % 4], (10, 3)).astype(float)
    edges = np.abs(p - np.roll(p, 1, axis=1)) + np.abs(p - np.roll(p, 1, axis=0))
    cells = np.stack([edges, np.roll(edges, 1, axis=1)], axis=2)
    cells = cells + np.random.default_rng(3).normal(0, 0.15, cells.shape)
    runs = [cell_repeat(cells, axis=a, max_yarns=48, tol=0.1, z=3.0, min_depth=0.15) for a in (0, 1)]
    found = [r[0] for r in runs]
    assert found == [2, 24]  # along y a shift of two wefts is the same look: the cells cannot tell
    # ... but along x the look repeats over 2 warps only within a leg: the 2 wefts are a 2/2
    # twill's complement, and the repeat is widened to the twill's 4 for the fit to decide
    assert complement_repeats(found, [r[2] for r in runs], tol=0.1) == [4, 24]


def test_complement_repeats_keep_a_plain_weave_and_a_rib():
    """A plain weave repeats over 2 yarns along both axes, a 2 × 8 rib's shift by two warps
    changes half its cells: neither has a leg that matches itself two yarns on."""
    for p in (np.array([[1, 0], [0, 1]]), np.array([[1, 1, 1, 1, 0, 0, 0, 0], [0, 0, 0, 0, 1, 1, 1, 1]])):
        cells = _cells(p, (24 // p.shape[0], 48 // p.shape[1]), np.random.default_rng(3))
        runs = [cell_repeat(cells, axis=a, max_yarns=48, tol=0.1, z=3.0, min_depth=0.15) for a in (0, 1)]
        found = [r[0] for r in runs]
        assert found == list(p.shape)
        assert complement_repeats(found, [r[2] for r in runs], tol=0.1) == list(p.shape)


def test_cell_repeat_reports_no_repeat_in_noise():
    cells = np.random.default_rng(0).normal(size=(20, 20, 12))
    assert cell_repeat(cells, axis=1, max_yarns=48, tol=0.1, z=3.0, min_depth=0.15)[0] is None


def test_minimum_repeat_of_a_pattern_with_identical_rows():
    p = np.array([[1, 0, 0], [0, 1, 1], [1, 0, 0], [0, 1, 1]])
    assert minimum_repeat(p) == (2, 3)
    assert minimum_repeat(satin(5, 2)) == (5, 5)


# ------------------------------------------------------------------ forward-model renders

@pytest.mark.parametrize("seed, pattern", [
    (1, twill(2, 1, step=1)),
    (3, np.array([[1, 0, 0, 1, 1, 0], [0, 1, 1, 0, 0, 1], [1, 1, 0, 0, 1, 0], [0, 0, 1, 1, 0, 1]])),
])
def test_forward_model_render(seed, pattern):
    img, truth = forward_photo(np.random.default_rng(seed), pattern=pattern, size=256, spp=4, max_turn_deg=40.0,
                               pitch_px=(9.0, 12.0))
    r = prepare_photo(img)
    assert isinstance(r, Prepared), r.reason
    m = measure_forward(r, truth)
    assert m["repeat_ok"], (r.grid.yarns, truth.yarns)
    assert m["pitch_err"] <= 0.02 and m["turn_err"] <= 1.0, m


@pytest.mark.parametrize("name", sorted(p.stem for p in (FIXTURES / "photos").glob("*.png")))
def test_fixture_photo_gives_its_pattern_shape(name):
    """Every photo in fixtures/photos (``weavecap synth`` of fixtures/params) gives the minimum
    repeat of its params file's pattern."""
    pattern = np.array(json.loads((FIXTURES / "params" / f"{name}.json").read_text())["pattern"])
    r = prepare_photo(load_photo(FIXTURES / "photos" / f"{name}.png").rgb)
    assert isinstance(r, Prepared), r.reason
    assert tuple(r.grid.yarns) == minimum_repeat(pattern)
