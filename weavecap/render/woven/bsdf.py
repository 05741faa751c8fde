"""The woven neural BSDF on a mesh: the decoder at the pixel's footprint (Chen et al. §4.3).

:class:`NeuralSurfaceBSDF` stands where :class:`weavecap.render.bsdf.SurfaceBSDF` does (same
placement of the repeat on the mesh's UVs, same face/back convention and face frame), but its
``eval`` returns the network's *footprint-filtered* surface BSDF: the footprint is the pixel's,
from the ray differentials the integrator puts on the hit (``si.duv_dx``, ``si.duv_dy``, by
``si.compute_uv_partials``; none: a point), turned into fabric coordinates; the decoder gets
its centre, its side in yarn pitches (√ of its area: the parallelogram as a square of the same
area), its box-filtered map statistics and the two directions, and returns the 14 colour-free
channels, which the fabric's colours weigh (:func:`.terms.colour_coefficients`, exact).

- Colours are not in the latent: :meth:`set_colours` changes them with no encoding;
  :meth:`set_fabric` re-encodes when the pattern, radii or a shading parameter changed.
- Gaps: ``eval_null_transmission`` is 1 − the footprint's mean coverage (exact, from its
  summed-area table), so a pixel half over a gap lets half the light through.
- The §6.3 noise gain is box-filtered over the footprint the same way.
- The capture rigs' ambient term (BSDF attribute ``"ambient"``) is the surface model's
  :func:`~weavecap.render.bsdf.ambient_surface` at the footprint's mean maps (exact for a
  point; a mean of normals for a big footprint).
- ``sample``/``pdf`` are the surface model's (:class:`~weavecap.render.bsdf.SurfaceBSDF`'s, at
  the footprint centre), weighted by the network's value, so any integrator can use it; the
  neural integrator (:mod:`.integrator`) only evaluates it towards lights.
"""

from __future__ import annotations

import numpy as np

from ...params import Fabric
from ..bsdf import AMBIENT, Placement, SurfaceBSDF, SurfacePoint, ambient_surface, opaque, shading_of
from ..surface import NoiseMap, SurfaceMaps
from ...model.threads import surface_colours, thread_tables
from . import terms as _terms
from .footprint import baseline_channels, filtered_point
from .infer import BoxFilter, Decoder, FabricLatents, coverage_filter, footprint_filter, load_weights

mi, dr = _terms._backend()

_MODEL: dict = {}  # the loaded weights and encoder, shared by every BSDF of a process


def shared_model(path=None) -> tuple[dict, dict, FabricLatents]:
    """(arrays, record, encoder) of the weights at ``path`` (default: the shipped ones),
    loaded once per process."""
    key = str(path)
    if key not in _MODEL:
        arrays, record = load_weights(path)
        _MODEL[key] = (arrays, record, FabricLatents(arrays, record))
    return _MODEL[key]


class NeuralSurfaceBSDF(SurfaceBSDF):
    """``NeuralSurfaceBSDF(fabric, maps, placement, noise=None, weights=None)``: see the
    module docstring. A :class:`~weavecap.render.bsdf.SurfaceBSDF` (its placement, frames and
    sampling) whose values are the network's."""

    def __init__(self, fabric: Fabric, maps: SurfaceMaps, placement: Placement, noise: NoiseMap | None = None, *,
                 weights=None):
        SurfaceBSDF.__init__(self, fabric, maps, placement, None)
        self.arrays, self.record, self.encoder = shared_model(weights)
        train = self.record.get("train", {})
        self.use_features = bool(train.get("use_features", True))
        self.use_baseline = bool(train.get("use_baseline", True))
        self.maps = maps
        self.features = footprint_filter(maps)
        self.coverage_box = coverage_filter(maps)
        occ = [np.ascontiguousarray((maps.coverage[s] * maps.occlusion[s])[..., None]) for s in (0, 1)]
        self.occlusion = BoxFilter(occ)
        self.noise = None
        if noise is not None:
            self.noise = BoxFilter([noise.gain[..., None]])
            self.noise_repeats = opaque(noise.repeats)
        self.pattern_shape = fabric.shape
        n_e, n_a = fabric.shape
        self._yarns = opaque(n_a * n_e)  # yarns² in a repeat (footprint areas in yarn pitches²)
        self._warps = opaque(n_a)
        self._map_size = (opaque(maps.shape[0]), opaque(maps.shape[1]))
        self._texels_per_yarn = opaque(maps.texels_per_yarn)
        self.set_fabric(fabric)

    # -- editing ------------------------------------------------------------------------------

    def set_fabric(self, fabric: Fabric) -> None:
        """Encode ``fabric`` (its pattern must be the maps') and set its colours. The maps
        are not re-baked here: a new pattern or radius needs new maps (a new BSDF)."""
        if fabric.shape != self.pattern_shape:
            raise ValueError(f"the maps are of a {self.pattern_shape} repeat, the fabric's is {fabric.shape}")
        self.latents = self.encoder.encode(self.maps, fabric)
        self.decoder = Decoder(self.arrays, self.latents, use_features=self.use_features,
                               use_baseline=self.use_baseline)
        self.shading, self.colours = shading_of(fabric)
        self.threads = thread_tables(fabric)  # per-thread colours weigh their family's body channels in query
        self.set_colours({**_terms.fabric_colours(fabric),
                          **{f"{f}_{k}": (1.0, 1.0, 1.0) for f in self.threads for k in ("reflection", "subsurface")}})

    def set_colours(self, colours: dict) -> None:
        """New colours (the dict of :func:`.terms.fabric_colours`): no encoding, no kernel
        recompile (the coefficients are opaque)."""
        coef = _terms.colour_coefficients(colours)
        self.coefficients = [mi.Color3f(*(float(v) for v in row)) for row in coef]
        for c in self.coefficients:
            dr.make_opaque(c)

    # -- geometry -----------------------------------------------------------------------------

    def _repeats(self, u, v):
        """A UV vector (mesh units) in repeats along the fabric's s and t (no offset)."""
        c, s = self._cos, self._sin
        return (c * u + s * v) * self._per_repeat[0], (-s * u + c * v) * self._per_repeat[1]

    def footprint(self, si):
        """(s, t, size): the hit's fabric coordinates (repeats) and its footprint's side in
        yarn pitches (0 without ray differentials)."""
        fs, ft = self._fabric_uv(si)
        dsx, dtx = self._repeats(si.duv_dx.x, si.duv_dx.y)
        dsy, dty = self._repeats(si.duv_dy.x, si.duv_dy.y)
        area = dr.abs(dsx * dty - dsy * dtx) * self._yarns
        size = dr.sqrt(area)
        return fs, ft, dr.select(dr.isfinite(size), size, 0.0)

    def _texel(self, s, t, size):
        h, w = self._map_size
        return s * w, -t * h, 0.5 * size * self._texels_per_yarn

    def _gain(self, s, t, size):
        if self.noise is None:
            return mi.Float(1.0)
        h, w = self.noise.size
        r = self.noise_repeats
        return self.noise.mean(s / r * w, -t / r * h, 0.5 * size * w / (r * self._warps))[0]

    # -- values -------------------------------------------------------------------------------

    def query(self, s, t, size, wi, wo, back):
        """The network's footprint-filtered BSDF × |cos| (Color3f) for footprints centred at
        fabric coordinates (s, t) (repeats) of side ``size`` (yarn pitches, 0: a point),
        face-frame directions ``wi`` (viewer, z > 0) and ``wo`` (light), on the back where
        ``back`` (Bool) — no mesh needed."""
        x, y, half = self._texel(s, t, size)
        features = self.features.mean(x, y, half, back)
        baseline = baseline_channels(self.shading, features, wi, wo) if self.use_baseline else None
        values = self.decoder.values(s, t, size, wi, wo, features, back, baseline)
        # a family with a colour order: its threads' mean colours over the footprint
        tint = surface_colours(self.threads, self.pattern_shape, s, t, 0.5 * size)
        rgb = mi.Color3f(0.0)
        for name, coef, v in zip(_terms.CHANNELS, self.coefficients, values):
            family = name.rsplit("_", 1)[1]
            if family in tint and name.startswith("body"):
                coef = coef * tint[family][0 if name.startswith("body_r") else 1]
            rgb += coef * v
        rgb *= self._gain(s, t, size)
        return dr.select((wi.z > 0.0) & dr.isfinite(rgb.x + rgb.y + rgb.z), rgb, 0.0)

    def neural(self, si, wo, active):
        """:meth:`query` at a hit's footprint, towards world-local ``wo``."""
        back = si.wi.z < 0.0
        s, t, size = self.footprint(si)
        value = self.query(s, t, size, self._to_face(si.wi, back), self._to_face(wo, back), back)
        return dr.select(active, value, 0.0)

    def coverage(self, si):
        """The footprint's mean coverage."""
        back = si.wi.z < 0.0
        s, t, size = self.footprint(si)
        x, y, half = self._texel(s, t, size)
        return dr.clip(self.coverage_box.mean(x, y, half, back)[0], 0.0, 1.0)

    def _filtered_point(self, si) -> SurfacePoint:
        """The maps' footprint means as a SurfacePoint (:func:`.footprint.filtered_point`,
        with the footprint's mean occlusion and noise gain), for the ambient term."""
        back = si.wi.z < 0.0
        s, t, size = self.footprint(si)
        x, y, half = self._texel(s, t, size)
        features = self.features.mean(x, y, half, back)
        point = filtered_point(features)
        point.occlusion = self.occlusion.mean(x, y, half, back)[0] / dr.maximum(features[0], 1e-6)
        point.gain = self._gain(s, t, size)
        point.uv = mi.Point2f(s, -t)  # where the thread colours are read
        return point

    # -- the BSDF interface -------------------------------------------------------------------

    def eval(self, ctx, si, wo, active=True):
        return self.neural(si, wo, active)

    def eval_pdf(self, ctx, si, wo, active=True):
        return self.eval(ctx, si, wo, active), self.pdf(ctx, si, wo, active)

    def sample(self, ctx, si, sample1, sample2, active=True):
        """The surface model's sampling (:meth:`SurfaceBSDF.sample`), the network's value."""
        bs, _ = SurfaceBSDF.sample(self, ctx, si, sample1, sample2, active)
        ok = active & (bs.pdf > 0.0)
        value = self.neural(si, bs.wo, ok)
        return bs, dr.select(ok, value / dr.select(ok, bs.pdf, 1.0), 0.0)

    def eval_null_transmission(self, si, active=True):
        return dr.select(active, mi.Color3f(1.0 - self.coverage(si)), 0.0)

    def has_attribute(self, name, active=True):
        return mi.Bool(name == AMBIENT)

    def eval_attribute_3(self, name, si, active=True):
        if name != AMBIENT:
            return mi.Color3f(0.0)
        back = si.wi.z < 0.0
        value = ambient_surface(self.shading, self.colours, self._filtered_point(si), self._to_face(si.wi, back))
        return dr.select(active, value, 0.0)

    def to_string(self):
        n_e, n_a = self.pattern_shape
        return f"NeuralSurfaceBSDF[{n_e}x{n_a} repeat, woven network {self.record.get('format', '?')}]"
