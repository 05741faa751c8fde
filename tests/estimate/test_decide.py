"""The pattern decision's steps (weavecap.estimate.decide) on cell log-odds with known answers."""

from __future__ import annotations

import numpy as np
import pytest

from weavecap.estimate.cells import CellGrid
from weavecap.estimate.decide import DECIDED_NATS, fold, lattice_offset, photo_lattice, score_patterns
from weavecap.estimate.sampling import herringbone, satin, twill
from weavecap.estimate.weave_name import equal_up_to_shift


def noisy_logits(pattern, lattice, *, strength=2.0, flips=0.0, seed=0, phase=(0, 0)):
    """Log-odds a classifier might give a lattice of ``pattern`` tiled from ``phase``: ± strength
    with Gaussian noise, a share ``flips`` of the cells wrong."""
    rng = np.random.default_rng(seed)
    reps = (-(-lattice[0] // pattern.shape[0]) + 1, -(-lattice[1] // pattern.shape[1]) + 1)
    tiled = np.roll(np.tile(pattern, reps), phase, axis=(0, 1))[: lattice[0], : lattice[1]]
    truth = np.where(rng.random(lattice) < flips, 1 - tiled, tiled)
    return strength * (2.0 * truth - 1.0) + rng.normal(0, 0.5, lattice)


def test_fold_sums_each_cells_log_likelihood_over_the_repeat():
    rng = np.random.default_rng(3)
    logits = rng.normal(0, 2, (9, 10))
    p = twill(2, 1)
    a1, a0 = fold(logits, p.shape)
    tiled = np.tile(p, (3, 4))[:9, :10]
    direct = np.sum(np.where(tiled == 1, -np.logaddexp(0, -logits), -np.logaddexp(0, logits)))
    assert np.sum(np.where(p == 1, a1, a0)) == pytest.approx(direct)


@pytest.mark.parametrize("pattern, lattice", [
    (twill(2, 1, step=-1), (12, 12)), (1 - satin(5, 2), (15, 15)), (np.array([[1, 0], [0, 1]]), (8, 9)),
    (herringbone(twill(2, 2), 4), (10, 20)),
    (np.kron(np.array([[1, 0], [0, 1]]), np.ones((2, 1), int)), (12, 8))])
def test_a_named_weave_wins_even_with_a_fifth_of_the_cells_wrong(pattern, lattice):
    logits = noisy_logits(pattern, lattice, flips=0.2, seed=1, phase=(1, 2))
    ranked = score_patterns(logits)
    assert equal_up_to_shift(ranked[0].pattern, pattern), ranked[0].name


def test_a_custom_pattern_wins_only_when_the_cells_show_it_clearly():
    custom = np.array([[1, 1, 0, 1], [0, 1, 0, 0], [1, 0, 1, 0], [0, 0, 1, 1]], dtype=np.uint8)
    clear = score_patterns(noisy_logits(custom, (16, 16), strength=3.0, seed=2))
    assert clear[0].family == "custom" and equal_up_to_shift(clear[0].pattern, custom)
    # with most cells barely decided the photo cannot pay for sixteen free cells
    faint = score_patterns(noisy_logits(custom, (8, 8), strength=0.3, flips=0.3, seed=2))
    assert faint[0].family != "custom"


def evidence_per_cell(ranked, cells):
    """The best candidate's score less the best different weave's, per cell (decide's evidence)."""
    other = next(c for c in ranked[1:] if not equal_up_to_shift(c.pattern, ranked[0].pattern))
    return (ranked[0].score - other.score) / cells


def test_evidence_grows_with_what_the_cells_show():
    sure = score_patterns(noisy_logits(twill(1, 3), (12, 12), strength=6.0, seed=4))
    faint = score_patterns(noisy_logits(twill(1, 3), (12, 12), strength=0.05, seed=4))
    assert evidence_per_cell(sure, 144) > DECIDED_NATS > evidence_per_cell(faint, 144)


def test_the_lattice_covers_the_photo_in_whole_cells_at_the_repeats_phase():
    cells = CellGrid(rows=np.array([30.0, 40.0, 50.0]), cols=np.array([25.0, 37.0, 49.0, 61.0]))
    lattice = photo_lattice(np.zeros((100, 130)), cells)
    assert lattice.shape == (10, 10)
    assert lattice.rows[0] == pytest.approx(0.0) and lattice.cols[0] == pytest.approx(1.0)
    assert lattice.rows[-1] <= 100 and lattice.cols[-1] <= 130
    assert lattice_offset(lattice, cells) == (3, 2)
