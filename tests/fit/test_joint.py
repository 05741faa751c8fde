"""The joint fit (§6.1–6.2) on synthetic repeats with a known answer, and its range barrier."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from weavecap import params
from weavecap.fit.config import PRESETS, cell_px_for
from weavecap.fit.joint import barrier, fit
from weavecap.model.render import render_numpy
from weavecap.model.scene import View, build_scene
from weavecap.params import CONTINUOUS_KEYS, FIT_RANGES

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "params"


def canvas_of(fabric: params.Fabric, c: int) -> np.ndarray:
    """A photo's cell canvas, as the forward model draws it (8 spp: smooth edges)."""
    n_e, n_a = fabric.shape
    return render_numpy(build_scene(fabric, View(tiles=(1, 1), size=c * max(n_e, n_a), spp=8)))


def perturbed(truth: params.Fabric, rng: np.random.Generator) -> params.Fabric:
    """A start like a pre-estimate's: one cell wrong, colours ±0.1 off, the rest mid-range."""
    values = {}
    for key in CONTINUOUS_KEYS:
        lo, hi = FIT_RANGES[key]
        v = truth.get(key)
        if key.endswith(("body_reflection", "body_subsurface")):
            values[key] = tuple(np.clip(np.asarray(v) + rng.uniform(-0.1, 0.1, 3), 0, 1))
        else:
            values[key] = tuple([0.5 * (lo + hi)] * 3) if isinstance(v, tuple) else 0.5 * (lo + hi)
    pattern = truth.pattern.copy()
    pattern[0, 0] ^= 1
    return truth.replace({**values, "pattern": pattern, "plies": 4, "fibers": 35})


def test_draft_fit_recovers_a_known_pattern_radii_and_colours_seen():
    truth = params.load(FIXTURES / "custom_4x6.json")
    config = PRESETS["draft"]
    target = canvas_of(truth, cell_px_for(config, truth.shape))
    start = perturbed(truth, np.random.default_rng(0))
    result = fit(target, start, config=config, seed=0)
    assert np.array_equal(result.fabric.pattern, truth.pattern)
    assert result.loss < 0.1 * result.history[0]
    assert 10 * np.log10(1 / result.loss) > 28.0
    for key in ("warp.radius", "weft.radius"):
        assert abs(result.fabric.get(key) - truth.get(key)) <= 0.5, key
    # the colours the photo shows: mean of the cells where the warp, and where the weft, is on top
    c = cell_px_for(config, truth.shape)
    fitted = canvas_of(result.fabric, c)
    for on_top in (0, 1):
        mask = np.kron(truth.pattern == on_top, np.ones((c, c), bool))
        assert np.abs(fitted[mask].mean(axis=0) - target[mask].mean(axis=0)).max() < 0.03


def test_same_seed_same_fit():
    truth = params.load(FIXTURES / "plain.json")
    config = PRESETS["draft"].with_(iterations=12)
    target = canvas_of(truth, cell_px_for(config, truth.shape))
    start = perturbed(truth, np.random.default_rng(1))
    a, b = fit(target, start, config=config, seed=3), fit(target, start, config=config, seed=3)
    assert a.history == b.history and a.fabric == b.fabric


def test_values_stay_in_range_when_the_photo_pulls_beyond_it():
    """A target brighter than any fabric can be drives colours and reflectance to their
    upper bounds; the barrier and clamping keep every value inside Table 1 (the rig's gain,
    which could explain any brightness, held at 1)."""
    truth = params.load(FIXTURES / "plain.json")
    config = PRESETS["draft"].with_(iterations=15, learning_rate=0.3)
    c = cell_px_for(config, truth.shape)
    target = np.full((2 * c, 2 * c, 3), 5.0, dtype=np.float32)
    result = fit(target, truth, config=config, seed=0, fixed=frozenset({"light.gain"}))
    for key in CONTINUOUS_KEYS:
        lo, hi = FIT_RANGES[key]
        v = np.asarray(result.fabric.get(key), dtype=np.float64)
        assert np.all((v >= lo) & (v <= hi)), (key, v)
    assert np.allclose(result.fabric.warp.body_reflection, 1.0)


def test_barrier_is_zero_inside_and_pushes_back_outside():
    lo, hi = np.array([0.0, 1.4]), np.array([1.0, 1.6])
    value, grad = barrier(np.array([0.5, 1.5]), lo, hi, 0.01)
    assert value == 0 and not grad.any()
    value, grad = barrier(np.array([1.5, 1.2]), lo, hi, 0.01)
    assert value == pytest.approx(0.01 * (0.25 + 0.04))
    assert grad[0] > 0 and grad[1] < 0  # a step against the gradient moves back into range


def test_fixed_pattern_is_never_changed():
    truth = params.load(FIXTURES / "twill_2_1.json")
    config = PRESETS["draft"].with_(iterations=10, anneal_every=1, pattern_sweeps=(0.1, 0.5))
    target = canvas_of(truth.replace({"pattern": np.roll(truth.pattern, 1, axis=1)}), cell_px_for(config, truth.shape))
    result = fit(target, truth, config=config, fixed=frozenset({"pattern"}))
    assert np.array_equal(result.fabric.pattern, truth.pattern)
    assert "pattern" not in result.moves


@pytest.mark.parametrize("mode", ["search", "anneal", "gradient"])
def test_every_radius_mode_moves_a_wrong_radius_towards_the_truth(mode):
    truth = params.load(FIXTURES / "plain.json")
    config = PRESETS["draft"].with_(iterations=8, anneal_every=1, radius_every=1, learning_rate=0.05)
    target = canvas_of(truth, cell_px_for(config, truth.shape))
    start = truth.replace({"warp.radius": truth.warp.radius - 1.0, "weft.radius": truth.weft.radius - 1.0})
    result = fit(target, start, config=config, radius_mode=mode, fixed=frozenset({"pattern", "plies", "fibers"}))
    moved = [abs(result.fabric.get(k) - truth.get(k)) < 1.0 for k in ("warp.radius", "weft.radius")]
    assert any(moved), result.moves


@pytest.mark.parametrize("fixture", ["twill_2_1.json", "plain.json"])
def test_plies_scan_finds_the_true_count(fixture):
    from weavecap.fit.joint import scan_plies
    from weavecap.model.render import blurred_mse

    truth = params.load(FIXTURES / fixture).replace({"plies": 5, "shadowing.ply": 0.8})
    c = 16
    target = canvas_of(truth, c)
    fs = build_scene(truth.replace({"plies": 2}), View(tiles=(1, 1), size=c * max(truth.shape), spp=8))
    out = scan_plies(fs, lambda: blurred_mse(render_numpy(fs), target))
    assert fs.to_fabric().plies == 5 and {k: out[k] for k in ("renders", "changed")} == {"renders": 6, "changed": 1}
    assert blurred_mse(render_numpy(fs), target) < 1e-6
    assert out["range"] > 0.05  # strong grooves: the photo tells the counts apart


def test_the_fit_scans_plies_only_when_they_are_free():
    truth = params.load(FIXTURES / "plain.json")
    config = PRESETS["draft"].with_(iterations=6, plies_scans=(0.5,))
    target = canvas_of(truth, cell_px_for(config, truth.shape))
    free = fit(target, truth.replace({"plies": 1}), config=config, fixed=frozenset({"pattern"}))
    held = fit(target, truth.replace({"plies": 1}), config=config, fixed=frozenset({"pattern", "plies"}))
    assert free.moves["plies_scan"]["scans"] == 1 and "plies_scan" not in held.moves
    assert held.fabric.plies == 1


@pytest.mark.parametrize("fixture", ["twill_2_1.json", "custom_4x6.json"])
def test_colour_solve_recovers_known_body_colours_from_black(fixture):
    from weavecap.fit.joint import BODY_COLOUR_KEYS, solve_colours
    from weavecap.model.render import blurred_mse

    truth = params.load(FIXTURES / fixture).replace({"specular.coefficient": 0.5})
    c = 16
    target = canvas_of(truth, c)
    black = {k: (0.0, 0.0, 0.0) for k in BODY_COLOUR_KEYS}
    fs = build_scene(truth.replace(black), View(tiles=(1, 1), size=c * max(truth.shape), spp=8))
    before = blurred_mse(render_numpy(fs), target)
    out = solve_colours(fs, target, lambda: blurred_mse(render_numpy(fs), target), spp=8, blur_px=0.0)
    assert out == {"renders": 6, "changed": 1}
    assert blurred_mse(render_numpy(fs), target) < 1e-3 * before
    # the products the render sees, m_r R^B and (1 - m_r) S^B, are the truth's (m_r is the truth's here)
    for key in BODY_COLOUR_KEYS:
        assert np.abs(np.subtract(fs.to_fabric().get(key), truth.get(key))).max() < 0.03, key


def test_colour_solve_keeps_the_colours_when_it_cannot_do_better():
    from weavecap.fit.joint import BODY_COLOUR_KEYS, solve_colours
    from weavecap.model.render import blurred_mse

    truth = params.load(FIXTURES / "plain.json")
    c = 16
    fs = build_scene(truth, View(tiles=(1, 1), size=c * max(truth.shape), spp=8))
    for target in (np.zeros_like(canvas_of(truth, c)), np.ones_like(canvas_of(truth, c))):
        start = fs.to_fabric()
        loss = blurred_mse(render_numpy(fs), target)
        out = solve_colours(fs, target, lambda: blurred_mse(render_numpy(fs), target), spp=8, blur_px=1.0)
        after = fs.to_fabric()
        assert blurred_mse(render_numpy(fs), target) <= loss and np.isfinite(loss)
        if not out["changed"]:  # an all-white target is all clipped: nothing to solve from
            for key in BODY_COLOUR_KEYS:
                assert after.get(key) == pytest.approx(start.get(key)), key


def test_the_fit_solves_colours_that_gradient_steps_left_black():
    truth = params.load(FIXTURES / "twill_2_1.json")
    config = PRESETS["draft"].with_(iterations=4, colour_solves=(0.25,), pattern_moves=False, plies_scans=(),
                                    family_colours=False)
    target = canvas_of(truth, cell_px_for(config, truth.shape))
    black = truth.replace({k: (0.0, 0.0, 0.0) for k in ("warp.body_reflection", "weft.body_reflection")})
    solved = fit(target, black, config=config, fixed=frozenset({"pattern"}))
    plain = fit(target, black, config=config.with_(colour_solves=()), fixed=frozenset({"pattern"}))
    assert {k: solved.moves["colour_solve"][k] for k in ("solves", "changed", "renders")} == \
        {"solves": 1, "changed": 1, "renders": 6}
    assert "colour_solve" not in plain.moves
    assert solved.loss < 0.5 * plain.loss


def test_the_gain_a_photo_too_bright_for_the_rig_needs_is_the_one_its_colours_ask():
    """Colours (0.9, 0.6) photographed 2.5 times brighter than the rig lights them would need
    colours 2.25 and 1.5: the smallest gain that brings every colour within [0, 1] is 2.25 / 2.5
    of the photo's, i.e. a factor 2.25 on a gain of 1 (bisection: within 1%), the same as
    solving over every pixel."""
    from scipy.optimize import lsq_linear

    from weavecap.fit.joint import _range_scale

    rng = np.random.default_rng(4)
    a = rng.random((5000, 2))
    d = 0.05 * rng.random(5000)
    systems = [(a, d, 2.5 * a @ np.array([0.9, 0.6]) + d)] * 2
    lo, hi, k = np.zeros(2), np.ones(2), np.ones(2)
    scale = _range_scale(systems, k, lo, hi)
    assert 2.25 * 0.99 <= scale <= 2.25 * 1.01

    def per_pixel(f: float, upper) -> float:  # the loss over every pixel, as the problem reads
        return sum(float(np.sum((f * a @ lsq_linear(f * a, t - d, bounds=(lo, upper)).x - (t - d)) ** 2))
                   for a, d, t in systems)

    good = per_pixel(1.0, np.inf) * 1.001 + 1e-15
    assert per_pixel(scale, hi) <= good < per_pixel(scale * 0.99, hi)


def test_colour_solve_recovers_a_known_exposure_and_white_balance():
    """A photo taken with a gain per channel (exposure × white balance): the back light seen
    through the gaps does not depend on the fabric's colours, so it fixes the gain, and the
    colours come out as the fabric's own."""
    from weavecap.fit.joint import BODY_COLOUR_KEYS, solve_colours
    from weavecap.model.render import blurred_mse

    truth = params.load(FIXTURES / "twill_2_1.json").replace({
        "warp.body_reflection": (0.7, 0.3, 0.2), "warp.body_subsurface": (0.6, 0.3, 0.2),
        "weft.body_reflection": (0.2, 0.4, 0.6), "weft.body_subsurface": (0.2, 0.4, 0.5)})
    c, known = 16, (1.6, 1.25, 0.85)
    fs = build_scene(truth, View(tiles=(1, 1), size=c * max(truth.shape), spp=8))
    fs.rig = fs.rig.with_gain(known)
    target = render_numpy(fs)  # HDR: nothing clipped
    fs.rig = fs.rig.with_gain(1.0)
    for k in BODY_COLOUR_KEYS:
        fs.set(k, (0.0, 0.0, 0.0))
    out = solve_colours(fs, target, lambda: blurred_mse(render_numpy(fs), target), spp=8, blur_px=0.0, gain=True)
    assert out["changed"] == 1 and out["gain_determined"] == [True, True, True]
    np.testing.assert_allclose(fs.rig.gain, known, rtol=0.02)
    for key in BODY_COLOUR_KEYS:
        np.testing.assert_allclose(fs.to_fabric().get(key), truth.get(key), atol=0.02, err_msg=key)


def test_colour_solve_raises_a_gain_the_photo_does_not_fix_just_into_range():
    """A matte, front-lit fabric 2.5× brighter than the rig's render of it: nothing in the
    photo but the colours moves with the gain, so the gain is the smallest that keeps every
    colour within [0, 1] (2.5 × 0.8 = 2.0: the brightest colour at 1), and no colour is left
    at the clamp below it — the render matches the photo."""
    from weavecap.fit.joint import BODY_COLOUR_KEYS, solve_colours
    from weavecap.model.render import blurred_mse

    matte = {"specular.reflection": (0.0, 0.0, 0.0), "specular.transmission": (0.0, 0.0, 0.0),
             "specular.transmission_exit": (0.0, 0.0, 0.0)}
    truth = params.load(FIXTURES / "twill_2_1.json").replace({
        **matte, "warp.body_reflection": (0.8, 0.5, 0.2), "warp.body_subsurface": (0.4, 0.3, 0.2),
        "weft.body_reflection": (0.3, 0.6, 0.3), "weft.body_subsurface": (0.2, 0.2, 0.2)})
    from weavecap.model.scene import light_rig

    c = 16
    dark_room = light_rig("front")  # nothing seen through the gaps
    fs = build_scene(truth, View(tiles=(1, 1), size=c * max(truth.shape), spp=8), light=dark_room)
    fs.rig = fs.rig.with_gain(2.5)
    target = render_numpy(fs)
    fs.rig = fs.rig.with_gain(1.0)
    for k in BODY_COLOUR_KEYS:
        fs.set(k, (0.5, 0.5, 0.5))
    out = solve_colours(fs, target, lambda: blurred_mse(render_numpy(fs), target), spp=8, blur_px=0.0, gain=True)
    assert out["changed"] == 1 and out["gain_determined"] == [False, False, False]
    np.testing.assert_allclose(fs.rig.gain, 2.0, rtol=0.02)
    assert blurred_mse(render_numpy(fs), target) < 1e-5
    np.testing.assert_allclose(fs.to_fabric().warp.body_reflection, (1.0, 0.625, 0.25), atol=0.02)

def test_the_room_seen_through_a_front_lit_fabric_does_not_colour_the_light():
    """A front-lit fabric photographed at a neutral gain of 2, the room behind its gaps orange
    (a wall, the fibres beneath a dense cloth): the ``front`` rig's backdrop is no reference,
    so the gain stays neutral and each yarn keeps its tint. Read as the back light, the gaps
    made the light orange (gain 6.0 / 2.0 / 0.6) and both yarns blue (0.17 / 0.45 / 1.0)
    to make up."""
    from dataclasses import replace

    from weavecap.fit.joint import BODY_COLOUR_KEYS, solve_colours
    from weavecap.model.render import blurred_mse
    from weavecap.model.scene import light_rig

    matte = {"specular.reflection": (0.0, 0.0, 0.0), "specular.transmission": (0.0, 0.0, 0.0),
             "specular.transmission_exit": (0.0, 0.0, 0.0)}
    truth = params.load(FIXTURES / "plain.json").replace({
        **matte, "warp.radius": 3.0, "weft.radius": 3.0,
        "warp.body_reflection": (0.5, 0.45, 0.4), "warp.body_subsurface": (0.3, 0.3, 0.3),
        "weft.body_reflection": (0.4, 0.45, 0.5), "weft.body_subsurface": (0.3, 0.3, 0.3)})
    c, front = 16, light_rig("front")
    assert not front.backdrop_is_reference and light_rig("both").backdrop_is_reference

    def shot(rig):
        fs = build_scene(truth, View(tiles=(2, 2), size=2 * c * max(truth.shape), spp=8), light=rig.with_gain(2.0))
        return render_numpy(fs)

    no_room = shot(front)  # the rig's own room: dark
    target = no_room + (shot(replace(front, backdrop=0.05)) - no_room) * np.array([3.0, 1.0, 0.3])  # lit, orange
    fs = build_scene(truth, View(tiles=(2, 2), size=2 * c * max(truth.shape), spp=8), light=front)
    for k in BODY_COLOUR_KEYS:
        fs.set(k, (0.5, 0.5, 0.5))
    out = solve_colours(fs, target, lambda: blurred_mse(render_numpy(fs), target), spp=8, blur_px=0.0, gain=True)
    assert out["gain_determined"] == [False, False, False]
    gain = np.asarray(fs.rig.gain)
    assert gain.max() / gain.min() < 1.001
    for family in ("warp", "weft"):  # each yarn's own tint survives: red over blue, and the reverse
        r, _, b = fs.to_fabric().get(f"{family}.body_reflection")
        assert (r > b) == (family == "warp"), (family, r, b)


def test_family_colours_raise_the_gain_without_brightening_the_highlights():
    """A shiny twill photographed at twice the rig's exposure, its highlights half the
    start's: the family colours ask for more than the body colours' range, so the gain rises
    — and the highlights' colours come down by as much (gain × highlight colour stays the
    start's, which already matched the photo), the bodies are solved again at the new gain,
    and the render matches the photo (the loss 10⁴ times lower). Left as they were, the
    highlights came out 2.8× too bright, the bodies went black to make up, and the loss rose."""
    from weavecap.fit.joint import SPECULAR_COLOUR_KEYS, match_family_colours
    from weavecap.model.render import blurred_mse
    from weavecap.model.scene import light_rig

    shine = (0.5, 0.6, 0.7)
    fabric = params.load(FIXTURES / "twill_2_1.json").replace({
        **{k: shine for k in SPECULAR_COLOUR_KEYS},
        "warp.body_reflection": (0.8, 0.5, 0.2), "warp.body_subsurface": (0.8, 0.5, 0.2),
        "weft.body_reflection": (0.3, 0.6, 0.3), "weft.body_subsurface": (0.3, 0.6, 0.3)})
    photo = fabric.replace({k: tuple(0.5 * v for v in shine) for k in SPECULAR_COLOUR_KEYS})
    c = 16
    dark_room = light_rig("front")
    shot = build_scene(photo, View(tiles=(1, 1), size=c * max(photo.shape), spp=8), light=dark_room)
    shot.rig = shot.rig.with_gain(2.0)
    target = render_numpy(shot)
    fs = build_scene(fabric, View(tiles=(1, 1), size=c * max(fabric.shape), spp=8), light=dark_room)
    out = match_family_colours(fs, target, lambda: blurred_mse(render_numpy(fs), target), spp=8, blur_px=0.0,
                               gain=True)
    gain = np.asarray(fs.rig.gain)
    assert np.all(gain > 1.5)
    for k in SPECULAR_COLOUR_KEYS:
        np.testing.assert_allclose(gain * np.asarray(fs.to_fabric().get(k)), shine, rtol=1e-4, err_msg=k)
    assert out["loss_after"] < 1e-3 * out["loss_before"]
