"""The reference path tracer (weavecap.render.integrator) on scenes with known answers.

A white-ish diffuse plane under a uniform sky has radiance albedo × sky (emitter sampling and
BSDF sampling combined by MIS must add up to it); a plane that is 30% null lets 30% of the
background and of a light behind it through; the capture rigs' ambient term is the BSDF's
attribute; the same seed gives the same image, bit for bit.
"""

from __future__ import annotations

import numpy as np
import pytest

from weavecap.backend import mitsuba
from weavecap.render import integrator  # noqa: F401  (registers "weavecap_path")

mi = mitsuba()
import drjit as dr  # noqa: E402


class HalfNull(mi.BSDF):
    """A diffuse BSDF of albedo 0.5 whose surface is a share ``null`` of holes."""

    def __init__(self, props):
        mi.BSDF.__init__(self, props)
        self.null = float(props.get("null", 0.3))
        self.m_flags = mi.BSDFFlags.DiffuseReflection | mi.BSDFFlags.FrontSide | mi.BSDFFlags.Null
        self.m_components = [self.m_flags]

    def sample(self, ctx, si, s1, s2, active=True):
        bs = mi.BSDFSample3f()
        bs.wo = mi.warp.square_to_cosine_hemisphere(s2)
        bs.pdf = mi.warp.square_to_cosine_hemisphere_pdf(bs.wo)
        bs.eta = 1.0
        bs.sampled_type = mi.UInt32(+mi.BSDFFlags.DiffuseReflection)
        bs.sampled_component = 0
        return bs, mi.Color3f(0.5 * (1 - self.null)) & (active & (si.wi.z > 0))

    def eval(self, ctx, si, wo, active=True):
        return mi.Color3f(0.5 * (1 - self.null) * dr.maximum(wo.z, 0) / dr.pi) & (active & (si.wi.z > 0))

    def pdf(self, ctx, si, wo, active=True):
        return mi.warp.square_to_cosine_hemisphere_pdf(wo)

    def eval_pdf(self, ctx, si, wo, active=True):
        return self.eval(ctx, si, wo, active), self.pdf(ctx, si, wo, active)

    def eval_null_transmission(self, si, active=True):
        return mi.Color3f(self.null)

    def to_string(self):
        return "HalfNull"


mi.register_bsdf("test_half_null", lambda props: HalfNull(props))


def render(bsdf: dict, *, emitters: dict, integrator_props: dict | None = None, spp: int = 64, seed: int = 0):
    """A 16×16 orthographic view of a 2×2 plane at z = 0 facing the camera (+z)."""
    scene = {"type": "scene", "integrator": {"type": "weavecap_path", **(integrator_props or {})},
             "plane": {"type": "rectangle", "bsdf": bsdf},
             "sensor": {"type": "orthographic",
                        "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 3], target=[0, 0, 0], up=[0, 1, 0])
                        @ mi.ScalarTransform4f().scale([0.5, 0.5, 1]),
                        "film": {"type": "hdrfilm", "width": 16, "height": 16, "rfilter": {"type": "box"}}},
             **emitters}
    return np.array(mi.render(mi.load_dict(scene), spp=spp, seed=seed))


SKY = {"sky": {"type": "constant", "radiance": {"type": "rgb", "value": 0.8}}}


def test_diffuse_plane_under_a_uniform_sky_has_radiance_albedo_times_sky():
    """ρ = 0.6 under a sky of 0.8: 0.48, within 1.5% (mean of 16k samples)."""
    image = render({"type": "diffuse", "reflectance": {"type": "rgb", "value": 0.6}}, emitters=SKY)
    assert image.mean() == pytest.approx(0.48, rel=0.015)


def test_direct_only_is_one_bounce():
    """max_depth 2 (direct lighting) of that plane: the same answer (nothing to interreflect)."""
    image = render({"type": "diffuse", "reflectance": {"type": "rgb", "value": 0.6}}, emitters=SKY,
                   integrator_props={"max_depth": 2})
    assert image.mean() == pytest.approx(0.48, rel=0.015)


def test_gaps_let_the_background_and_a_back_light_through():
    """A plane that is 30% holes, of albedo 0.5, lit from the front by a sun of irradiance 1
    and seen against a background of 2: 0.3 × 2 (background through the holes) + 0.7 ×
    0.5 / π (the lit yarns); a sun behind it instead lights nothing but the holes show."""
    sun_front = {"sun": {"type": "directional", "direction": [0, 0, -1], "irradiance": {"type": "rgb", "value": 1.0}}}
    image = render({"type": "test_half_null", "null": 0.3}, emitters=sun_front,
                   integrator_props={"background": 2.0}, spp=256)
    assert image.mean() == pytest.approx(0.3 * 2.0 + 0.7 * 0.5 / np.pi, rel=0.02)
    sun_back = {"sun": {"type": "directional", "direction": [0, 0, 1], "irradiance": {"type": "rgb", "value": 1.0}}}
    image = render({"type": "test_half_null", "null": 0.3}, emitters=sun_back, integrator_props={"background": 2.0},
                   spp=256)
    assert image.mean() == pytest.approx(0.3 * 2.0, rel=0.02)


def test_shadow_rays_pass_through_gaps():
    """A 30%-null plane over a diffuse ground, sun overhead: the ground behind it receives 30%
    of the sun (0.3 × 0.6 / π), seen through the holes (× 0.3) — plus the plane's own 0.7 ×
    0.5 / π."""
    scene = {"type": "scene", "integrator": {"type": "weavecap_path"},
             "plane": {"type": "rectangle", "bsdf": {"type": "test_half_null", "null": 0.3}},
             "ground": {"type": "rectangle", "to_world": mi.ScalarTransform4f().translate([0, 0, -1]),
                        "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": 0.6}}},
             "sun": {"type": "directional", "direction": [0, 0, -1], "irradiance": {"type": "rgb", "value": 1.0}},
             "sensor": {"type": "orthographic",
                        "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 3], target=[0, 0, 0], up=[0, 1, 0])
                        @ mi.ScalarTransform4f().scale([0.5, 0.5, 1]),
                        "film": {"type": "hdrfilm", "width": 16, "height": 16, "rfilter": {"type": "box"}}}}
    image = np.array(mi.render(mi.load_dict(scene), spp=256))
    expected = 0.7 * 0.5 / np.pi + 0.3 * (0.3 * 0.6 / np.pi)
    assert image.mean() == pytest.approx(expected, rel=0.03)


def test_ambient_term_without_the_attribute_is_the_albedo():
    """``ambient`` with a BSDF that has no "ambient" attribute: its sampled albedo (0.6) × the
    ambient radiance (0.5), no rays — 0.3 with nothing else lighting it."""
    dark = {"sun": {"type": "directional", "direction": [0, 0, 1], "irradiance": {"type": "rgb", "value": 1.0}}}
    image = render({"type": "diffuse", "reflectance": {"type": "rgb", "value": 0.6}}, emitters=dark,
                   integrator_props={"ambient": 0.5, "max_depth": 2})
    assert image.mean() == pytest.approx(0.3, rel=1e-4)


def test_same_seed_same_image():
    """Bit-identical for the same seed; another seed gives other noise."""
    bsdf = {"type": "test_half_null", "null": 0.3}
    a = render(bsdf, emitters=SKY, spp=4, seed=3)
    b = render(bsdf, emitters=SKY, spp=4, seed=3)
    c = render(bsdf, emitters=SKY, spp=4, seed=4)
    assert np.array_equal(a, b) and not np.array_equal(a, c)
