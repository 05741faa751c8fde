"""Thread colours of a capture (weavecap/fit/threads.py, weavecap/fit/compare.py) and the
per-thread colour lookup of the forward model (weavecap/model/threads.py), on known answers."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from weavecap import params
from weavecap.estimate.cells import CellGrid
from weavecap.estimate.thread_colours import colour_order, thread_colours
from weavecap.fit.photo_view import PhotoView
from weavecap.fit.threads import capture_threads, flattening_factor, flattening_references, thread_delta_e
from weavecap.model.render import as_photographed, render_numpy
from weavecap.model.scene import View, build_scene, light_rig
from weavecap.model.threads import mi, thread_table

ROOT = Path(__file__).resolve().parents[1]
FIXTURES = ROOT / "fixtures" / "params"
C = 16
BLUR = 0.7


def view_of(fabric: params.Fabric, tiles: tuple[int, int]) -> PhotoView:
    n_e, n_a = fabric.shape
    size = C * max(tiles[0] * n_e, tiles[1] * n_a)
    image = as_photographed(render_numpy(build_scene(fabric, View(tiles=tiles, size=size, spp=4))), BLUR, 1.0)
    return PhotoView(canvas=image, c=C, first=(0, 0), shape=fabric.shape, pitch_px=float(C), white=1.0)


@pytest.mark.parametrize("name, tiles, crop", [("check_plain", (7, 6), (0, 0)), ("check_plain", (9, 7), (3, 1)),
                                               ("stripe_twill", (3, 6), (0, 0))])
def test_each_threads_colour_is_solved_from_the_photo(name, tiles, crop):
    """Started from one wrong grey per family, with the rest of the fabric right, every entry of
    every colour order comes back (the render is linear in them): the check's white, navy and
    red in both directions, the stripe's green, white and navy warps. A view that starts
    ``crop`` cells into the photo (mid-repeat: its first cell is cell (1, 1) of the weave)
    counts its threads from the repeat that holds its first cell: weft 3 of the photo is its
    weft 1, warp 1 its warp 1."""
    truth = params.load(FIXTURES / f"{name}.json")
    grey = (0.3, 0.3, 0.3)
    start = truth.with_threads(None).replace({f"{f}.{k}": grey for f in ("warp", "weft")
                                              for k in ("body_reflection", "body_subsurface")})
    full = view_of(truth, tiles)
    n_e, n_a = truth.shape
    view = PhotoView(canvas=full.canvas[crop[0] * C:, crop[1] * C:], c=C, first=(crop[0] % n_e, crop[1] % n_a),
                     shape=truth.shape, pitch_px=float(C), white=1.0)
    got, note = capture_threads(view, start, light_rig("both"), blur_px=BLUR, spp=4)
    for family, skipped in (("warp", crop[1] - crop[1] % n_a), ("weft", crop[0] - crop[0] % n_e)):
        want = truth.threads.family(family)
        if want is None:
            assert got.threads.family(family) is None and family not in note["colour_orders"]
            continue
        order = got.threads.family(family)
        assert order.repeat == want.repeat
        # every thread's colour, counted from the repeat that holds the view's first cell
        np.testing.assert_allclose(order.per_thread("body_reflection"),
                                   np.roll(want.per_thread("body_reflection"), -skipped, axis=0), atol=0.03)
        assert note["colour_orders"][family]["delta_e"]["max"] < 1.0
        assert note["colour_orders"][family]["delta_e_before"]["median"] > 5


def test_a_plain_dyed_capture_keeps_its_family_colours():
    truth = params.load(FIXTURES / "twill_2_1.json")
    got, note = capture_threads(view_of(truth, (3, 3)), truth, light_rig("both"), blur_px=BLUR, spp=4)
    assert got.threads is None and note == {"colour_orders": {}}


def test_flattening_gives_every_thread_its_familys_reference_colour():
    """The check divided by its thread colours reads as one colour per family (within a few
    ΔE, the cells' edges mixing yarns) where it read three; the two families are flattened to
    different colours (white and navy are both worn by 3 of the 6 or 7 threads: the pair
    furthest apart)."""
    truth = params.load(FIXTURES / "check_plain.json")
    view = view_of(truth, (7, 6))
    measured = thread_colours(view.canvas, truth.pattern, C)
    orders = {f: colour_order(measured[f]) for f in ("warp", "weft")}
    references = flattening_references(orders, measured)
    warp_to, weft_to = (orders[f].palette[references[f]] for f in ("warp", "weft"))
    assert thread_delta_e({"warp": warp_to[None]}, {"warp": weft_to[None]})["warp"][0] > 15, (warp_to, weft_to)
    lattice = CellGrid.regular((7 * 2, 6 * 2), C)
    flat = view.canvas * flattening_factor(view.canvas.shape[:2], lattice, truth.pattern, orders, references)
    after = thread_colours(flat, truth.pattern, C)
    for family in ("warp", "weft"):
        assert colour_order(after[family]) is None
        to = orders[family].palette[references[family]]
        spread = thread_delta_e({family: after[family]}, {family: np.repeat(to[None], len(after[family]), 0)})
        assert np.nanmax(spread[family]) < 4.0, spread


def test_the_thread_lookup_wraps_any_index_and_box_filters_a_footprint():
    colours = np.array([[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]])
    table = thread_table(colours, 0.5 * colours)
    index = mi.Float([-4, -3, -1, 0, 2, 3, 7])
    r, s = table.at(index)
    got = np.array(r).T if np.array(r).shape[0] == 3 else np.array(r)
    np.testing.assert_allclose(got, colours[np.array([-4, -3, -1, 0, 2, 3, 7]) % 3])
    np.testing.assert_allclose(np.array(s).reshape(3, -1).T, 0.5 * got)
    # a footprint over threads 0.5 .. 2.75: half of thread 0, all of 1, three quarters of 2
    mean, _ = table.box_mean(mi.Float([1.625]), mi.Float([1.125]))
    np.testing.assert_allclose(np.array(mean).ravel(), np.array([0.5, 1.0, 0.75]) / 2.25, atol=1e-6)
    # ... and over -1.5 .. 4.5 (wrapping both ways): two whole repeats
    mean, _ = table.box_mean(mi.Float([1.5]), mi.Float([3.0]))
    np.testing.assert_allclose(np.array(mean).ravel(), np.full(3, 1 / 3), atol=1e-6)
    point, _ = table.box_mean(mi.Float([-0.5]), mi.Float([0.0]))  # no footprint: the thread there
    np.testing.assert_allclose(np.array(point).ravel(), colours[2])


def test_each_cell_of_the_render_shows_its_top_threads_colour():
    """The forward model colours the yarn on top of each cell by its thread's entry, over the
    fabric's whole repeat (14 picks x 6 ends for the check)."""
    # no grooves: their phase runs along each yarn, so cells of one repeat differ a little
    truth = params.load(FIXTURES / "check_plain.json").replace({"shadowing.ply": 0.0, "shadowing.fiber": 0.0})
    image = render_numpy(build_scene(truth, View(tiles=(7, 3), size=C * 14, spp=1), light="front"))
    single = {}
    for entry in truth.threads.warp.palette:
        plain = truth.with_threads(None).replace({f"{f}.{k}": entry.body_reflection for f in ("warp", "weft")
                                                  for k in ("body_reflection", "body_subsurface")})
        single[entry.body_reflection] = render_numpy(build_scene(plain, View(tiles=(1, 1), size=2 * C, spp=1),
                                                                 light="front"))
    for i in range(14):
        for j in range(6):
            weft = truth.pattern[i % 2, j % 2] == 1
            order = truth.threads.weft if weft else truth.threads.warp
            entry = order.palette[order.sequence[(i if weft else j) % order.repeat]]
            ref = single[entry.body_reflection][(i % 2) * C + C // 2, (j % 2) * C + C // 2]
            np.testing.assert_allclose(image[i * C + C // 2, j * C + C // 2], ref, atol=1e-3)


def _same_order(a, b) -> bool:
    """Whether two colour orders are the same up to where the repeat starts and how the
    palette is numbered: some rotation of ``a`` maps one to one onto ``b``."""
    a, b = list(a), list(b)

    def matches(rotated) -> bool:
        pairs = set(zip(rotated, b))
        return len({x for x, _ in pairs}) == len(pairs) == len({y for _, y in pairs})

    return len(a) == len(b) and any(matches(a[k:] + a[:k]) for k in range(len(a)))


def test_a_synthetic_check_is_captured_thread_by_thread(tmp_path):
    """``weavecap synth`` of the check (a plain weave, 6-end and 7-pick colour orders in white,
    navy and red), then ``weavecap fit`` (draft): each family's colour order comes back, every
    thread within ΔE 10 of the photo's (measured: median 0.3 / 0.1, largest 6.8 / 7.3), the
    pixel figures at the photo's scale are reported, and the captured params survive WIF with
    their colour orders."""
    import json

    from click.testing import CliRunner

    from weavecap import wif
    from weavecap.cli.main import cli

    photo, out = tmp_path / "check.png", tmp_path / "fit"
    runner = CliRunner()
    made = runner.invoke(cli, ["synth", str(FIXTURES / "check_plain.json"), "-o", str(photo), "--tiles", "14x12",
                               "--size", "512", "-q"], catch_exceptions=False)
    assert made.exit_code == 0, made.output
    fitted = runner.invoke(cli, ["fit", str(photo), "-o", str(out), "--quality", "draft"], catch_exceptions=False)
    assert fitted.exit_code == 0, fitted.output
    report = json.loads((out / "report.json").read_text())
    truth = params.load(FIXTURES / "check_plain.json")
    got = params.load(out / "params.json")
    orders = report["threads"]["colour_orders"]
    for family in ("warp", "weft"):
        assert _same_order(got.threads.family(family).sequence, truth.threads.family(family).sequence), family
        assert orders[family]["delta_e"]["max"] < 10, orders[family]
    scale = report["fit"]["fidelity"]["photo_scale"]
    assert scale["colour_p90"] < 10 and scale["structure"] > 0.9, scale
    draft = wif.read_wif(_written_wif(got, tmp_path))
    for family in ("warp", "weft"):
        assert draft.threads.family(family).sequence == got.threads.family(family).sequence
    from weavecap.photo import load_photo

    assert load_photo(out / "compare.png").rgb.shape[0] >= 256


def _written_wif(fabric: params.Fabric, folder: Path) -> Path:
    from weavecap import wif

    path = folder / "captured.wif"
    wif.save_wif(fabric, path)
    return path
