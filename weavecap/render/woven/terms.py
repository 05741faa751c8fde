"""The surface BSDF split into colour-free terms (Chen et al. 2024, §4.1, Eq. 7–8).

Chen et al. split the footprint-filtered BSDF into warp/weft diffuse and specular parts so
that the colours multiply outside the network (Eq. 8). In our surface model
(:func:`weavecap.render.bsdf.eval_surface`, the BYSDF of :mod:`weavecap.model.bysdf`) every
colour is a per-channel coefficient, and the BSDF is exactly a polynomial in them:

    f = (1 - T^S) [ m_r R^B (B_R - T^S_y B_Rτ) + (1 - m_r) S^B (B_S - T^S_y B_Sτ) ]
        + R^S S_R + T^S S_T + (1 - T^S) T^S_y S_Y

with ``R^B``/``S^B`` the body colours of the yarn on top (mixed by its warp share), ``R^S,
T^S, T^S_y`` the shared specular colours and ``m_r`` the body coefficient. The seven terms
(``B_R``: body reflection lobe with unit colour and the Fresnel share; ``B_Rτ``: the same
times the exit-point attenuation τ, which the ``T^S_y`` share of the body's energy carries;
``B_S``, ``B_Sτ``: body transmission; ``S_R``, ``S_T``, ``S_Y``: specular reflection,
specular transmission and exit-point transmission lobes) hold no colour and no ``m_r``. Each
is split into its warp and weft part by the warp share of the point, so a footprint's value
is 14 numbers (:data:`CHANNELS`), and *every* colour — body and specular — and ``m_r`` can
change without re-encoding: :func:`combine` is exact.

The terms are measured with the surface model itself: :func:`eval_surface` is called with
colours that are 1 in one colour channel and 0 in the others (three calls give nine
independent slots, seven are used), so nothing here re-implements a lobe.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from ..bsdf import SurfacePoint, YarnColours, eval_surface, shading_of
from ..surface import BACK, FACE, HORIZON_AZIMUTHS, SurfaceMaps

__all__ = ["TERMS", "CHANNELS", "REFLECTION_CHANNELS", "point_terms", "combine", "colour_coefficients", "FACE", "BACK"]

mi = None  # set on first use (Mitsuba through weavecap.backend)
dr = None

#: the seven colour-free terms, in this order
TERMS = ("body_r", "body_r_tau", "body_s", "body_s_tau", "spec_r", "spec_t", "spec_y")
#: the 14 channels the network predicts: each term's warp part, then its weft part
CHANNELS = tuple(f"{t}_{y}" for t in TERMS for y in ("warp", "weft"))
#: channels that can be non-zero when the light is on the viewer's side (face-frame wo.z > 0):
#: the others need a light below the yarn's local surface, which the horizon hides
REFLECTION_CHANNELS = tuple(i for i, c in enumerate(CHANNELS) if c.startswith(("body_r", "spec_r")))
BODY_CHANNELS = tuple(i for i, c in enumerate(CHANNELS) if c.startswith("body"))
SPECULAR_CHANNELS = tuple(i for i, c in enumerate(CHANNELS) if c.startswith("spec"))

# (colour slot settings) for each eval_surface call: per colour channel, which of R^B, S^B,
# R^S, T^S, T^S_y is 1 (the rest 0); m_r is 1/2 in every call (the body's reflection and
# transmission never meet at one point, so 2× each gives the m_r-free lobe)
_SLOTS = (
    (("rb",), ("sb",), ("rs",)),
    (("ts",), ("ty",), ("rb", "ty")),
    (("sb", "ty"), (), ()),
)


def _backend():
    global mi, dr
    if mi is None:
        from ...model import bysdf as _bysdf

        mi, dr = _bysdf.mi, _bysdf.dr
    return mi, dr


def _slot_colour(call: tuple, key: str):
    return mi.Color3f(*[1.0 if key in channel else 0.0 for channel in call])


def point_terms(shading, point: SurfacePoint, wi, wo) -> list:
    """The seven :data:`TERMS` (Dr.Jit Floats) of the surface BSDF at ``point``.

    Parameters
    ----------
    shading : :class:`weavecap.model.bysdf.Shading` of the fabric (its colours and ``m_r``
        are ignored: they are what the terms leave out)
    point : the maps at the point (:meth:`weavecap.render.bsdf.SurfaceTextures.lookup`, or
        texel values); its ``gain`` multiplies every term
    wi, wo : face-frame unit directions towards the viewer and towards the light

    Returns
    -------
    list of 7 Floats, BSDF × |cos θ_o| like :func:`eval_surface`, in :data:`TERMS` order
    """
    _backend()
    v = []
    for call in _SLOTS:
        p = dataclasses.replace(shading, coefficient=mi.Float(0.5), reflection=_slot_colour(call, "rs"),
                                transmission=_slot_colour(call, "ts"), transmission_exit=_slot_colour(call, "ty"))
        rb, sb = _slot_colour(call, "rb"), _slot_colour(call, "sb")
        value = eval_surface(p, YarnColours(rb, rb, sb, sb), point, wi, wo)
        v.extend([value.x, value.y, value.z])
    body_r, body_s, spec_r, spec_t, spec_y, v_r_ty, v_s_ty = v[0], v[1], v[2], v[3], v[4], v[5], v[6]
    body_r, body_s = 2.0 * body_r, 2.0 * body_s
    body_r_tau = body_r - 2.0 * (v_r_ty - spec_y)
    body_s_tau = body_s - 2.0 * (v_s_ty - spec_y)
    return [body_r, body_r_tau, body_s, body_s_tau, spec_r, spec_t, spec_y]


def colour_coefficients(fabric_colours: dict) -> np.ndarray:
    """(14, 3) coefficients of the :data:`CHANNELS` for each RGB channel: the value is
    ``Σ_k coef[k] · channel[k]`` (Eq. 8 for our model).

    ``fabric_colours``: ``coefficient`` (m_r, float) and RGB triples ``reflection`` (R^S),
    ``transmission`` (T^S), ``transmission_exit`` (T^S_y), ``warp_reflection``,
    ``weft_reflection`` (R^B), ``warp_subsurface``, ``weft_subsurface`` (S^B).
    """
    c = {k: np.clip(np.asarray(v, dtype=np.float64), 0.0, 1.0) for k, v in fabric_colours.items()}
    m_r = float(c["coefficient"])
    keep = 1.0 - c["transmission"]
    ty = c["transmission_exit"]
    coef = {}
    for yarn in ("warp", "weft"):
        rb, sb = c[f"{yarn}_reflection"], c[f"{yarn}_subsurface"]
        coef[f"body_r_{yarn}"] = keep * m_r * rb
        coef[f"body_r_tau_{yarn}"] = -keep * m_r * rb * ty
        coef[f"body_s_{yarn}"] = keep * (1.0 - m_r) * sb
        coef[f"body_s_tau_{yarn}"] = -keep * (1.0 - m_r) * sb * ty
        coef[f"spec_r_{yarn}"] = c["reflection"]
        coef[f"spec_t_{yarn}"] = c["transmission"]
        coef[f"spec_y_{yarn}"] = keep * ty
    return np.stack([np.broadcast_to(coef[name], (3,)) for name in CHANNELS]).astype(np.float64)


def fabric_colours(fabric) -> dict:
    """The colours :func:`colour_coefficients` needs, from a :class:`weavecap.params.Fabric`
    (a body-colour texture stands for its mean colour here)."""
    from ...model.scene import body_texture

    out = {"coefficient": fabric.specular.coefficient, "reflection": fabric.specular.reflection,
           "transmission": fabric.specular.transmission, "transmission_exit": fabric.specular.transmission_exit}
    for yarn in ("warp", "weft"):
        value = fabric.get(f"{yarn}.body_reflection")
        out[f"{yarn}_reflection"] = body_texture(value)[1] if isinstance(value, str) else value
        out[f"{yarn}_subsurface"] = fabric.get(f"{yarn}.body_subsurface")
    return out


def combine(channels: np.ndarray, coefficients: np.ndarray) -> np.ndarray:
    """RGB values (..., 3) from channel values (..., 14) and :func:`colour_coefficients`."""
    return np.asarray(channels, dtype=np.float64) @ coefficients


def split_by_yarn(terms: np.ndarray, warp: np.ndarray) -> np.ndarray:
    """(..., 7) terms and (...) warp shares → (..., 14) :data:`CHANNELS` (warp part, weft part
    of each term)."""
    w = np.asarray(warp)[..., None]
    return np.stack([terms * w, terms * (1.0 - w)], axis=-1).reshape(terms.shape[:-1] + (2 * len(TERMS),))


@dataclass
class ValuesPoint(SurfacePoint):
    """A :class:`~weavecap.render.bsdf.SurfacePoint` that holds its visibility values (a
    texel's, or a footprint's means) instead of reading them from textures."""

    through_values: list = field(default_factory=list)  # 1 + K Floats
    horizon_values: list = field(default_factory=list)  # K Floats

    def through(self, active=True) -> list:
        return self.through_values

    def horizon(self, active=True) -> list:
        return self.horizon_values


def values_point(*, coverage, warp, normal, groove, occlusion, through: list, horizon: list, gain) -> ValuesPoint:
    """A :class:`ValuesPoint` from its values (Dr.Jit Floats; ``normal`` a unit Vector3f)."""
    mi, _ = _backend()
    return ValuesPoint(coverage=coverage, warp=warp, normal=normal, groove=groove, occlusion=occlusion, gain=gain,
                       uv=mi.Point2f(0.0, 0.0), through_0=through[0], textures=[], position=None,
                       through_values=list(through), horizon_values=list(horizon))


def texel_point(maps: SurfaceMaps, side: int, index):
    """The :class:`SurfacePoint` of texels ``index`` (UInt32 into the flattened (H, W) map of
    ``side``): the baked values at the texel centres, no interpolation, gain 1."""
    _backend()
    h, w = maps.shape

    def field(a):
        return mi.Float(np.ascontiguousarray(a[side].reshape(h * w), dtype=np.float32))

    def gather(a):
        return dr.gather(mi.Float, field(a), index)

    nx, ny = gather(maps.normal[..., 0]), gather(maps.normal[..., 1])
    # as SurfaceTextures.lookup rebuilds it: z from x and y, out of the side seen
    normal = mi.Vector3f(nx, ny, dr.sqrt(dr.maximum(1.0 - nx * nx - ny * ny, 1e-4)))
    k = HORIZON_AZIMUTHS
    return values_point(coverage=gather(maps.coverage), warp=gather(maps.warp), normal=dr.normalize(normal),
                        groove=(gather(maps.grooves[..., 0]), gather(maps.grooves[..., 1])),
                        occlusion=gather(maps.occlusion), through=[gather(maps.through[..., j]) for j in range(1 + k)],
                        horizon=[gather(maps.horizon[..., j]) for j in range(k)], gain=mi.Float(1.0))
