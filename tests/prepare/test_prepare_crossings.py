"""Projections that repeat over several yarns (Wu et al. 2025 §4.4).

A weave's repeat can set its yarns' mean brightness apart: a basket 2/2's pairs, a random
weave's columns of floats. The integral projection then repeats over the pairs (over the 6
warps of a random 3×6), and its period is not the yarn pitch. The lattice of yarn crossings
(``grid.crossing_pitches``) tells: its fundamental is at the yarn pitch whatever the weave.
The photos are made by :mod:`weavecap.bench.heightfield_photos`, which shares no code with the
forward model; before the crossing test the basket came out 2×2 at twice its pitch and the
random 3×6 as 3×2 with a warp pitch of 6 warps.
"""

from __future__ import annotations

import numpy as np
import pytest

from weavecap.bench.heightfield_photos import bench_specs, render_photo, with_camera
from weavecap.photo import srgb_to_linear
from weavecap.prepare import Prepared, prepare_photo
from weavecap.prepare.grid import crossing_pitches, power_spectrum


def _holes(n: int, pitch: float) -> np.ndarray:
    """A grid of dark gaps 3 px wide at the given pitch along both axes, darkest (a hole)
    where they cross: the only term whose spectrum lies off the axes."""
    t = np.arange(n) % pitch
    gap = (np.minimum(t, pitch - t) < 1.5).astype(float)
    return 1.0 - 0.2 * gap[None, :] - 0.2 * gap[:, None] - 0.4 * gap[None, :] * gap[:, None]


def test_crossings_split_a_projection_that_repeats_over_pairs():
    n = 384
    img = _holes(n, 12.0)
    pair = ((np.arange(n) // 12) % 2).astype(float)  # every other yarn brighter, along each axis
    img = img + 0.4 * pair[None, :] + 0.4 * pair[:, None]  # the projections' period: 24 px
    (dx, dy), ratio, _ = crossing_pitches(power_spectrum(img), (24.0, 24.0), divisors=(2, 3, 4, 6), min_pitch=4.0,
                                          gain=2.0, min_share=0.01)
    assert (dx, dy) == (2, 2) and ratio > 2.0, ratio


def test_crossings_keep_yarns_with_a_centre_line():
    # yarns of pitch 24 whose profile dips twice (a bright centre line between two darker
    # halves): the projection's peak is at 12 px, but the gaps cross only every 24 px
    n = 384
    x = np.arange(n)
    yarn = 0.3 * np.cos(2 * np.pi * x / 12.0) ** 2
    img = _holes(n, 24.0) + yarn[None, :] + yarn[:, None]
    (dx, dy), ratio, _ = crossing_pitches(power_spectrum(img), (24.0, 24.0), divisors=(2, 3, 4, 6), min_pitch=4.0,
                                          gain=2.0, min_share=0.01)
    assert (dx, dy) == (1, 1), ratio


def _photo(name: str, size: int = 512):
    for k, spec in enumerate(bench_specs(seed=11)):
        if spec.name == name:
            spec = with_camera(spec, size_px=(size, size))
            srgb = render_photo(spec, seed=11 + k)
            return spec, srgb_to_linear(srgb.astype(np.float32) / 255.0)
    raise KeyError(name)


@pytest.mark.parametrize("name", ["11_basket22", "16_random3x6", "15_plain_backlit"])
def test_independent_photo_gives_its_repeat_and_pitch(name):
    spec, rgb = _photo(name)
    r = prepare_photo(rgb)
    assert isinstance(r, Prepared), r
    assert tuple(r.grid.yarns) == np.asarray(spec.pattern).shape, (r.grid.yarns, r.checks)
    pitch = np.asarray(r.checks["pitch_input_px"])
    assert np.allclose(pitch, spec.pitch_px, rtol=0.03), (pitch, spec.pitch_px)
