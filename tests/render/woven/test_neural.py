"""The shipped network where the rays are: weights, the Dr.Jit decoder, editing, energy,
extremes, and a render against the reference."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from weavecap import params
from weavecap.fixtures import path as fixture_path
from weavecap.render.surface import bake
from weavecap.bench import woven as bench
from weavecap.render.woven import infer
from weavecap.render.woven import network as net
from weavecap.render.woven import terms
from weavecap.render.woven.bsdf import NeuralSurfaceBSDF, shared_model

mi, dr = terms._backend()


def _f(a):
    return mi.Float(np.ascontiguousarray(a, dtype=np.float32))


@pytest.fixture(scope="module")
def plain():
    fabric = params.load(fixture_path("params", "plain.json"))
    return fabric, bake(fabric, texels_per_yarn=8, supersamples=2)


def test_shipped_weights_load_without_pickle_and_are_small():
    path = infer.weights_path()
    assert path.stat().st_size <= 5e6
    with np.load(path, allow_pickle=False) as z:
        assert all(z[k].dtype == np.float32 for k in z.files)
    arrays, record = infer.load_weights()
    model = infer.torch_model(arrays, record)  # a strict load: every parameter, nothing else
    assert sum(p.numel() for p in model.parameters()) == sum(a.size for a in arrays.values())
    for key in ("data", "train", "data_seconds", "train_seconds", "held_out_errors", "queries"):
        assert key in record
    # the network improves on its prefiltered guess on fabrics it never saw
    assert (record["held_out_errors"]["median_material_rel_mse"]
            < record["held_out_errors_prefilter_only"]["median_material_rel_mse"])


def test_drjit_decoder_equals_pytorch():
    arrays, record = infer.load_weights()
    model = infer.torch_model(arrays, record)
    rng = np.random.default_rng(0)
    latents = rng.normal(size=(2, net.LATENT)).astype(np.float32)
    decoder = infer.Decoder(arrays, latents)
    n = 2000
    inputs = np.zeros((n, 9), np.float32)
    inputs[:, :2] = rng.uniform(-2, 3, (n, 2))
    inputs[:, 2] = np.exp(rng.uniform(-5, 4, n))
    inputs[:10, 2] = 0.0
    d = rng.normal(size=(n, 2, 3))
    d /= np.linalg.norm(d, axis=2, keepdims=True)
    d[:, 0, 2] = np.abs(d[:, 0, 2])
    inputs[:, 3:6], inputs[:, 6:9] = d[:, 0], d[:, 1]
    features = rng.random((n, 16)).astype(np.float32)
    baseline = (rng.random((n, 14)) ** 3).astype(np.float32)
    back = rng.random(n) < 0.5
    vec = lambda k: mi.Vector3f(*(_f(inputs[:, i]) for i in range(k, k + 3)))  # noqa: E731
    got = decoder.values(_f(inputs[:, 0]), _f(inputs[:, 1]), _f(inputs[:, 2]), vec(3), vec(6),
                         [_f(features[:, k]) for k in range(16)], mi.Bool(back), [_f(baseline[:, k]) for k in range(14)])
    got = np.stack([np.array(g) for g in got], axis=-1)
    with torch.no_grad():
        t = torch.from_numpy
        z = t(latents)[t(back.astype(np.int64))]
        want = net.to_values(model.decoder(z, t(inputs), t(features), t(baseline)), t(inputs)).numpy()
    np.testing.assert_allclose(got, want, rtol=2e-4, atol=1e-6 * max(1.0, np.abs(want).max()))


def _query(bsdf, n=256, seed=0, size=None):
    rng = np.random.default_rng(seed)
    s, t = rng.random(n), rng.random(n)
    sizes = np.exp(rng.uniform(-3, 2, n)) if size is None else np.full(n, size)
    wi = np.c_[rng.normal(size=(n, 2)) * 0.3, np.ones(n)]
    wo = np.c_[rng.normal(size=(n, 2)) * 0.5, np.where(rng.random(n) < 0.5, 1.0, -1.0)]
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    vec = lambda a: mi.Vector3f(*(_f(a[:, k]) for k in range(3)))  # noqa: E731
    return np.array(bsdf.query(_f(s), _f(t), _f(sizes), vec(wi), vec(wo), mi.Bool(np.zeros(n, dtype=bool)))).T


def test_thread_colours_weigh_the_body_channels_outside_the_network(plain):
    """A colour order whose every thread wears the family's own colours renders as the family
    colours do (the threads' colours multiply unit-coloured body coefficients: exact); a warp
    order red, blue: a point on warp 0's float is red-dominated, one on warp 1's blue, and a
    footprint over both repeats of the order sees their mean (the order box-filtered)."""
    fabric, maps = plain
    own = params.PaletteEntry(fabric.warp.body_reflection, fabric.warp.body_subsurface)
    same = fabric.with_threads(params.Threads(warp=params.ThreadColours(palette=(own,), sequence=(0, 0, 0))))
    base = _query(NeuralSurfaceBSDF(fabric, maps, bench.placement_of(fabric)))
    np.testing.assert_allclose(_query(NeuralSurfaceBSDF(same, maps, bench.placement_of(same))), base,
                               rtol=1e-5, atol=1e-7)
    red, blue = (0.8, 0.05, 0.05), (0.05, 0.05, 0.8)
    order = params.ThreadColours(palette=(params.PaletteEntry(red, red), params.PaletteEntry(blue, blue)),
                                 sequence=(0, 1))
    striped = fabric.with_threads(params.Threads(warp=order))
    bsdf = NeuralSurfaceBSDF(striped, maps, bench.placement_of(striped))
    n_e, n_a = fabric.shape
    up = mi.Vector3f(0.0, 0.0, 1.0)

    def at(j: int, i: int, size: float) -> np.ndarray:  # the centre of cell (i, j), seen and lit from above
        s, t = (j + 0.5) / n_a, 1.0 - (i + 0.5) / n_e
        return np.array(bsdf.query(_f([s]), _f([t]), _f([size]), up, up, mi.Bool(False))).ravel()

    warp_cells = [(i, j) for i in range(n_e) for j in range(n_a) if fabric.pattern[i, j] == 0]
    (i0, j0) = next((i, j) for i, j in warp_cells if j % 2 == 0)
    (i1, j1) = next((i, j) for i, j in warp_cells if j % 2 == 1)
    assert at(j0, i0, 0.0)[0] > 2 * at(j0, i0, 0.0)[2]  # warp 0: red
    assert at(j1, i1, 0.0)[2] > 2 * at(j1, i1, 0.0)[0]  # warp 1: blue
    wide = at(j0, i0, 4.0)  # 4 pitches: two whole repeats of the order, red and blue alike
    assert 0.6 < wide[0] / wide[2] < 1.6


def test_colours_change_without_encoding_and_roughness_re_encodes(plain, monkeypatch):
    fabric, maps = plain
    _, _, encoder = shared_model()
    calls = []
    forward = encoder.model.encoder.forward
    monkeypatch.setattr(encoder.model.encoder, "forward", lambda *a: calls.append(1) or forward(*a))
    encoder._cache.clear()
    bsdf = NeuralSurfaceBSDF(fabric, maps, bench.placement_of(fabric))
    assert len(calls) == 1
    before = _query(bsdf)
    red = dict(terms.fabric_colours(fabric), warp_reflection=(0.9, 0.1, 0.1), weft_reflection=(0.9, 0.1, 0.1),
               reflection=(0.2, 0.2, 0.2))
    bsdf.set_colours(red)
    after = _query(bsdf)
    assert len(calls) == 1  # no encoding
    assert not np.allclose(before, after)
    assert after[:, 0].sum() > 2 * after[:, 1].sum()  # it turned red
    # the same footprints and directions with the new colours, through combine(): exact
    bsdf.set_colours(terms.fabric_colours(fabric))
    np.testing.assert_allclose(_query(bsdf), before, rtol=1e-6, atol=1e-9)
    bsdf.set_fabric(fabric.replace({"specular.roughness": 0.05}))
    assert len(calls) == 2  # a roughness change re-encodes
    assert not np.allclose(_query(bsdf), before)


@pytest.mark.parametrize("name", ["plain", "random"])
def test_white_furnace(plain, name):
    """A white fabric reflects and transmits at most 1.05 of the light (hemispherical albedo
    of the network's filtered BSDF, over footprints and view directions)."""
    from weavecap.estimate.sampling import random_fabric

    fabric, maps = plain
    if name == "random":
        fabric = random_fabric(np.random.default_rng(11), np.array([[1, 1, 0], [0, 1, 1], [1, 0, 1]], np.uint8))
        maps = bake(fabric, texels_per_yarn=8, supersamples=2)
    result = bench.furnace(fabric, maps, views=4, directions=32)
    assert result["neural_max_albedo"] <= 1.05
    assert result["surface_model_max_albedo"] <= 1.0 + 1e-3


@pytest.mark.parametrize("edit", [{"specular.roughness": 0.0, "specular.roughness_exit": 0.0},
                                  {"specular.roughness": 1.0, "specular.ior": 3.0},
                                  {"specular.ior": 1.0, "specular.ior_exit": 1.0},
                                  {"warp.body_reflection": [0, 0, 0], "weft.body_reflection": [1, 1, 1],
                                   "specular.transmission": [1, 1, 1]}])
def test_finite_at_grazing_angles_and_extreme_parameters(plain, edit):
    fabric, maps = plain
    bsdf = NeuralSurfaceBSDF(fabric.replace(edit), maps, bench.placement_of(fabric))
    n = 6
    wi = np.array([[1, 0, 1e-6], [0, 1, 0], [0, 0, 1], [0.6, 0, 0.8], [1, 0, 1e-3], [0, -1, 1e-6]])
    wo = np.array([[-1, 0, 1e-6], [0, 1, -1e-6], [0, 0, -1], [1, 0, 0], [0, 0, 1], [0.3, 0.3, -0.9]])
    vec = lambda a: mi.Vector3f(*(_f(a[:, k] / np.linalg.norm(a, axis=1)) for k in range(3)))  # noqa: E731
    for size in (0.0, 1e-6, 0.3, 40.0, 1e6):
        v = np.array(bsdf.query(_f(np.linspace(0, 1, n)), _f(np.linspace(-3, 7, n)), _f(np.full(n, size)), vec(wi),
                                vec(wo), mi.Bool(np.arange(n) % 2 == 1)))
        assert np.isfinite(v).all() and (v >= 0).all(), size


def test_neural_render_beats_the_reference_at_one_sample(plain):
    """A far view of a flat sheet (5 repeats a pixel): the neural image at 1 spp is closer to
    the reference at 256 spp than the reference at 1 spp is, and has its brightness."""
    fabric, maps = plain
    view = bench.View("far", 0.2)
    repeat = 2 * bench.PITCH_M
    ref = bench.scene(bench._surface_bsdf(fabric, maps, False), bench.reference_integrator(), view, repeat, (24, 24), 16)
    truth, _ = bench.render(ref, 256, seed=1)
    one, _ = bench.render(ref, 1, seed=2)
    neural_scene = bench.scene(NeuralSurfaceBSDF(fabric, maps, bench.placement_of(fabric)), bench.neural_integrator(),
                               view, repeat, (24, 24), 1, sampler=bench.NEURAL_SAMPLER)
    neural, _ = bench.render(neural_scene, 1, seed=0)
    assert np.isfinite(neural).all()
    assert bench.mse(neural, truth) < 0.5 * bench.mse(one, truth)
    assert abs(neural.mean() / truth.mean() - 1.0) < 0.15
