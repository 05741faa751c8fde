"""The colour-order stage (weavecap/estimate/thread_colours.py) on renders with a known answer."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from weavecap import params
from weavecap.estimate.thread_colours import colour_order, colour_repeat, thread_colours
from weavecap.model.render import as_photographed, render_numpy
from weavecap.model.scene import View, build_scene

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "params"
C = 16


def photo_of(fabric: params.Fabric, tiles: tuple[int, int]) -> np.ndarray:
    """A render of ``tiles`` weave repeats at C px a cell, blurred as a photo is."""
    n_e, n_a = fabric.shape
    size = C * max(tiles[0] * n_e, tiles[1] * n_a)
    return as_photographed(render_numpy(build_scene(fabric, View(tiles=tiles, size=size, spp=4))), 0.7, 1.0)


def cyclic_equal(a, b) -> bool:
    a, b = list(a), list(b)
    return len(a) == len(b) and any(a == b[k:] + b[:k] for k in range(len(b)))


@pytest.mark.parametrize("name, tiles", [("check_plain", (7, 6)), ("stripe_twill", (3, 6))])
def test_the_colour_orders_of_a_yarn_dyed_render_thread_by_thread(name, tiles):
    """Each family's colour repeat, its sequence and each entry's colour: the check's 6-end and
    7-pick orders (3 colours each, not multiples of the weave's 2), the stripe's 8-end warp
    order and its plain-dyed weft (no order)."""
    truth = params.load(FIXTURES / f"{name}.json")
    measured = thread_colours(photo_of(truth, tiles), truth.pattern, C)
    flat = photo_of(truth.with_threads(None).replace({f"{f}.{k}": truth.threads.warp.palette[0].body_reflection
                                                       for f in ("warp", "weft")
                                                       for k in ("body_reflection", "body_subsurface")}), tiles)
    reference = thread_colours(flat, truth.pattern, C)  # every thread in the first entry's colour
    for family in ("warp", "weft"):
        want = truth.threads.family(family)
        got = colour_order(measured[family])
        if want is None:
            assert got is None, family
            continue
        assert got.seen_twice and got.repeat == want.repeat
        assert cyclic_equal(got.sequence, want.sequence), (got.sequence, want.sequence)
        # the palette in the photo: the entry of the first thread is the first entry's colour
        first = got.sequence[0]
        assert np.allclose(got.palette[first], np.median(reference[family], axis=0), atol=0.01)


def test_a_plain_dyed_fabric_has_no_colour_order():
    truth = params.load(FIXTURES / "twill_2_1.json")
    measured = thread_colours(photo_of(truth, (4, 4)), truth.pattern, C)
    assert colour_order(measured["warp"]) is None and colour_order(measured["weft"]) is None


def test_thread_colours_are_read_at_the_cells_where_the_thread_is_on_top():
    """A canvas painted per cell with its top thread's colour (warp j: j/10 in red, weft i:
    i/10 in blue): each thread reads back exactly; a thread never on top reads NaN."""
    pattern = np.array([[1, 0], [0, 1]])
    rows, cols = 4, 6
    canvas = np.zeros((rows * C, cols * C, 3))
    for i in range(rows):
        for j in range(cols):
            weft = pattern[i % 2, j % 2] == 1
            canvas[i * C:(i + 1) * C, j * C:(j + 1) * C] = (0, 0, i / 10) if weft else (j / 10, 0, 0)
    got = thread_colours(canvas, pattern, C)
    np.testing.assert_allclose(got["warp"][:, 0], np.arange(cols) / 10)
    np.testing.assert_allclose(got["weft"][:, 2], np.arange(rows) / 10)
    all_weft = thread_colours(canvas, np.ones((2, 2)), C)
    assert np.all(np.isnan(all_weft["warp"]))


def test_the_colour_repeat_is_the_shortest_period_seen_twice_without_a_disagreeing_thread():
    order = [0, 0, 1, 2, 2]
    assert colour_repeat(np.array(order * 3)) == (5, True)
    assert colour_repeat(np.array(order * 3 + [0, 0])) == (5, True)  # a part repeat at the end
    unknown = np.array(order * 3)
    unknown[[1, 7]] = -1  # never on top: no vote
    assert colour_repeat(unknown) == (5, True)
    misread = np.array(order * 3)
    misread[6] = 2  # one thread misread: no shorter period holds, and 5 no longer does
    assert colour_repeat(misread)[0] != 5
    assert colour_repeat(np.array(order + [1])) == (6, False)  # seen once: every thread is the order
