"""The yarn-based BYSDF of Wu et al. 2025, §3.3 (Eq. 1–4), in Dr.Jit, and as a Mitsuba 3 BSDF.

Directions are in the local shading frame of a point on a yarn's surface (normal = +z). ``wv``
is the direction towards the viewer and ``wl`` the one towards the light (Mitsuba's ``si.wi``
and ``wo``). Every function returns the BSDF times ``|cos θ_l|``, as Mitsuba's ``eval`` does.

The lobes, and how they share the light so that the sum never exceeds one (the paper mixes
them "to ensure energy conservation"; the weights below are our concrete reading):

- ``F_v = F(cos θ_v, η^S)`` (dielectric Fresnel, Mitsuba's ``fresnel``) splits what is
  reflected at the surface from what enters the yarn;
- specular reflection f_x^S (Eq. 1, top): ``R^S · F(wv·h) D G2 / (4 cos_v cos_l)``, GGX;
- specular transmission f_x^S (Eq. 1, bottom): ``T^S (1 - F) D G2 / (4 cos_v cos_l)`` about
  the straight-through direction. A yarn is thin: light that enters also leaves, so the two
  refractions cancel in direction and the net lobe is the mirror image of the reflection lobe
  through the tangent plane ("thin dielectric"); η acts through the Fresnel terms;
- exit-point transmission f_y^S (Eq. 2): the same lobe with roughness α^S_y and IOR η^S_y,
  weighted by ``(1 - T^S) T^S_y τ^{N_i}``; Beer–Lambert ``τ^{N_i} = exp(-A^S ℓ n_p / n_f)``,
  ℓ the chord through the yarn in diameters (``cos θ_t`` of the refracted view ray), taking
  ``N_i = n_p`` ply layers each of attenuation ``exp(-A^S ℓ / n_f)``;
- body reflection f_x^B (Eq. 3): ``m_r G_p G_f R^B ½[LS + 1/π]`` with the Lommel–Seeliger
  term ``LS = 1 / (2π (cos_v + cos_l))``; the ½ makes the mix's albedo at most one;
- body transmission f_y^B (Eq. 4): ``(1 - m_r) G_p G_f S^B / π · exp(-A^B ℓ)``;
- the body lobes share ``(1 - F_v)(1 - T^S)(1 - T^S_y τ)`` — what was not reflected or
  transmitted specularly.

Ply and fibre shadowing (G_p, G_f) are procedural, from the tube's texture coordinates
(u = length along the yarn in circumferences, v = angle / 2π): plies are ``n_p`` helical
strands twisted at :data:`PLY_TWIST_DEG`, fibres ``n_f`` finer strands along them, and the
grooves between them are darkened by ``G_p`` and ``G_f`` (0 = no shadowing, 1 = black
grooves), more at grazing light.

Every division is guarded (``dr.select(dr.isfinite(x), x, 0)``), GGX's α is clamped to
``[ALPHA_MIN, 1]`` and IORs to ``>= 1``, so values and gradients stay finite for roughness 0,
cosines of 1e-6, IOR 1 and black or white colours.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..backend import mitsuba

mi = mitsuba()
import drjit as dr  # noqa: E402  (after the backend chose libLLVM)

ALPHA_MIN = 1e-3  # GGX α below this is a mirror for any pixel size; keeps D finite
PLY_TWIST_DEG = 28.0  # helix angle of the plies on the yarn surface
FIBER_TWIST_DEG = 20.0  # helix angle of the fibres within a ply
PLY_GROOVE_POWER = 6.0  # sharpness of the dark grooves between plies
FIBER_GROOVE_POWER = 2.0
EPS = 1e-7


@dataclass
class Shading:
    """BYSDF parameters shared by warps and wefts, as Dr.Jit values (Table 1 names).

    Scalars are ``mi.Float`` of width 1 and colours ``mi.Color3f``; ``plies`` and ``fibers``
    are floats too so that annealing them never recompiles a kernel.
    """

    coefficient: object  # m_r
    reflection: object  # R^S
    transmission: object  # T^S
    transmission_exit: object  # T^S_y
    roughness: object  # α^S
    roughness_exit: object  # α^S_y
    ior: object  # η^S
    ior_exit: object  # η^S_y
    attenuation: object  # A^S
    body_attenuation: object  # A^B
    ply_shadow: object  # G_p
    fiber_shadow: object  # G_f
    plies: object  # n_p
    fibers: object  # n_f


# --------------------------------------------------------------------------------------------
# microfacet pieces (GGX, height-correlated Smith)


def _safe(x):
    return dr.select(dr.isfinite(x), x, 0.0)


def _alpha(roughness):
    return dr.clip(roughness, ALPHA_MIN, 1.0)


def ggx_d(cos_m, alpha):
    """GGX normal distribution D(m) for a microfacet normal at ``cos_m`` to the surface normal."""
    a2 = alpha * alpha
    c2 = cos_m * cos_m
    denom = c2 * (a2 - 1.0) + 1.0
    return dr.select(cos_m > 0.0, _safe(a2 / (dr.pi * denom * denom)), 0.0)


def _smith_s(cos_t, alpha):
    """sqrt(α² + (1-α²) cos²θ): the common factor of Smith's Λ for GGX."""
    a2 = alpha * alpha
    return dr.sqrt(dr.maximum(a2 + (1.0 - a2) * cos_t * cos_t, EPS))


def ggx_g1(cos_t, alpha):
    """Smith masking G1 for GGX, 2c / (c + S(c)), finite as c → 0."""
    c = dr.abs(cos_t)
    return _safe(2.0 * c / dr.maximum(c + _smith_s(c, alpha), EPS))


def ggx_lobe(wv, wl, alpha):
    """``D(h) G2(wv, wl) / (4 cos_v cos_l) · cos_l`` for a reflection-like pair (both z > 0).

    Written as ``D c_l / (2 (S_v c_l + S_l c_v))`` (height-correlated G2 folded in), which
    stays finite when either cosine goes to zero.
    """
    cv, cl = wv.z, wl.z
    h = dr.normalize(wv + wl)
    h_ok = dr.squared_norm(wv + wl) > EPS
    d = ggx_d(h.z, alpha)
    denom = 2.0 * (_smith_s(cv, alpha) * cl + _smith_s(cl, alpha) * cv)
    val = _safe(d * cl / dr.maximum(denom, EPS))
    return dr.select((cv > 0.0) & (cl > 0.0) & h_ok, val, 0.0), h


def _mirror(w):
    """Reflect a direction through the tangent plane (z → -z)."""
    return mi.Vector3f(w.x, w.y, -w.z)


def fresnel(cos_t, eta):
    """Unpolarised dielectric Fresnel reflectance for a ray from outside (cos ≥ 0), η ≥ 1."""
    f, cos_tr, _, _ = mi.fresnel(dr.clip(cos_t, 0.0, 1.0), dr.maximum(eta, 1.0))
    return _safe(f), _safe(dr.abs(cos_tr))


# --------------------------------------------------------------------------------------------
# procedural plies and fibres


def grooves(p: Shading, uv):
    """How deep in the groove between plies and between fibres a point lies, each in [0, 1].

    ``uv``: tube texture coordinates (u along the yarn in circumferences, v around it).
    Returns ``(groove_p, groove_f)``: 1 in the middle of a groove, 0 on a strand's crest.
    """
    tan_p = math.tan(math.radians(PLY_TWIST_DEG))
    tan_f = math.tan(math.radians(FIBER_TWIST_DEG))
    phase_p = p.plies * (uv.y - uv.x * tan_p)
    phase_f = p.fibers * (uv.y - uv.x * tan_f)
    groove_p = dr.power(0.5 + 0.5 * dr.cos(2.0 * dr.pi * phase_p), PLY_GROOVE_POWER)
    groove_f = dr.power(0.5 + 0.5 * dr.cos(2.0 * dr.pi * phase_f), FIBER_GROOVE_POWER)
    return groove_p, groove_f


def groove_shadowing(p: Shading, groove_p, groove_f, cos_light):
    """G_p(x, ω_l) · G_f(x) from the groove depths of :func:`grooves` (or their averages over
    a texel, as the surface model bakes them)."""
    grazing = 1.0 - 0.5 * dr.clip(dr.abs(cos_light), 0.0, 1.0)
    g_p = 1.0 - dr.clip(p.ply_shadow, 0.0, 1.0) * groove_p * grazing
    g_f = 1.0 - dr.clip(p.fiber_shadow, 0.0, 1.0) * groove_f
    return g_p * g_f


def shadowing(p: Shading, uv, cos_light):
    """G_p(x, ω_l) · G_f(x): darkening in the grooves between plies and between fibres.

    ``uv``: tube texture coordinates (u along the yarn in circumferences, v around it).
    """
    return groove_shadowing(p, *grooves(p, uv), cos_light)


# --------------------------------------------------------------------------------------------
# the BYSDF


@dataclass
class LobeWeights:
    """Energy shares for one view direction (see the module docstring).

    ``fresnel_v``: F(cos θ_v, η^S); ``t_s``: T^S; ``t_y``: T^S_y τ^{N_i}; ``body``: the body
    lobes' share (1 - F_v)(1 - T^S)(1 - T^S_y τ); ``chord``: ℓ, the chord in diameters.
    """

    fresnel_v: object
    t_s: object
    t_y: object
    body: object
    chord: object


def lobe_weights(p: Shading, cos_v):
    """The partition of light among lobes for a view at ``cos_v`` (≥ 0) to the normal."""
    f_v, cos_t = fresnel(cos_v, p.ior)
    n_p = dr.maximum(p.plies, 1.0)
    n_f = dr.maximum(p.fibers, 1.0)
    tau = dr.exp(-dr.maximum(p.attenuation, 0.0) * cos_t * n_p / n_f)
    t_s = dr.clip(p.transmission, 0.0, 1.0)
    t_y = dr.clip(p.transmission_exit, 0.0, 1.0) * tau
    return LobeWeights(fresnel_v=f_v, t_s=t_s, t_y=t_y, body=(1.0 - f_v) * (1.0 - t_s) * (1.0 - t_y), chord=cos_t)


def _two_sided(wv, wl):
    """Flip both directions when the viewer is below the local surface (tubes seen edge-on)."""
    flip = wv.z < 0.0
    wv = mi.Vector3f(wv.x, wv.y, dr.select(flip, -wv.z, wv.z))
    wl = mi.Vector3f(wl.x, wl.y, dr.select(flip, -wl.z, wl.z))
    return wv, wl


def eval_bysdf(p: Shading, body_reflection, body_subsurface, uv, wv, wl, *, groove=None):
    """BYSDF × |cos θ_l| (Color3f) for view ``wv`` and light ``wl`` in the local frame.

    Parameters
    ----------
    p : Shading
    body_reflection, body_subsurface : Color3f
        R^B and S^B of the yarn hit (warp or weft; a texture lookup already done).
    uv : Point2f, tube texture coordinates (for plies and fibres); unused when ``groove`` is given
    wv, wl : Vector3f, unit directions towards the viewer and the light
    groove : (groove_p, groove_f), optional
        Groove depths already known (:func:`grooves`, or a baked map's texel average) in
        place of their procedural value at ``uv``.
    """
    wv, wl = _two_sided(wv, wl)
    cv = dr.clip(wv.z, 0.0, 1.0)
    cl = wl.z
    reflect = cl > 0.0
    w = lobe_weights(p, cv)
    alpha, alpha_y = _alpha(p.roughness), _alpha(p.roughness_exit)
    wl_up = dr.select(reflect, wl, _mirror(wl))  # the light mirrored to the viewer's side

    lobe, h = ggx_lobe(wv, wl_up, alpha)
    f_h, _ = fresnel(dr.dot(wv, h), p.ior)
    lobe_y, h_y = ggx_lobe(wv, wl_up, alpha_y)
    f_hy, _ = fresnel(dr.dot(wv, h_y), p.ior_exit)

    spec_r = dr.clip(p.reflection, 0.0, 1.0) * f_h * lobe
    spec_t = w.t_s * (1.0 - f_h) * lobe
    exit_t = (1.0 - w.t_s) * w.t_y * (1.0 - f_hy) * lobe_y

    g = shadowing(p, uv, cl) if groove is None else groove_shadowing(p, *groove, cl)
    acl = dr.abs(cl)
    m_r = dr.clip(p.coefficient, 0.0, 1.0)
    ls = acl / (2.0 * dr.pi * dr.maximum(cv + acl, EPS))
    body_r = m_r * dr.clip(body_reflection, 0.0, 1.0) * 0.5 * (ls + acl / dr.pi)
    body_t = ((1.0 - m_r) * dr.clip(body_subsurface, 0.0, 1.0) * acl / dr.pi
              * dr.exp(-dr.maximum(p.body_attenuation, 0.0) * w.chord))
    body = w.body * g * dr.select(reflect, body_r, body_t)
    spec = dr.select(reflect, spec_r, spec_t + exit_t)
    out = mi.Color3f(spec) + body
    valid = (cv > 0.0) & (dr.abs(cl) > 0.0)
    return dr.select(valid & dr.isfinite(out.x + out.y + out.z), out, 0.0)


def _sampling_weights(p: Shading, body_reflection, body_subsurface, cos_v):
    """Probabilities of the five sampling strategies, roughly proportional to their energy."""
    w = lobe_weights(p, cos_v)
    lum = mi.luminance
    m_r = dr.clip(p.coefficient, 0.0, 1.0)
    ws = [
        w.fresnel_v * lum(mi.Color3f(dr.clip(p.reflection, 0.0, 1.0))),
        (1.0 - w.fresnel_v) * lum(mi.Color3f(w.t_s)),
        (1.0 - w.fresnel_v) * lum(mi.Color3f((1.0 - w.t_s) * w.t_y)),
        lum(mi.Color3f(w.body)) * m_r * lum(body_reflection),
        lum(mi.Color3f(w.body)) * (1.0 - m_r) * lum(body_subsurface),
    ]
    ws = [dr.maximum(x, 0.0) + 1e-4 for x in ws]  # every lobe stays reachable
    total = ws[0] + ws[1] + ws[2] + ws[3] + ws[4]
    return [x / total for x in ws]


def pdf_bysdf(p: Shading, body_reflection, body_subsurface, wv, wl):
    """Solid-angle density with which :func:`sample_bysdf` produces ``wl``."""
    wv, wl = _two_sided(wv, wl)
    cv = dr.clip(wv.z, 0.0, 1.0)
    reflect = wl.z > 0.0
    pr = _sampling_weights(p, body_reflection, body_subsurface, cv)
    wl_up = dr.select(reflect, wl, _mirror(wl))

    def ggx_pdf(alpha):
        h = dr.normalize(wv + wl_up)
        pdf_m = ggx_g1(cv, alpha) * dr.maximum(dr.dot(wv, h), 0.0) * ggx_d(h.z, alpha) / dr.maximum(cv, EPS)
        return _safe(pdf_m / dr.maximum(4.0 * dr.abs(dr.dot(wl_up, h)), EPS))

    cos_pdf = dr.abs(wl.z) / dr.pi
    pdf = dr.select(reflect,
                    pr[0] * ggx_pdf(_alpha(p.roughness)) + pr[3] * cos_pdf,
                    pr[1] * ggx_pdf(_alpha(p.roughness)) + pr[2] * ggx_pdf(_alpha(p.roughness_exit)) + pr[4] * cos_pdf)
    return dr.select((cv > 0.0) & (dr.abs(wl.z) > 0.0), pdf, 0.0)


def sample_bysdf(p: Shading, body_reflection, body_subsurface, wv, sample1, sample2):
    """Sample a light direction. Returns (wl, pdf, lobe index 0..4) in the local frame."""
    flip = wv.z < 0.0
    wv_up = mi.Vector3f(wv.x, wv.y, dr.abs(wv.z))
    cv = dr.clip(wv_up.z, 0.0, 1.0)
    pr = _sampling_weights(p, body_reflection, body_subsurface, cv)
    c0 = pr[0]
    c1 = c0 + pr[1]
    c2 = c1 + pr[2]
    c3 = c2 + pr[3]
    lobe = dr.select(sample1 < c0, 0, dr.select(sample1 < c1, 1, dr.select(sample1 < c2, 2, dr.select(sample1 < c3, 3, 4))))
    alpha = dr.select(lobe == 2, _alpha(p.roughness_exit), _alpha(p.roughness))
    distr = mi.MicrofacetDistribution(mi.MicrofacetType.GGX, alpha, True)
    m, _ = distr.sample(wv_up, sample2)
    spec_dir = mi.reflect(wv_up, m)
    diffuse_dir = mi.warp.square_to_cosine_hemisphere(sample2)
    wl = dr.select(lobe >= 3, diffuse_dir, spec_dir)
    below = wl.z <= 0.0  # a microfacet reflection under the horizon: the sample is lost
    wl = dr.select((lobe == 1) | (lobe == 2) | (lobe == 4), _mirror(wl), wl)
    wl = mi.Vector3f(wl.x, wl.y, dr.select(flip, -wl.z, wl.z))
    pdf = dr.select(below, 0.0, pdf_bysdf(p, body_reflection, body_subsurface, wv, wl))
    return wl, pdf, lobe


# --------------------------------------------------------------------------------------------
# the Mitsuba plugin

COLOUR_KEYS = ("reflection", "transmission", "transmission_exit", "body_reflection", "body_subsurface")
SCALAR_KEYS = ("coefficient", "roughness", "roughness_exit", "ior", "ior_exit", "attenuation",
               "body_attenuation", "ply_shadow", "fiber_shadow", "plies", "fibers")
DEFAULTS = {"coefficient": 0.5, "roughness": 0.3, "roughness_exit": 0.3, "ior": 1.5, "ior_exit": 1.5,
            "attenuation": 10.0, "body_attenuation": 0.4, "ply_shadow": 0.5, "fiber_shadow": 0.5,
            "plies": 3.0, "fibers": 30.0, "reflection": 0.5, "transmission": 0.2, "transmission_exit": 0.2,
            "body_reflection": 0.5, "body_subsurface": 0.5}


class BYSDF(mi.BSDF):
    """Mitsuba 3 plugin ``"bysdf"``: the yarn BYSDF for one kind of yarn (warp or weft).

    Properties (all optional, Table 1 names): ``coefficient, roughness, roughness_exit, ior,
    ior_exit, attenuation, body_attenuation, ply_shadow, fiber_shadow, plies, fibers``
    (floats) and ``reflection, transmission, transmission_exit, body_reflection,
    body_subsurface`` (floats or RGB). Every one is exposed to ``mi.traverse`` as
    differentiable; all are kept opaque so new values never recompile kernels.
    """

    def __init__(self, props):
        mi.BSDF.__init__(self, props)
        self.values = {}
        for key in SCALAR_KEYS:
            self.values[key] = mi.Float(float(props.get(key, DEFAULTS[key])))
        for key in COLOUR_KEYS:
            value = props.get(key, DEFAULTS[key])
            self.values[key] = mi.Color3f(*value) if hasattr(value, "__len__") else mi.Color3f(float(value))
        self._make_opaque()
        reflection = (mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.DiffuseReflection
                      | mi.BSDFFlags.FrontSide | mi.BSDFFlags.BackSide)
        transmission = (mi.BSDFFlags.GlossyTransmission | mi.BSDFFlags.DiffuseTransmission
                        | mi.BSDFFlags.FrontSide | mi.BSDFFlags.BackSide)
        self.m_components = [reflection, transmission]
        self.m_flags = reflection | transmission

    def _make_opaque(self):
        for value in self.values.values():
            dr.make_opaque(value)

    def shading(self) -> Shading:
        v = self.values
        return Shading(coefficient=v["coefficient"], reflection=v["reflection"], transmission=v["transmission"],
                       transmission_exit=v["transmission_exit"], roughness=v["roughness"],
                       roughness_exit=v["roughness_exit"], ior=v["ior"], ior_exit=v["ior_exit"],
                       attenuation=v["attenuation"], body_attenuation=v["body_attenuation"],
                       ply_shadow=v["ply_shadow"], fiber_shadow=v["fiber_shadow"], plies=v["plies"],
                       fibers=v["fibers"])

    def sample(self, ctx, si, sample1, sample2, active=True):
        p = self.shading()
        wl, pdf, lobe = sample_bysdf(p, self.values["body_reflection"], self.values["body_subsurface"],
                                     si.wi, sample1, sample2)
        value = eval_bysdf(p, self.values["body_reflection"], self.values["body_subsurface"], si.uv, si.wi, wl)
        bs = mi.BSDFSample3f()
        bs.wo = wl
        bs.pdf = pdf
        bs.eta = 1.0
        bs.sampled_component = dr.select(lobe == 0, 0, dr.select(lobe == 3, 0, 1))
        bs.sampled_type = mi.UInt32(+dr.select(lobe >= 3,
                                               dr.select(lobe == 3, mi.UInt32(+mi.BSDFFlags.DiffuseReflection),
                                                         mi.UInt32(+mi.BSDFFlags.DiffuseTransmission)),
                                               dr.select(lobe == 0, mi.UInt32(+mi.BSDFFlags.GlossyReflection),
                                                         mi.UInt32(+mi.BSDFFlags.GlossyTransmission))))
        weight = dr.select(pdf > 0.0, value / pdf, 0.0)
        return bs, dr.select(active & (pdf > 0.0), weight, 0.0)

    def eval(self, ctx, si, wo, active=True):
        value = eval_bysdf(self.shading(), self.values["body_reflection"], self.values["body_subsurface"],
                           si.uv, si.wi, wo)
        return dr.select(active, value, 0.0)

    def pdf(self, ctx, si, wo, active=True):
        pdf = pdf_bysdf(self.shading(), self.values["body_reflection"], self.values["body_subsurface"], si.wi, wo)
        return dr.select(active, pdf, 0.0)

    def eval_pdf(self, ctx, si, wo, active=True):
        return self.eval(ctx, si, wo, active), self.pdf(ctx, si, wo, active)

    def traverse(self, callback):
        for key, value in self.values.items():
            callback.put(key, value, mi.ParamFlags.Differentiable)

    def parameters_changed(self, keys):
        self._make_opaque()

    def to_string(self):
        return "BYSDF[" + ", ".join(f"{k}={v}" for k, v in self.values.items()) + "]"


def register() -> None:
    """Make ``{"type": "bysdf"}`` available to ``mi.load_dict`` (idempotent)."""
    mi.register_bsdf("bysdf", lambda props: BYSDF(props))


register()


def albedo_bysdf(p: Shading, body_reflection, body_subsurface, uv, cos_v, *, groove=None):
    """Directional albedo (reflection + transmission) for a view at ``cos_v``: the radiance
    returned under a uniform white ambient light of radiance 1, for the ambient part of §6.4.

    Each lobe contributes its energy share (the GGX lobes' own losses are neglected); the
    Lommel–Seeliger albedo is ``1 - c ln(1 + 1/c)``. ``groove`` as in :func:`eval_bysdf`.
    """
    cv = dr.clip(dr.abs(cos_v), EPS, 1.0)
    w = lobe_weights(p, cv)
    m_r = dr.clip(p.coefficient, 0.0, 1.0)
    a_ls = 1.0 - cv * dr.log(1.0 + 1.0 / cv)
    spec = w.fresnel_v * dr.clip(p.reflection, 0.0, 1.0) + (1.0 - w.fresnel_v) * (w.t_s + (1.0 - w.t_s) * w.t_y)
    g = shadowing(p, uv, 1.0) if groove is None else groove_shadowing(p, *groove, 1.0)
    body = w.body * g * (
        m_r * dr.clip(body_reflection, 0.0, 1.0) * 0.5 * (a_ls + 1.0)
        + (1.0 - m_r) * dr.clip(body_subsurface, 0.0, 1.0) * dr.exp(-dr.maximum(p.body_attenuation, 0.0) * w.chord))
    return mi.Color3f(spec) + body
