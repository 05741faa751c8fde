"""Tests for weavecap.model.bysdf, the yarn BYSDF of Wu et al. §3.3.

What a user relies on: no NaN, infinity or negative light anywhere in the parameter space of
Table 1 (nor at its hard edges: mirror-smooth yarns, grazing light, IOR 1, black or white
yarns), gradients that stay finite for the fit, no energy created (white furnace), and a
sampler that agrees with the evaluation it drives.

Monte-Carlo checks batch many parameter sets into one Dr.Jit call (one parameter set per
block of lanes) and use fixed seeds, so they are deterministic. Tolerances are stated per
test in standard errors (SE) of the estimate plus a small absolute margin.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from weavecap.backend import mitsuba

mi = mitsuba()
import drjit as dr  # noqa: E402  (after the backend chose libLLVM)

from weavecap.model import bysdf as b  # noqa: E402
from shading_batch import ShadingBatch, mean_se, uniform_sphere  # noqa: E402

WHITE = dict(reflection=1.0, transmission=0.3, transmission_exit=0.5, attenuation=0.0, body_attenuation=0.0,
             body_reflection=1.0, body_subsurface=1.0, ply_shadow=0.0, fiber_shadow=0.0, coefficient=0.5)
NOTHING = dict(reflection=0.0, transmission=0.0, transmission_exit=0.0, attenuation=0.0, body_attenuation=0.0,
               body_reflection=0.0, body_subsurface=0.0, ply_shadow=0.0, fiber_shadow=0.0)
#: each lobe of §3.3 alone (all others switched off)
LOBES = {
    "specular-reflection": {**NOTHING, "reflection": 1.0},
    "specular-transmission": {**NOTHING, "transmission": 1.0},
    "exit-transmission": {**NOTHING, "transmission_exit": 1.0},
    "body-reflection": {**NOTHING, "coefficient": 1.0, "body_reflection": 1.0},
    "body-transmission": {**NOTHING, "coefficient": 0.0, "body_subsurface": 1.0},
}
REFLECTING = {"specular-reflection", "body-reflection"}


class Batch(ShadingBatch):
    """Parameter sets, each repeated over ``lanes`` lanes, as the arguments of the BYSDF functions."""

    def __init__(self, configs: list[dict], lanes: int, *, grad: bool = False):
        super().__init__(configs, lanes, grad=grad)
        self.body_reflection = self.column("body_reflection")
        self.body_subsurface = self.column("body_subsurface")

    def eval(self, wv, wl, uv=None):
        uv = mi.Point2f(0.3, 0.2) if uv is None else uv
        return b.eval_bysdf(self.p, self.body_reflection, self.body_subsurface, uv, wv, wl)

    def pdf(self, wv, wl):
        return b.pdf_bysdf(self.p, self.body_reflection, self.body_subsurface, wv, wl)

    def sample(self, wv, seed: int):
        rng = np.random.default_rng(seed)
        n = self.count * self.lanes
        u = [mi.Float(rng.random(n, dtype=np.float32)) for _ in range(3)]
        return b.sample_bysdf(self.p, self.body_reflection, self.body_subsurface, wv, u[0], mi.Point2f(u[1], u[2]))


def view(cos_v: np.ndarray, lanes: int) -> mi.Vector3f:
    """View directions at the given cosines (one per config), in the xz-plane."""
    c = np.repeat(np.asarray(cos_v, dtype=np.float64), lanes)
    return mi.Vector3f(np.sqrt(1 - c * c).astype(np.float32), np.zeros_like(c, dtype=np.float32),
                       c.astype(np.float32))


# -- hard cases: finite, non-negative values and gradients ------------------------------------

ROUGHNESS = [1e-4, 1e-3, 0.05, 1.0]
IORS = [1.0, 1.0 + 1e-6, 1.5, 3.0]
COLOURS = [0.0, 1.0]  # black and white yarns
HARD_CONFIGS = [
    {**lobe, "roughness": r, "roughness_exit": r, "ior": eta, "ior_exit": eta,
     **{k: c for k in ("reflection", "body_reflection", "body_subsurface") if lobe[k] > 0}}
    for lobe, r, eta, c in itertools.product(list(LOBES.values()) + [WHITE], ROUGHNESS, IORS, COLOURS)
]


def hard_directions() -> tuple[np.ndarray, np.ndarray]:
    """View/light pairs at the edges: cosines 1e-6, ω_v·ω_l = 0, mirror peak, straight through."""
    pairs = []
    for cv in (1e-6, 1e-3, 0.5, 1.0):
        sv = np.sqrt(1 - cv * cv)
        v = np.array([sv, 0.0, cv])
        for w in (np.array([-sv, 0, cv]),  # mirror direction: the specular peak
                  -v,  # straight through
                  np.array([-cv, 0, sv]), np.array([cv, 0, -sv]),  # perpendicular to the view
                  np.array([0, np.sqrt(1 - 1e-12), 1e-6]), np.array([0, np.sqrt(1 - 1e-12), -1e-6]),  # grazing
                  np.array([0, 0, 1.0]), np.array([0, 0, -1.0])):
            pairs.append((v, w))
    pairs.append((np.array([0, 0, -1.0]), np.array([0.6, 0, 0.8])))  # viewer below the surface
    wv, wl = (np.array(x, dtype=np.float32) for x in zip(*pairs))
    return wv, wl


def test_perpendicular_pairs_are_in_the_hard_set():
    """The hard directions include exact ω_v·ω_l = 0 and cosines of 1e-6 (guards the test)."""
    wv, wl = hard_directions()
    assert np.any(np.abs(np.sum(wv * wl, axis=1)) < 1e-7)
    assert np.any(np.abs(wv[:, 2]) <= 1e-6) and np.any(np.abs(wl[:, 2]) <= 1e-6)


def test_hard_cases_values_and_gradients_are_finite_and_non_negative():
    """eval, pdf, sample weights and albedo are finite and ≥ 0, and so are their gradients
    with respect to every parameter, for roughness 1e-4…1, IOR 1…3, black/white, every lobe."""
    wv_np, wl_np = hard_directions()
    k = len(wv_np)
    batch = Batch(HARD_CONFIGS, k, grad=True)
    tile = lambda a: np.tile(a, (len(HARD_CONFIGS), 1))  # noqa: E731
    wv = mi.Vector3f(*tile(wv_np).T)
    wl = mi.Vector3f(*tile(wl_np).T)

    value = batch.eval(wv, wl)
    pdf = batch.pdf(wv, wl)
    wl_s, pdf_s, _ = batch.sample(wv, seed=1)
    weight = dr.select(pdf_s > 0, batch.eval(wv, wl_s) / pdf_s, 0.0)
    albedo = b.albedo_bysdf(batch.p, batch.body_reflection, batch.body_subsurface, mi.Point2f(0.3, 0.2), wv.z)
    for name, x in [("eval", value), ("pdf", pdf), ("sample pdf", pdf_s), ("sample weight", weight),
                    ("albedo", albedo)]:
        a = np.asarray(x)
        assert np.isfinite(a).all(), name
        assert (a >= 0).all(), name

    dr.backward(dr.sum(value.x + value.y + value.z) + dr.sum(weight.x) + dr.sum(albedo.y))
    for key, leaf in batch.leaves:
        assert np.isfinite(np.asarray(dr.grad(leaf))).all(), f"gradient of {key} is not finite"
    grads = {key: np.abs(np.asarray(dr.grad(leaf))).sum() for key, leaf in batch.leaves}
    for key in ("roughness", "ior", "coefficient", "reflection", "body_reflection", "body_subsurface"):
        assert grads[key] > 0, f"no gradient reaches {key}"


@pytest.mark.parametrize("lobe", LOBES)
def test_each_lobe_lights_only_its_own_hemisphere(lobe):
    """Reflection lobes return light only on the viewer's side, transmission lobes only through."""
    lanes = 4096
    batch = Batch([{**LOBES[lobe], "roughness": 0.3, "roughness_exit": 0.3}], lanes)
    wl = uniform_sphere(lanes, seed=2)
    value = batch.per_config(batch.eval(view([0.6], lanes), wl))[0]
    above = np.asarray(wl.z) > 0
    same, other = (above, ~above) if lobe in REFLECTING else (~above, above)
    assert value[same].max() > 0
    assert np.all(value[other] == 0)


# -- known answers -----------------------------------------------------------------------------


def test_without_index_contrast_nothing_is_reflected_specularly():
    """IOR 1: the Fresnel reflectance is zero, so the specular reflection lobe vanishes."""
    lanes = 2048
    batch = Batch([{**LOBES["specular-reflection"], "ior": 1.0, "roughness": 0.2}], lanes)
    wl = uniform_sphere(lanes, seed=3)
    assert np.all(batch.per_config(batch.eval(view([0.7], lanes), wl)) == 0)


def test_lambert_body_transmission_has_its_closed_form():
    """Body transmission alone with IOR 1 and no attenuation is Lambert: f·|cos| = |cos_l| / π."""
    lanes = 2048
    batch = Batch([{**LOBES["body-transmission"], "ior": 1.0}], lanes)
    wl = uniform_sphere(lanes, seed=4)
    value = batch.per_config(batch.eval(view([0.4], lanes), wl))[0]
    z = np.asarray(wl.z)
    np.testing.assert_allclose(value, np.where(z < 0, -z / np.pi, 0.0), rtol=1e-5, atol=1e-7)


def test_body_reflection_is_lommel_seeliger_plus_lambert():
    """Body reflection alone (IOR 1) is ½[LS + Lambert]: f·cos = ½[c_l / (2π(c_v + c_l)) + c_l / π]."""
    lanes = 2048
    cv = 0.3
    batch = Batch([{**LOBES["body-reflection"], "ior": 1.0}], lanes)
    wl = uniform_sphere(lanes, seed=5)
    value = batch.per_config(batch.eval(view([cv], lanes), wl))[0]
    cl = np.asarray(wl.z)
    expected = np.where(cl > 0, 0.5 * (cl / (2 * np.pi * (cv + cl)) + cl / np.pi), 0.0)
    np.testing.assert_allclose(value, expected, rtol=1e-5, atol=1e-7)


def test_beer_lambert_attenuation_of_the_exit_lobe():
    """Exit-point transmission falls as exp(-A^S ℓ n_p / n_f): doubling A^S squares the factor."""
    lanes = 1
    a = 9.0
    configs = [{**LOBES["exit-transmission"], "attenuation": x, "roughness_exit": 0.3} for x in (0.0, a, 2 * a)]
    batch = Batch(configs, lanes)
    wv = view([0.8] * 3, lanes)
    value = batch.per_config(batch.eval(wv, mi.Vector3f(np.repeat(np.float32(-0.48), 3), 0, -0.6)))[:, 0]
    ratio_a, ratio_2a = value[1] / value[0], value[2] / value[0]
    assert 0 < ratio_a < 1
    assert ratio_2a == pytest.approx(ratio_a**2, rel=1e-4)


@pytest.mark.parametrize("cos_v", [0.05, 0.5, 1.0])
def test_albedo_matches_the_integral_of_the_body_lobes(cos_v):
    """albedo_bysdf (used for the ambient light) equals ∫ f |cos| dω for the body lobes, whose
    closed forms it uses: 4 SE + 0.002 of a 200k-sample uniform-sphere estimate."""
    lanes = 200_000
    configs = [{**LOBES[name], "ior": 1.5} for name in ("body-reflection", "body-transmission")]
    batch = Batch(configs, lanes)
    wv = view([cos_v] * 2, lanes)
    wl = uniform_sphere(2 * lanes, seed=6)
    estimate, se = mean_se(4 * np.pi * batch.per_config(batch.eval(wv, wl)))
    albedo = batch.per_config(b.albedo_bysdf(batch.p, batch.body_reflection, batch.body_subsurface,
                                             mi.Point2f(0.3, 0.2), wv.z))[:, 0]
    assert np.all(np.abs(estimate - albedo) <= 4 * se + 2e-3), (estimate, albedo, se)


# -- white furnace and sampling consistency --------------------------------------------------------

FURNACE_COS = [1e-6, 1e-3, 0.1, 0.5, 1.0]
FURNACE_ROUGHNESS = [1e-4, 1e-2, 0.1, 0.5, 1.0]
#: how the white yarn shares light among its lobes: T^S, T^S_y and m_r (T^S_y = 1 leaves no body)
FURNACE_MIX = [dict(transmission=t, transmission_exit=t_y, coefficient=m)
               for t, t_y, m in [(0, 0, 1), (0, 0, 0), (0.5, 0.5, 0.5), (0.2, 0, 1), (0, 1, 0.5), (1, 1, 0.5)]]
FURNACE = [(c, {**WHITE, **mix, "roughness": r, "roughness_exit": r})
           for c, r, mix in itertools.product(FURNACE_COS, FURNACE_ROUGHNESS, FURNACE_MIX)]
LANES = 20_000


@pytest.fixture(scope="module")
def furnace():
    """For every furnace case: the energy ∫ f |cos| dω estimated two ways, with standard errors,
    and ∫ pdf dω, and the fraction of samples that sample_bysdf did not lose."""
    cos_v = [c for c, _ in FURNACE]
    batch = Batch([cfg for _, cfg in FURNACE], LANES)
    wv = view(cos_v, LANES)
    wl, pdf, _ = batch.sample(wv, seed=7)
    weight = batch.per_config(dr.select(pdf > 0, batch.eval(wv, wl) / pdf, 0.0))
    kept = batch.per_config(pdf) > 0
    u = uniform_sphere(len(FURNACE) * LANES, seed=8)
    uniform = 4 * np.pi * batch.per_config(batch.eval(wv, u))
    pdf_u = 4 * np.pi * batch.per_config(batch.pdf(wv, u))
    return dict(sampled=mean_se(weight), uniform=mean_se(uniform), pdf=mean_se(pdf_u), kept=kept.mean(axis=1))


def _cases(rows):
    return [f"cos_v={FURNACE[i][0]:g} roughness={FURNACE[i][1]['roughness']:g} "
            f"T={FURNACE[i][1]['transmission']:g} T_y={FURNACE[i][1]['transmission_exit']:g} "
            f"m_r={FURNACE[i][1]['coefficient']:g}" for i in rows]


def test_white_furnace_by_sampling(furnace):
    """White yarns without attenuation reflect plus transmit at most all the light: the
    importance-sampled energy is ≤ 1 + 0.01 + 4 SE, for views with cos θ_v ≥ 1e-3 (at 1e-6 the
    Lommel–Seeliger weights have unbounded variance and the SE is meaningless; the uniform
    estimate covers it)."""
    energy, se = furnace["sampled"]
    rows = [i for i, (c, _) in enumerate(FURNACE) if c >= 1e-3]
    bad = [i for i in rows if energy[i] > 1.01 + 4 * se[i]]
    assert not bad, list(zip(_cases(bad), energy[bad], se[bad]))


def test_white_furnace_by_uniform_sphere(furnace):
    """The same bound with the uniform-sphere estimate, at every view angle down to cos 1e-6."""
    energy, se = furnace["uniform"]
    bad = np.flatnonzero(energy > 1.01 + 4 * se)
    assert not len(bad), list(zip(_cases(bad), energy[bad], se[bad]))


def test_furnace_is_not_trivially_dark(furnace):
    """A white, rough yarn seen from above returns most of the light (the furnace test has teeth)."""
    energy, _ = furnace["uniform"]
    rows = [i for i, (c, cfg) in enumerate(FURNACE) if c == 1.0 and cfg["roughness"] == 0.5]
    assert np.all(energy[rows] > 0.6), energy[rows]


def test_eval_and_sampling_estimators_agree(furnace):
    """Sampling is consistent with eval/pdf: both estimates of the energy agree within 5 combined
    SE + 0.01 wherever the uniform estimate can resolve the lobes (roughness ≥ 0.1, cos_v ≥ 1e-3)."""
    (a, sa), (u, su) = furnace["sampled"], furnace["uniform"]
    rows = np.array([i for i, (c, cfg) in enumerate(FURNACE) if cfg["roughness"] >= 0.1 and c >= 1e-3])
    diff = np.abs(a[rows] - u[rows])
    bad = rows[diff > 5 * np.hypot(sa[rows], su[rows]) + 0.01]
    assert not len(bad), list(zip(_cases(bad), a[bad], u[bad]))


def test_pdf_integrates_to_the_fraction_of_kept_samples(furnace):
    """∫ pdf dω ≤ 1 (4 SE + 0.01), and it equals the share of samples that sample_bysdf did not
    lose below the horizon (roughness ≥ 0.1, where a uniform estimate of ∫ pdf is reliable)."""
    integral, se = furnace["pdf"]
    rows = np.array([i for i, (_, cfg) in enumerate(FURNACE) if cfg["roughness"] >= 0.1])
    assert np.all(integral[rows] <= 1.01 + 4 * se[rows]), integral[rows].max()
    kept = furnace["kept"][rows]
    bad = rows[np.abs(integral[rows] - kept) > 4 * se[rows] + 0.02]
    assert not len(bad), list(zip(_cases(bad), integral[bad], furnace["kept"][bad]))


@pytest.mark.parametrize("cos_v, roughness", [(0.9, 0.3), (0.3, 0.6), (0.05, 1.0)])
def test_sampled_directions_follow_the_pdf(cos_v, roughness):
    """Where sample_bysdf sends directions matches pdf_bysdf: per equal-area cell of the sphere
    (10 bands of z × 8 azimuths), the share of samples is within 4 SE + 0.002 of ∫_cell pdf."""
    lanes = 200_000
    batch = Batch([{**WHITE, "roughness": roughness, "roughness_exit": roughness}], lanes)
    wv = view([cos_v], lanes)
    wl, pdf, _ = batch.sample(wv, seed=9)
    u = uniform_sphere(lanes, seed=10)
    pdf_u = 4 * np.pi * np.asarray(batch.pdf(wv, u))

    observed = np.bincount(cell_index(wl)[np.asarray(pdf) > 0], minlength=80) / lanes
    expected = np.bincount(cell_index(u), weights=pdf_u, minlength=80) / lanes
    assert observed.sum() > 0.5
    tolerance = 5 * np.sqrt(expected / lanes) + 2e-3
    assert np.all(np.abs(observed - expected) <= tolerance), np.abs(observed - expected).max()


def cell_index(w) -> np.ndarray:
    """Index of the equal-area cell (10 bands of z × 8 azimuth sectors) of each direction."""
    x, y, z = (np.asarray(c) for c in (w.x, w.y, w.z))
    band = np.clip(((z + 1) / 2 * 10).astype(int), 0, 9)
    sector = ((np.arctan2(y, x) + np.pi) / (2 * np.pi) * 8).astype(int) % 8
    return band * 8 + sector


# -- the Mitsuba plugin ------------------------------------------------------------------------


def test_plugin_matches_the_functions_and_exposes_every_parameter():
    """mi.load_dict({"type": "bysdf"}) evaluates and samples as the functions do, and every
    Table 1 shading parameter is a differentiable scene parameter."""
    props = {"roughness": 0.25, "ior": 1.45, "coefficient": 0.7, "reflection": [0.2, 0.4, 0.6],
             "body_reflection": [0.8, 0.1, 0.1]}
    bsdf = mi.load_dict({"type": "bysdf", **props})
    params = mi.traverse(bsdf)
    assert set(b.SCALAR_KEYS) | set(b.COLOUR_KEYS) <= set(params.keys())
    assert all(params.flags(key) & mi.ParamFlags.NonDifferentiable == 0 for key in params.keys())

    si = dr.zeros(mi.SurfaceInteraction3f)
    si.wi = mi.Vector3f(0.0, 0.6, 0.8)
    si.uv = mi.Point2f(0.3, 0.2)
    ctx = mi.BSDFContext()
    wo = mi.Vector3f(0.0, -0.6, 0.8)
    expected = bsdf.shading()
    direct = b.eval_bysdf(expected, bsdf.values["body_reflection"], bsdf.values["body_subsurface"], si.uv, si.wi, wo)
    np.testing.assert_allclose(np.asarray(bsdf.eval(ctx, si, wo)), np.asarray(direct), rtol=1e-6)
    assert float(np.asarray(expected.roughness)[0]) == pytest.approx(0.25)

    bs, weight = bsdf.sample(ctx, si, 0.3, mi.Point2f(0.2, 0.7))
    value, pdf = bsdf.eval_pdf(ctx, si, bs.wo)
    np.testing.assert_allclose(np.asarray(pdf), np.asarray(bs.pdf), rtol=1e-5)
    np.testing.assert_allclose(np.asarray(weight), np.asarray(value) / np.asarray(pdf)[:, None].T, rtol=1e-5)
