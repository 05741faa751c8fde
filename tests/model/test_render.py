"""The forward model end to end (weavecap.model.scene + render): what a fit relies on.

Known answers: a fabric whose warp and weft have different colours must show, in every cell,
the colour of the yarn the pattern puts on top; gradients must equal finite differences; the
same seed must give the same image.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from weavecap import params
from weavecap.model.render import mse_and_gradients, render_numpy
from weavecap.model.scene import View, build_scene
from weavecap.params import FIT_RANGES

FIXTURES = sorted((Path(__file__).resolve().parents[2] / "fixtures" / "params").glob("*.json"))
RED, BLUE = (0.8, 0.1, 0.1), (0.1, 0.1, 0.8)


def two_colour(fabric: params.Fabric) -> params.Fabric:
    """The fabric with a red warp and a blue weft (every thread: no colour order)."""
    return fabric.with_threads(None).replace({"warp.body_reflection": RED, "warp.body_subsurface": RED,
                                              "weft.body_reflection": BLUE, "weft.body_subsurface": BLUE})


def cell_means(image: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """(n_e, n_a, 3) mean colour of the central 40% of each cell of a one-repeat image."""
    n_e, n_a = shape
    h, w = image.shape[:2]
    out = np.zeros((n_e, n_a, 3))
    for i in range(n_e):
        for j in range(n_a):
            y0, y1 = (i + 0.3) * h / n_e, (i + 0.7) * h / n_e
            x0, x1 = (j + 0.3) * w / n_a, (j + 0.7) * w / n_a
            out[i, j] = image[int(y0):int(np.ceil(y1)), int(x0):int(np.ceil(x1))].reshape(-1, 3).mean(axis=0)
    return out


@pytest.mark.parametrize("path", FIXTURES, ids=lambda p: p.stem)
def test_every_cell_shows_the_yarn_on_top(path):
    """The weave is visible: each cell is red where the warp is over, blue where the weft is."""
    fabric = two_colour(params.load(path))
    n_e, n_a = fabric.shape
    image = render_numpy(build_scene(fabric, View(tiles=(1, 1), size=16 * max(n_e, n_a), spp=1), light="front"))
    means = cell_means(image, fabric.shape)
    weft_on_top = means[..., 2] > means[..., 0]
    assert np.array_equal(weft_on_top, fabric.pattern.astype(bool)), (weft_on_top.astype(int), fabric.pattern)


def test_repeats_tile_exactly():
    """Two repeats side by side are the same picture twice: the geometry is periodic. (The
    procedural plies and fibres are not tied to the weave's repeat, so they are switched off.)"""
    fabric = params.load(FIXTURES[0]).replace({"shadowing.ply": 0.0, "shadowing.fiber": 0.0})
    image = render_numpy(build_scene(fabric, View(tiles=(2, 2), size=64, spp=1)))
    h, w = image.shape[:2]
    assert np.allclose(image[: h // 2], image[h // 2:], atol=2e-3)
    assert np.allclose(image[:, : w // 2], image[:, w // 2:], atol=2e-3)


def test_same_seed_same_image_other_seed_differs():
    fabric = params.load(FIXTURES[0])
    scene = build_scene(fabric, View(tiles=(1, 1), size=48, spp=4))
    a = render_numpy(scene, seed=3)
    b = render_numpy(build_scene(fabric, View(tiles=(1, 1), size=48, spp=4)), seed=3)
    c = render_numpy(scene, seed=4)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)
    assert abs(a.mean() - c.mean()) < 0.01  # only the antialiasing jitter differs


def test_a_geometry_set_back_to_what_is_built_keeps_the_scene_and_renders_alike():
    """A radius or pattern set to the value already built (a search stepping back onto its last
    trial) keeps the built scene; a real change rebuilds it, and stepping back renders as before."""
    fabric = params.load(FIXTURES[0])
    fs = build_scene(fabric, View(tiles=(1, 1), size=32, spp=2))
    before, scene = render_numpy(fs, seed=1), fs.scene
    fs.set("warp.radius", fabric.warp.radius)
    fs.set("pattern", fabric.pattern.copy())
    assert fs.scene is scene
    fs.set("warp.radius", fabric.warp.radius + 0.5)
    assert fs.scene is not scene and not np.array_equal(render_numpy(fs, seed=1), before)
    fs.set("warp.radius", fabric.warp.radius)
    assert np.array_equal(render_numpy(fs, seed=1), before)


def test_stepping_back_to_a_geometry_built_lately_reuses_it_with_the_values_set_since():
    """A radius search tries r ± δ and steps back; a flip refused is flipped back. The scene
    built for a geometry is reused (no BVH build, no geometry pass) among the last
    GEOMETRIES_KEPT, and renders what a scene built afresh renders — with any value set since."""
    from weavecap.model.scene import GEOMETRIES_KEPT

    fabric = params.load(FIXTURES[0])
    view = View(tiles=(1, 1), size=32, spp=2)
    fs = build_scene(fabric, view)
    first = fs.scene
    fs.set("warp.radius", fabric.warp.radius + 0.5)
    fs.set("warp.body_reflection", (0.9, 0.2, 0.1))  # replaced while the other geometry is built
    fs.set("warp.radius", fabric.warp.radius)
    assert fs.scene is first
    np.testing.assert_array_equal(render_numpy(fs, seed=1), render_numpy(build_scene(fs.to_fabric(), view), seed=1))
    for k in range(1, GEOMETRIES_KEPT + 1):  # as many new geometries as are kept: the first is let go
        fs.set("weft.radius", fabric.weft.radius + 0.1 * k)
    fs.set("weft.radius", fabric.weft.radius)
    assert fs.scene is not first
    np.testing.assert_array_equal(render_numpy(fs, seed=1), render_numpy(build_scene(fs.to_fabric(), view), seed=1))


def test_new_radii_render_with_the_kernels_already_compiled():
    """A capture tries hundreds of radii. The yarn heights move with each; compiled into the
    geometry pass as constants, every radius compiled a new kernel (~80 ms) and left a file in
    the kernel cache: 12 new radii, 12 compiles. Read from memory, the kernels are reused; what
    is left is Mitsuba's own pointer to each scene built, a few addresses over and over."""
    import drjit as dr

    fabric = params.load(FIXTURES[0])
    fs = build_scene(fabric, View(tiles=(1, 1), size=32, spp=2))
    render_numpy(fs)
    dr.set_flag(dr.JitFlag.KernelHistory, True)
    try:
        dr.kernel_history()  # emptied
        for k in range(12):
            fs.set("warp.radius", fabric.warp.radius + 0.05 * (k + 1))
            render_numpy(fs)
        kernels = [k for k in dr.kernel_history() if k["type"] == dr.KernelType.JIT]
    finally:
        dr.set_flag(dr.JitFlag.KernelHistory, False)
    assert len(kernels) >= 12
    assert sum(1 for k in kernels if not k["cache_hit"]) <= 8


def test_quarter_turn_turns_the_picture():
    """--rotate 90 turns the fabric counter-clockwise in the image."""
    fabric = params.load([p for p in FIXTURES if p.stem == "twill_2_1"][0])
    view = dict(tiles=(1, 1), size=48, spp=1)
    straight = render_numpy(build_scene(fabric, View(**view)))
    turned = render_numpy(build_scene(fabric, View(**view, rotate_deg=90.0)))
    assert np.abs(turned - np.rot90(straight, 1)).max() < 1e-4
    assert np.abs(turned - np.rot90(straight, -1)).mean() > 0.03


def test_light_rigs_light_the_gaps_as_described():
    """Thin yarns leave gaps: dark under a front-only rig, bright with a light behind (the
    one-lamp rig keeps the room rig's back light)."""
    fabric = params.load(FIXTURES[0]).replace({"warp.radius": 2.0, "weft.radius": 2.0})
    view = View(tiles=(1, 1), size=40, spp=1)
    front = render_numpy(build_scene(fabric, view, light="front"))
    corner = (slice(0, 2), slice(0, 2))  # between yarns: each yarn is centred in its cell
    assert front[corner].max() < 0.1
    for rig in ("back", "lamp"):
        assert render_numpy(build_scene(fabric, view, light=rig))[corner].min() > 0.5, rig


def test_the_lamp_rig_is_the_room_rig_without_its_side_lights():
    """``lamp``: the room rig's front and back lights, no light from the sides (low in the
    sky), and the ambient raised in their place; an unknown rig's error names every rig."""
    from weavecap.errors import InputError
    from weavecap.model.scene import RIGS, light_rig

    both, lamp = light_rig("both"), light_rig("lamp")
    assert set(lamp.lights) < set(both.lights)
    assert all(light.direction[2] > 0.9 or light.direction[2] < -0.9 for light in lamp.lights)
    assert lamp.ambient > both.ambient and lamp.backdrop == both.backdrop
    with pytest.raises(InputError) as err:
        light_rig("side")
    assert all(name in str(err.value) for name in RIGS)


def test_perspective_camera_sees_the_same_fabric_in_the_middle():
    fabric = params.load(FIXTURES[0])
    ortho = render_numpy(build_scene(fabric, View(tiles=(2, 2), size=64, spp=1)))
    persp = render_numpy(build_scene(fabric, View(tiles=(2, 2), size=64, spp=1, camera="perspective", fov_deg=10)))
    assert np.isfinite(persp).all()
    assert abs(persp.mean() - ortho.mean()) < 0.1 * ortho.mean()


@pytest.mark.parametrize("end", [0, 1], ids=["lower", "upper"])
def test_every_parameter_at_the_ends_of_its_range(end):
    """Renders and gradients stay finite and renders non-negative at Table 1's bounds."""
    fabric = params.load(FIXTURES[0])
    values = {}
    for key, bounds in FIT_RANGES.items():
        v = bounds[end]
        current = fabric.get(key)
        values[key] = tuple([v] * 3) if isinstance(current, tuple) else (int(v) if key in ("plies", "fibers") else v)
    fabric = fabric.replace(values)
    scene = build_scene(fabric, View(tiles=(1, 1), size=32, spp=1))
    image = render_numpy(scene)
    assert np.isfinite(image).all() and image.min() >= 0
    keys = [k for k in FIT_RANGES if k not in ("plies", "fibers")]
    _, grads, _ = mse_and_gradients(scene, np.full_like(image, 0.3), keys)
    for key, g in grads.items():
        assert np.isfinite(g).all(), key


FD_KEYS = ["specular.roughness", "specular.ior", "specular.coefficient", "body_attenuation", "shadowing.ply",
           "shadowing.fiber", "specular.roughness_exit", "specular.attenuation", "warp.body_reflection",
           "specular.transmission"]


def test_gradients_match_finite_differences():
    """d MSE / d parameter by reverse-mode AD equals a central difference, for ten parameters."""
    fabric = params.load([p for p in FIXTURES if p.stem == "twill_2_1"][0])
    scene = build_scene(fabric, View(tiles=(1, 1), size=40, spp=1))
    rng = np.random.default_rng(0)
    target = (render_numpy(scene) * 0.8 + 0.05 * rng.random((40, 40, 3))).astype(np.float32)
    _, grads, _ = mse_and_gradients(scene, target, FD_KEYS)

    def loss() -> float:
        return float(np.mean((render_numpy(scene).astype(np.float64) - target) ** 2))

    for key in FD_KEYS:
        v0 = fabric.get(key)
        channel = 0 if isinstance(v0, tuple) else None
        x0 = v0[0] if channel is not None else v0
        h = 1e-3
        ends = []
        for x in (x0 - h, x0 + h):
            scene.set(key, (x, *v0[1:]) if channel is not None else x)
            ends.append(loss())
        scene.set(key, v0)
        fd = (ends[1] - ends[0]) / (2 * h)
        ad = grads[key][0]
        assert abs(fd) > 1e-7, f"{key}: the loss should depend on it"
        assert ad == pytest.approx(fd, rel=0.03, abs=1e-7), key


def test_radius_gradient_points_towards_the_true_radius():
    fabric = params.load(FIXTURES[0])
    truth = render_numpy(build_scene(fabric, View(tiles=(1, 1), size=40, spp=1)))
    r0 = fabric.warp.radius
    for offset in (-0.5, 0.5):
        scene = build_scene(fabric.replace({"warp.radius": r0 + offset}), View(tiles=(1, 1), size=40, spp=1))
        _, grads, _ = mse_and_gradients(scene, truth, ["warp.radius"])
        assert np.sign(grads["warp.radius"][0]) == np.sign(offset)


def test_the_rig_gain_scales_every_light_and_the_backdrop_per_channel():
    """A photo's exposure and white balance (weavecap.model.scene.LightRig.gain): the render
    under a gain is that gain times the render at (1, 1, 1), gaps and yarns alike, and the
    gradients scale with it."""
    from dataclasses import replace

    from weavecap.model.scene import light_rig

    fabric = two_colour(params.load(FIXTURES[0]))
    view = View(tiles=(1, 1), size=48, spp=2)
    fs = build_scene(fabric, view, light="both")
    base = render_numpy(fs)
    gain = (2.0, 0.8, 1.3)
    fs.rig = fs.rig.with_gain(gain)
    assert np.allclose(render_numpy(fs), base * np.array(gain, np.float32), rtol=1e-5, atol=1e-7)
    target = np.clip(base * 1.5, 0, 1)
    keys = ["warp.body_reflection", "specular.roughness"]
    _, g1, _ = mse_and_gradients(replace(fs, rig=light_rig("both")), target, keys)
    _, g2, _ = mse_and_gradients(fs, target, keys)
    assert all(np.all(np.isfinite(v)) for v in list(g1.values()) + list(g2.values()))
    assert not np.allclose(g1["warp.body_reflection"], g2["warp.body_reflection"])
    with pytest.raises(Exception, match="positive"):
        fs.rig.with_gain((1.0, 0.0, 1.0))
