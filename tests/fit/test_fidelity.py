"""Fidelity figures (weavecap/fit/fidelity.py) on canvases with a known answer."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.ndimage import gaussian_filter

from weavecap.fit.fidelity import captioned, family_masks, fidelity, luminance_correlation, structure_ceiling

C = 16
TWILL = np.array([[1, 1, 0], [0, 1, 1], [1, 0, 1]], np.uint8)
RED, BLUE = np.array([0.6, 0.08, 0.05]), np.array([0.05, 0.1, 0.5])


def _canvas(pattern, warp, weft):
    """A repeat: each cell the colour of its top yarn, with its yarn's stripes (warps run down,
    wefts across) and dark gaps at the cell edges."""
    n_e, n_a = pattern.shape
    img = np.zeros((n_e * C, n_a * C, 3))
    yy, xx = np.mgrid[0:C, 0:C]
    edge = np.minimum(np.minimum(yy, C - 1 - yy), np.minimum(xx, C - 1 - xx))
    for i in range(n_e):
        for j in range(n_a):
            weft_top = pattern[i, j] == 1
            stripes = 0.8 + 0.2 * np.cos(2 * np.pi * (yy if weft_top else xx) / 4.0)
            cell = (weft if weft_top else warp)[None, None] * stripes[..., None]
            cell = np.where((edge < 1)[..., None], 0.02, cell)
            img[i * C:(i + 1) * C, j * C:(j + 1) * C] = cell
    return img


def test_a_photo_against_itself_is_perfect():
    photo = _canvas(TWILL, RED, BLUE)
    f = fidelity(photo, photo, TWILL)
    assert abs(f.sharpness - 1) < 1e-12 and abs(f.structure - 1) < 1e-12
    assert f.delta_e["warp"] < 1e-6 and f.delta_e["weft"] < 1e-6


def test_the_share_of_each_familys_centres_the_camera_clipped():
    """The weft a stop brighter: its stripes' crests pass the white and clip, the red warp does
    not; the figure counts the centres of the weft's cells at the white (its colour is then a
    lower bound), on the repeat as shot. With no value above 1 the white is 1; a
    high-dynamic-range repeat (values above 1) clips nowhere."""
    photo = _canvas(TWILL, RED, BLUE)
    bright = np.minimum(_canvas(TWILL, RED, 2.5 * BLUE), 1.0)
    masks = family_masks(TWILL, bright.shape[:2])
    expected = float(np.any(bright >= 0.98, axis=-1)[masks["weft"]].mean())
    assert 0.2 < expected < 0.8  # the stripes' crests, not whole cells
    f = fidelity(photo, photo, TWILL, shot=bright)
    assert f.clipped["warp"] == 0.0 and abs(f.clipped["weft"] - expected) < 1e-12
    assert fidelity(photo, photo, TWILL).clipped == {"warp": 0.0, "weft": 0.0}
    assert fidelity(photo, photo, TWILL, shot=2.5 * photo + 1.0).clipped == {"warp": 0.0, "weft": 0.0}
    assert f.to_json()["clipped"]["weft"] == round(expected, 4)


def test_a_blurred_copy_scores_low_sharpness():
    photo = _canvas(TWILL, RED, BLUE)
    blurred = gaussian_filter(photo, (C / 6, C / 6, 0), mode="wrap")
    f = fidelity(photo, blurred, TWILL)
    assert f.sharpness < 0.1, f.sharpness
    # the colours are still right: only sharpness (and structure, less) tells a blur
    assert max(f.delta_e.values()) < 3 and 0.5 < f.structure < 0.8
    # the energy falls fast with σ: the gaps and the yarns' stripes are a few px wide
    light = fidelity(photo, gaussian_filter(photo, (0.5, 0.5, 0), mode="wrap"), TWILL)
    assert 0.5 < light.sharpness < 0.7 and light.structure > 0.98


def test_swapped_colours_score_a_high_colour_difference():
    photo = _canvas(TWILL, RED, BLUE)
    swapped = _canvas(TWILL, BLUE, RED)
    f = fidelity(photo, swapped, TWILL)
    assert min(f.delta_e.values()) > 40, f.delta_e
    # a uniform grey haze of the right mean: colours far off, no structure
    haze = np.broadcast_to(photo.mean(axis=(0, 1)), photo.shape)
    g = fidelity(photo, haze, TWILL)
    assert min(g.delta_e.values()) > 10 and g.sharpness == 0


def test_family_masks_follow_the_pattern():
    m = family_masks(TWILL, (3 * C, 3 * C), centre_share=0.5)
    assert not np.any(m["warp"] & m["weft"])
    # the centre of cell (0, 2) (warp on top) and of cell (0, 0) (weft on top)
    assert m["warp"][C // 2, 2 * C + C // 2] and m["weft"][C // 2, C // 2]
    assert m["warp"].sum() == 3 * (C // 2) ** 2 and m["weft"].sum() == 6 * (C // 2) ** 2


def test_a_family_the_pattern_never_shows_is_nan_not_an_error():
    p = np.ones((2, 2), np.uint8)
    photo = _canvas(p, RED, BLUE)
    f = fidelity(photo, photo, p)
    assert np.isnan(f.delta_e["warp"]) and f.to_json()["delta_e"]["warp"] is None
    assert np.isfinite(f.delta_e["weft"])


def test_black_and_nan_free():
    black = np.zeros((2 * C, 2 * C, 3))
    f = fidelity(black, black, np.array([[1, 0], [0, 1]]))
    assert np.isnan(f.sharpness) and f.to_json()["sharpness"] is None
    assert f.delta_e["warp"] == 0


def test_caption_strip_below_the_image():
    img = np.full((40, 300, 3), 0.5, np.float32)
    out = captioned(img, "sharpness 0.91  dE2000 warp 2.1 weft 3.4  structure 0.95")
    assert out.shape == (62, 300, 3) and np.all(out[:40] == img)
    assert out[40:].min() < 0.2 and out[40:].max() > 0.9  # dark text on white


def test_more_faithful_takes_the_right_colours_but_not_at_the_cost_of_a_blur():
    """A render whose colours are averaged (a third of the way to the grey mean) against one
    with the photo's colours: the latter is more faithful. The photo's colours on a blurred
    canvas are not: the sharpness lost outweighs them. A capture is never more faithful than
    itself, and one whose colours only move within a ΔE of 1 is not either."""
    from weavecap.fit.fidelity import more_faithful

    bounds = dict(min_sharpness=0.8, max_delta_e=10.0)
    photo = _canvas(TWILL, RED, BLUE)
    grey = (RED + BLUE) / 2
    muted = fidelity(photo, _canvas(TWILL, RED + (grey - RED) / 3, BLUE + (grey - BLUE) / 3), TWILL)
    right = fidelity(photo, photo, TWILL)
    blurred = fidelity(photo, gaussian_filter(photo, (1.0, 1.0, 0), mode="wrap"), TWILL)
    assert min(muted.delta_e.values()) > 5
    assert more_faithful(right, muted, **bounds)
    assert not more_faithful(muted, right, **bounds)
    assert not more_faithful(blurred, muted, **bounds)
    assert not more_faithful(muted, muted, **bounds)
    nearly = fidelity(photo, _canvas(TWILL, RED * 1.01, BLUE * 1.01), TWILL)
    assert not more_faithful(right, nearly, **bounds)


def test_a_render_made_faithful_is_more_faithful_though_sharper_than_the_photo():
    """Colours 60 % of the way to grey (both families beyond ΔE 10) against the photo's colours
    on an over-sharpened canvas (1.3 times the photo's gradient energy): the second is faithful
    and the first is not, and its structure is closer, so it is taken, though its sharpness is
    further from the photo's. Blurred below the sharpness bound, the photo's colours are not
    taken."""
    from weavecap.fit.fidelity import Fidelity, faithful_figures, more_faithful

    bounds = dict(min_sharpness=0.8, max_delta_e=10.0)
    photo = _canvas(TWILL, RED, BLUE)
    grey = (RED + BLUE) / 2
    far = fidelity(photo, _canvas(TWILL, RED + (grey - RED) * 0.6, BLUE + (grey - BLUE) * 0.6), TWILL)
    crisp = fidelity(photo, np.clip(photo + 0.3 * (photo - gaussian_filter(photo, (1, 1, 0), mode="wrap")), 0, 1),
                     TWILL)
    blurred = fidelity(photo, gaussian_filter(photo, (2.5, 2.5, 0), mode="wrap"), TWILL)
    assert min(far.delta_e.values()) > 10 and 1.2 < crisp.sharpness < 1.5 and blurred.sharpness < 0.8
    assert not faithful_figures(far.sharpness, far.delta_e, **bounds)
    assert faithful_figures(crisp.sharpness, crisp.delta_e, **bounds)
    assert abs(np.log(crisp.sharpness)) > abs(np.log(far.sharpness)) + 0.05  # further off, yet taken
    assert more_faithful(crisp, far, **bounds)
    assert not more_faithful(far, crisp, **bounds)
    assert not more_faithful(blurred, far, **bounds)
    # the measured figures: the real satin W108's match is taken; the independent twill 3/1's,
    # colours matched on cells a whole cell off the photo's yarns, its structure no higher, is not
    w108 = Fidelity(sharpness=1.019, delta_e={"warp": 10.85, "weft": 6.18}, structure=0.2025, lab={})
    assert more_faithful(Fidelity(1.345, {"warp": 0.02, "weft": 0.03}, 0.3185, {}), w108, **bounds)
    twill = Fidelity(sharpness=0.923, delta_e={"warp": 13.31, "weft": 2.08}, structure=0.464, lab={})
    assert not more_faithful(Fidelity(1.197, {"warp": 2.86, "weft": 0.0}, 0.45, {}), twill, **bounds)
    assert faithful_figures(0.9, {"warp": 3.0, "weft": None}, **bounds)  # a family never shown is not judged
    assert not faithful_figures(float("nan"), {"warp": 3.0}, **bounds)


def test_rendered_family_colours_follow_each_familys_own_colours():
    """The exposure check's measure (:func:`weavecap.fit.fidelity.rendered_family_lab`): a
    family whose body colours are halved renders darker, the other family stays as it was,
    and the same fabric renders the same colours."""
    from pathlib import Path

    from skimage.color import deltaE_ciede2000

    from weavecap import params
    from weavecap.fit.fidelity import rendered_family_lab

    fabric = params.load(Path(__file__).resolve().parents[2] / "fixtures" / "params" / "twill_2_1.json")
    base = rendered_family_lab(fabric, cell_px=12)
    assert all(np.isfinite(base[f]).all() for f in ("warp", "weft"))
    assert all(np.allclose(base[f], rendered_family_lab(fabric, cell_px=12)[f]) for f in ("warp", "weft"))
    keys = ("warp.body_reflection", "warp.body_subsurface")
    darker = rendered_family_lab(fabric.replace({k: tuple(0.5 * np.asarray(fabric.get(k))) for k in keys}), cell_px=12)
    assert darker["warp"][0] < base["warp"][0] - 2.5  # measured 3.4 (the highlight stays)
    assert deltaE_ciede2000(darker["weft"], base["weft"]) < 1.0


def test_the_pixel_figure_scores_a_colour_swapped_fit_badly_where_the_family_mean_does_not():
    """A warp striped red, red, navy, navy (on a twill 2/1: the warp tops a third of the cells)
    against a fit with the stripes swapped (navy where red is): every family's mean colour is
    the same, so the family ΔE is 0, but every warp pixel is in the other colour."""
    from pathlib import Path

    from weavecap import params
    from weavecap.fit.fidelity import pixel_fidelity
    from weavecap.model.render import render_numpy
    from weavecap.model.scene import View, build_scene

    base = params.load(Path(__file__).resolve().parents[2] / "fixtures" / "params" / "twill_2_1.json")
    red, blue = (0.55, 0.06, 0.05), (0.06, 0.08, 0.3)

    def striped(first, second):
        order = params.ThreadColours(palette=(params.PaletteEntry(first, first), params.PaletteEntry(second, second)),
                                     sequence=(0, 0, 1, 1))
        return base.with_threads(params.Threads(warp=order))

    tiles = (4, 4)  # 12 x 12 yarns: three stripe repeats
    photo, swapped = (render_numpy(build_scene(f, View(tiles=tiles, size=12 * C, spp=4)))
                      for f in (striped(red, blue), striped(blue, red)))
    pattern = np.tile(base.pattern, tiles)
    family = fidelity(photo, swapped, pattern)
    assert max(family.delta_e.values()) < 1.0, family.delta_e
    pixels = pixel_fidelity(photo, swapped, C)
    assert pixels.colour_p90 > 12, pixels  # beyond the 12 a faithful capture keeps (measured: 15.2)
    itself = pixel_fidelity(photo, photo, C)
    assert itself.colour_p90 < 1e-6 and abs(itself.sharpness - 1) < 1e-9 and abs(itself.structure - 1) < 1e-9


def test_equal_lightness_sees_hue_and_chroma_not_exposure():
    """A colour two stops darker is the same colour at equal lightness; the same lightness in
    another hue is not; black or NaN gives NaN, not an error."""
    from weavecap.estimate.colour import linear_to_lab
    from weavecap.fit.fidelity import at_equal_lightness

    orange = np.array([0.6, 0.25, 0.08])
    assert at_equal_lightness(linear_to_lab(orange), linear_to_lab(orange / 4)) < 0.05
    assert at_equal_lightness(linear_to_lab(orange), linear_to_lab(4 * orange)) < 0.05  # above white too
    grey = np.full(3, orange @ np.array([0.2126, 0.7152, 0.0722]))
    assert at_equal_lightness(linear_to_lab(orange), linear_to_lab(grey)) > 20
    assert np.isnan(at_equal_lightness(linear_to_lab(orange), [np.nan, 0, 0]))
    assert np.isfinite(at_equal_lightness(linear_to_lab(orange), linear_to_lab(np.zeros(3))))


def test_a_colour_the_light_took_is_seen_under_a_neutral_light():
    """The photo of an orange fabric and two captures that render it exactly under their fitted
    light: the fabric's own orange (ΔE 0 at equal lightness under a neutral light), and a grey
    fabric under an orange light (what a coloured gain gave) — the family ΔE the fit sees is 0
    for both, the neutral-light figure tells them apart."""
    from pathlib import Path

    from weavecap import params
    from weavecap.fit.fidelity import neutral_light_delta_e, rendered_family_lab

    base = params.load(Path(__file__).resolve().parents[2] / "fixtures" / "params" / "plain.json")
    orange, grey = (0.7, 0.3, 0.1), (0.4, 0.4, 0.4)
    right = base.replace({f"{f}.body_{t}": orange for f in ("warp", "weft") for t in ("reflection", "subsurface")})
    cast = base.replace({f"{f}.body_{t}": grey for f in ("warp", "weft") for t in ("reflection", "subsurface")})
    photo = {f: {"photo": lab} for f, lab in rendered_family_lab(right).items()}
    good, bad = neutral_light_delta_e(right, photo), neutral_light_delta_e(cast, photo)
    assert max(good.values()) < 0.05, good
    assert min(bad.values()) > 10, bad  # beyond a faithful capture's ΔE 10 (measured 11.8: the
    # fixture's white highlights are in both)


def test_the_structure_ceiling_is_the_share_of_the_photo_that_repeats():
    """A photo of 6 × 5 repeats of a 2 × 3 weave at 8 px a cell: a periodic pattern of variance
    s² plus an irregularity of variance n². No render repeating with the weave correlates with
    it better than √(s² / (s² + n²)) — its own mean over the repeats comes closest — and the
    ceiling says so; a periodic photo's is 1, pure noise's about 0 (with 2 views of a cell the
    in-sample mean alone would claim 0.71)."""
    c, repeat, times = 8, (2, 3), (6, 5)
    rng = np.random.default_rng(0)
    tile = rng.standard_normal((repeat[0] * c, repeat[1] * c))
    periodic = np.tile(tile, times)
    for n in (0.0, 0.5, 1.0, 2.0):
        photo = (0.5 + 0.05 * (periodic + n * rng.standard_normal(periodic.shape)))[..., None].repeat(3, axis=2)
        truth = 1.0 / np.sqrt(1.0 + n * n)
        ceiling = structure_ceiling(photo, c, repeat)
        assert ceiling == pytest.approx(truth, abs=0.03), (n, ceiling, truth)
        mean = np.tile(photo.reshape(times[0], repeat[0] * c, times[1], repeat[1] * c, 3).mean(axis=(0, 2)),
                       (*times, 1))
        assert luminance_correlation(photo, mean) <= ceiling + 0.05
    noise = 0.5 + 0.05 * rng.standard_normal((2 * repeat[0] * c, 2 * repeat[1] * c))[..., None].repeat(3, axis=2)
    assert structure_ceiling(noise, c, repeat) < 0.25
    assert np.isnan(structure_ceiling(noise[:c, :c], c, repeat))  # no cell seen twice
