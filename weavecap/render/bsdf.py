"""The surface BSDF: the baked maps of :mod:`weavecap.render.surface`, shaded with the BYSDF.

At a point of the garment the fabric's UV gives a place in the repeat; the maps there give the
yarn on top (its warp share, hence its colours), its normal, its groove depths, how much of the
sky its neighbours hide (horizon), and whether light through it from the far side leaves the
fabric (through); the BYSDF of :mod:`weavecap.model.bysdf` (its own functions, not a copy) is
evaluated in the frame of that normal. What the forward model does at a yarn, this does at the
map's texel:

- a light on the viewer's side of the fabric lights the yarn's reflection lobes if it is above
  the yarn's local surface and above the horizon (the forward model's shadow rays);
- a light on the far side lights its transmission lobes where its exit-point ray leaves the
  fabric (the ``through`` map, straight through and tilted as the capture rig's back light);
- a gap (coverage < 1) is a null interaction: :meth:`SurfaceBSDF.eval_null_transmission`
  returns ``1 - coverage`` and :mod:`weavecap.render.integrator` lets that share of the light
  pass straight through (so a back light shows through the gaps);
- under the capture rigs, the ambient light is the forward model's term: the BYSDF's albedo ×
  its occlusion (:func:`ambient_surface`, the BSDF attribute ``"ambient"``);
- the §6.3 noise multiplies the result (:class:`weavecap.render.surface.NoiseMap`).

Frames. :func:`eval_surface`, :func:`sample_surface` and :func:`pdf_surface` work in the
*face frame* of the side seen (x along the fabric's +u, y along +v, z out of that side: the
maps' own frame), so a caller with no mesh (a neural renderer learning this BSDF, a bake for
export) calls them with map lookups (:meth:`SurfaceTextures.lookup`) and directions. The
Mitsuba plugin :class:`SurfaceBSDF` turns a hit's UV and shading frame into those.

Every value returned is BSDF × |cos θ_o| about the yarn's mapped normal (Mitsuba's
convention), finite for any direction.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..model import bysdf as _bysdf
from ..model.scene import SHADING_KEYS, body_texture, parameter_store
from ..model.threads import surface_colours, thread_tables
from ..params import Fabric
from .surface import BACK, FACE, HORIZON_AZIMUTHS, THROUGH_AZIMUTH_DEG, THROUGH_TILT_DEG, NoiseMap, SurfaceMaps

mi = _bysdf.mi
dr = _bysdf.dr

HORIZON_SOFTNESS = 0.05  # width (in sin elevation) over which the horizon hides a light
MIN_FACING = 0.02  # a mapped normal is bent until the viewer sees it at least this much
AMBIENT = "ambient"  # the attribute :mod:`weavecap.render.integrator` asks for the rigs' ambient term


def opaque(value: float):
    """A Dr.Jit Float held in memory rather than compiled into a kernel as a constant: a
    kernel that reads it serves every value (a new fabric, pitch or texel count compiles
    nothing), where a Python float would be a new kernel each time."""
    v = mi.Float(float(value))
    dr.make_opaque(v)
    return v


@dataclass(frozen=True)
class Placement:
    """How the fabric lies on a mesh's texture coordinates.

    Attributes
    ----------
    repeat_size : (width, height) of one pattern repeat in the mesh's UV units (metres for
        meshes read by :mod:`weavecap.render.mesh`): ``n_a · pitch`` and ``n_e · pitch``
    angle_deg : the weave is turned counter-clockwise by this angle on the surface
    offset : (u, v) shift of the weave, in repeats
    """

    repeat_size: tuple[float, float]
    angle_deg: float = 0.0
    offset: tuple[float, float] = (0.0, 0.0)


@dataclass
class SurfacePoint:
    """What the maps say at a point, as Dr.Jit values (one lane per point). The visibility
    maps are read only when asked for, and only for the lanes asked about (:meth:`horizon`,
    :meth:`through`): a light is on one side of the fabric or the other, never both."""

    coverage: object  # Float
    warp: object  # Float, the warp share of the yarn on top
    normal: object  # Vector3f, face frame, unit
    groove: tuple  # (Float, Float): groove depths between plies, between fibres
    occlusion: object  # Float, the forward model's ambient occlusion
    gain: object  # Float, the §6.3 noise gain (1 without noise)
    uv: object  # Point2f, (s, -t): the position in the repeat's image (body-colour textures)
    through_0: object  # Float, light straight through the yarn leaves the fabric
    textures: list  # the visibility textures (the tilted `through` ring, then the horizon)
    position: object  # Point2f, the texture position they are read at

    def through(self, active=True) -> list:
        """1 + K Floats: light through the yarn leaves the fabric, straight and tilted."""
        ring = [x for tex in self.textures[:2] for x in tex.eval(self.position, active)]
        return [self.through_0] + ring

    def horizon(self, active=True) -> list:
        """K Floats: sine of the horizon elevation per azimuth."""
        return [x for tex in self.textures[2:] for x in tex.eval(self.position, active)]


#: the maps' channels in the order they are packed into 4-channel textures
CHANNELS = ("normal_x", "normal_y", "coverage", "warp", "groove_p", "groove_f", "occlusion") + tuple(
    f"through_{k}" for k in range(1 + HORIZON_AZIMUTHS)) + tuple(f"horizon_{k}" for k in range(HORIZON_AZIMUTHS))


def _channels(maps: SurfaceMaps) -> np.ndarray:
    """(2, H, W, len(CHANNELS)) float32: the maps the BSDF reads, in CHANNELS order (the
    normal's z follows from x and y: it points out of the side seen)."""
    return np.concatenate([maps.normal[..., :2], maps.coverage[..., None], maps.warp[..., None], maps.grooves,
                           maps.occlusion[..., None], maps.through, maps.horizon], axis=-1).astype(np.float32)


def _stack_sides(face: np.ndarray, back: np.ndarray) -> np.ndarray:
    """Face and back maps (H, W, C) as one image: each side padded by its wrapped last and
    first rows, so linear filtering wraps within a side and never blends the two."""
    pad = lambda a: np.concatenate([a[-1:], a, a[:1]], axis=0)  # noqa: E731
    return np.ascontiguousarray(np.concatenate([pad(face), pad(back)], axis=0), dtype=np.float32)


def _hat(values: list, phi):
    """Values at azimuths 2πj/K interpolated at ``phi`` (in azimuth steps, [0, K))."""
    k = len(values)
    out = mi.Float(0.0)
    for j, v in enumerate(values):
        dist = dr.abs(phi - j)
        out += v * dr.maximum(1.0 - dr.minimum(dist, k - dist), 0.0)
    return out


def _azimuth(w, start_deg: float = 0.0):
    """The azimuth of ``w`` from ``start_deg`` in steps of the maps' azimuths, in [0, K)."""
    k = HORIZON_AZIMUTHS
    phi = (dr.atan2(w.y, w.x) - math.radians(start_deg)) * (k / (2.0 * math.pi))
    return phi - k * dr.floor(phi / k)


class SurfaceTextures:
    """The maps of one fabric as Dr.Jit textures, looked up at fabric coordinates.

    The CHANNELS packed four to a texture (the first two hold what every shading call needs, the
    others the visibility maps, read lane by lane as needed), both sides stacked, wrapping over
    the repeat, and
    the coverage alone (the face's: a vertical ray meets a yarn from either side or from
    neither) for null interactions; the noise gain, when there is one, tiles over its own
    period. ``linear`` filtering interpolates between texels, for views where a texel covers a
    good part of a pixel or more; nearest-texel lookups cost a quarter as many memory reads and
    are what the pixel's samples average anyway when many texels fall in a pixel.
    """

    def __init__(self, maps: SurfaceMaps, noise: NoiseMap | None = None, *, linear: bool = True):
        self.maps = maps
        self.rows = opaque(maps.shape[0])
        self.linear = linear
        mode = dr.FilterMode.Linear if linear else dr.FilterMode.Nearest
        data = _channels(maps)
        self.textures = [mi.Texture2f(mi.TensorXf(_stack_sides(data[FACE, ..., c:c + 4], data[BACK, ..., c:c + 4])),
                                      filter_mode=mode, wrap_mode=dr.WrapMode.Repeat)
                         for c in range(0, data.shape[-1], 4)]
        self.coverage_texture = mi.Texture2f(mi.TensorXf(np.ascontiguousarray(maps.coverage[FACE, ..., None])),
                                             filter_mode=mode, wrap_mode=dr.WrapMode.Repeat)
        self.noise = None
        if noise is not None:
            self.noise = mi.Texture2f(mi.TensorXf(noise.gain[..., None]), filter_mode=dr.FilterMode.Linear,
                                      wrap_mode=dr.WrapMode.Repeat)
            self.noise_repeats = opaque(noise.repeats)

    def coverage(self, s, t):
        """The coverage (opacity) at fabric coordinates ``(s, t)``: one texture read."""
        return dr.clip(self.coverage_texture.eval(mi.Point2f(s, -t))[0], 0.0, 1.0)

    def lookup(self, s, t, back) -> SurfacePoint:
        """The maps at fabric coordinates ``(s, t)`` (Float, in repeats: ``s`` along +u, ``t``
        along +v) on the face (``back`` False) or the back (Bool) of the fabric."""
        rows = self.rows
        y_in = -t - dr.floor(-t)  # image rows run down, v up
        side = dr.select(back, rows + 2.0, 0.0)
        pos = mi.Point2f(s, (side + 1.0 + y_in * rows) / (2.0 * (rows + 2.0)))
        values = [x for tex in self.textures[:2] for x in tex.eval(pos)]  # the first 8 channels
        c = dict(zip(CHANNELS, values))
        nx, ny = c["normal_x"], c["normal_y"]
        normal = dr.normalize(mi.Vector3f(nx, ny, dr.sqrt(dr.maximum(1.0 - nx * nx - ny * ny, 1e-4))))
        gain = mi.Float(1.0)
        if self.noise is not None:
            gain = self.noise.eval(mi.Point2f(s / self.noise_repeats, -t / self.noise_repeats))[0]
        return SurfacePoint(coverage=dr.clip(c["coverage"], 0.0, 1.0), warp=dr.clip(c["warp"], 0.0, 1.0),
                            normal=normal, groove=(c["groove_p"], c["groove_f"]), occlusion=c["occlusion"],
                            gain=gain, uv=mi.Point2f(s, -t), through_0=c["through_0"], textures=self.textures[2:],
                            position=pos)


@dataclass
class YarnColours:
    """Body colours of the warp and the weft (``mi.Color3f``, or a texture over the repeat), or
    per thread where a family has a colour order (``threads``:
    :func:`weavecap.model.threads.thread_tables`, over a repeat of ``shape``)."""

    warp_reflection: object
    weft_reflection: object
    warp_subsurface: object
    weft_subsurface: object
    warp_texture: object = None
    weft_texture: object = None
    threads: dict | None = None
    shape: tuple[int, int] = (1, 1)

    def at(self, point: SurfacePoint):
        """(R^B, S^B) at a point: the warp's and the weft's colours (its threads' where they
        have a colour order) mixed by its warp share."""
        w = point.warp
        warp_r = self.warp_reflection if self.warp_texture is None else mi.Color3f(self.warp_texture.eval(point.uv))
        weft_r = self.weft_reflection if self.weft_texture is None else mi.Color3f(self.weft_texture.eval(point.uv))
        warp_s, weft_s = self.warp_subsurface, self.weft_subsurface
        if self.threads:
            own = surface_colours(self.threads, self.shape, point.uv.x, -point.uv.y)
            warp_r, warp_s = own.get("warp", (warp_r, warp_s))
            weft_r, weft_s = own.get("weft", (weft_r, weft_s))
        return (w * warp_r + (1.0 - w) * weft_r, w * warp_s + (1.0 - w) * weft_s)


def shading_of(fabric: Fabric) -> tuple[_bysdf.Shading, YarnColours]:
    """The BYSDF parameters and yarn colours of ``fabric`` as opaque Dr.Jit values."""
    store = parameter_store(fabric)
    shading = _bysdf.Shading(**{sk: store[fk] for sk, fk in SHADING_KEYS.items()})
    textures = {}
    for yarn in ("warp", "weft"):
        value = fabric.get(f"{yarn}.body_reflection")
        if isinstance(value, str):
            textures[yarn], mean = body_texture(value)
            store[f"{yarn}.body_reflection"] = mi.Color3f(*mean)
    colours = YarnColours(warp_reflection=store["warp.body_reflection"], weft_reflection=store["weft.body_reflection"],
                          warp_subsurface=store["warp.body_subsurface"], weft_subsurface=store["weft.body_subsurface"],
                          warp_texture=textures.get("warp"), weft_texture=textures.get("weft"),
                          threads=thread_tables(fabric), shape=fabric.shape)
    return shading, colours


def horizon_visibility(point: SurfacePoint, w, active=True):
    """How much of a light in face-frame direction ``w`` (z > 0) the neighbouring yarns leave
    visible, in [0, 1]: ``w``'s elevation against the point's horizon, interpolated between
    its azimuths (maps read for the ``active`` lanes only)."""
    h = _hat(point.horizon(active), _azimuth(w))
    return dr.clip((w.z - h) / HORIZON_SOFTNESS + 0.5, 0.0, 1.0)


def through_visibility(point: SurfacePoint, w, active=True):
    """How much light from the far side, arriving from face-frame direction ``w`` (z < 0),
    passes the yarn at ``point`` and leaves the fabric towards the viewer, in [0, 1]: the
    ``through`` map interpolated between straight through and its tilted ring (in tilt, up to
    THROUGH_TILT_DEG, held beyond) and between the ring's azimuths."""
    tilt = dr.acos(dr.clip(-w.z, -1.0, 1.0))
    a = dr.clip(tilt / math.radians(THROUGH_TILT_DEG), 0.0, 1.0)
    through = point.through(active)
    ring = _hat(through[1:], _azimuth(w, THROUGH_AZIMUTH_DEG))
    return dr.clip((1.0 - a) * through[0] + a * ring, 0.0, 1.0)


def _facing_normal(normal, wi):
    """The mapped normal, bent in the plane of itself and ``wi`` until ``wi`` sees it from at
    least MIN_FACING (a normal map can tilt a texel away from a grazing viewer)."""
    lack = MIN_FACING - dr.dot(normal, wi)
    return dr.normalize(dr.select(lack > 0.0, normal + lack * wi, normal))


def eval_surface(p: _bysdf.Shading, colours: YarnColours, point: SurfacePoint, wi, wo):
    """BSDF × |cos θ_o| of the surface (Color3f), without its null part.

    Parameters
    ----------
    p : the shared BYSDF parameters; colours : the yarns' body colours
    point : the maps at the point (:meth:`SurfaceTextures.lookup`)
    wi, wo : Vector3f, unit, in the face frame of the side seen (``wi.z >= 0``): towards the
        viewer and towards the light
    """
    frame = mi.Frame3f(_facing_normal(point.normal, wi))
    wv, wl = frame.to_local(wi), frame.to_local(wo)
    body_r, body_s = colours.at(point)
    value = _bysdf.eval_bysdf(p, body_r, body_s, None, wv, wl, groove=point.groove)
    same_side = wo.z > 0.0
    # the viewer's side: lit above the yarn's own surface and the neighbours' horizon;
    # the far side: through the yarn where its exit-point ray leaves the fabric
    lit_above = same_side & (wl.z > 0.0)
    visible = dr.select(same_side, dr.select(lit_above, horizon_visibility(point, wo, lit_above), 0.0),
                        through_visibility(point, wo, ~same_side))
    out = value * (visible * point.coverage * point.gain)
    return dr.select((wi.z > 0.0) & dr.isfinite(out.x + out.y + out.z), out, 0.0)


def ambient_surface(p: _bysdf.Shading, colours: YarnColours, point: SurfacePoint, wi):
    """The radiance (Color3f) the surface returns under the capture rigs' ambient light of
    radiance 1, as the forward model evaluates it: the BYSDF's directional albedo times the
    forward model's ambient occlusion (``wi`` in the face frame; no null part)."""
    frame = mi.Frame3f(_facing_normal(point.normal, wi))
    body_r, body_s = colours.at(point)
    albedo = _bysdf.albedo_bysdf(p, body_r, body_s, None, frame.to_local(wi).z, groove=point.groove)
    return albedo * (point.occlusion * point.coverage * point.gain)


def pdf_surface(p: _bysdf.Shading, colours: YarnColours, point: SurfacePoint, wi, wo):
    """Solid-angle density with which :func:`sample_surface` produces ``wo`` (face frame)."""
    frame = mi.Frame3f(_facing_normal(point.normal, wi))
    body_r, body_s = colours.at(point)
    return _bysdf.pdf_bysdf(p, body_r, body_s, frame.to_local(wi), frame.to_local(wo))


def sample_surface(p: _bysdf.Shading, colours: YarnColours, point: SurfacePoint, wi, sample1, sample2):
    """Sample a light direction by the BYSDF's lobes in the mapped normal's frame.

    Returns ``(wo, pdf, value, lobe)``: the direction (face frame), its density, the
    :func:`eval_surface` value there and the BYSDF lobe index (0–4, as ``sample_bysdf``).
    """
    frame = mi.Frame3f(_facing_normal(point.normal, wi))
    body_r, body_s = colours.at(point)
    wl, pdf, lobe = _bysdf.sample_bysdf(p, body_r, body_s, frame.to_local(wi), sample1, sample2)
    wo = frame.to_world(wl)
    return wo, pdf, eval_surface(p, colours, point, wi, wo), lobe


class SurfaceBSDF(mi.BSDF):
    """Mitsuba 3 BSDF of a fabric's surface model on a mesh (made in Python, not by name).

    ``SurfaceBSDF(fabric, maps, placement, noise=None, linear=True)`` (``linear``: texture
    filtering, see :class:`SurfaceTextures`). The hit's texture coordinates
    (``si.uv``, metres for meshes from :mod:`weavecap.render.mesh`) place it in the repeat
    through ``placement``; its shading frame (``s`` along the UV's +u) orients the maps. Both
    sides of a mesh show the fabric: the face on the side its normals point to.
    """

    def __init__(self, fabric: Fabric, maps: SurfaceMaps, placement: Placement, noise: NoiseMap | None = None, *,
                 linear: bool = True):
        mi.BSDF.__init__(self, mi.Properties())
        self.shading, self.colours = shading_of(fabric)
        self.textures = SurfaceTextures(maps, noise, linear=linear)
        self.placement = placement
        theta = math.radians(placement.angle_deg)
        # read from memory, not compiled in: a new fabric, pitch or angle reuses the kernels
        self._cos, self._sin = opaque(math.cos(theta)), opaque(math.sin(theta))
        self._per_repeat = (opaque(1.0 / placement.repeat_size[0]), opaque(1.0 / placement.repeat_size[1]))
        self._offset = (opaque(placement.offset[0]), opaque(placement.offset[1]))
        reflection = (mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.DiffuseReflection
                      | mi.BSDFFlags.FrontSide | mi.BSDFFlags.BackSide)
        transmission = (mi.BSDFFlags.GlossyTransmission | mi.BSDFFlags.DiffuseTransmission | mi.BSDFFlags.Null
                        | mi.BSDFFlags.FrontSide | mi.BSDFFlags.BackSide)
        self.m_components = [reflection, transmission]
        self.m_flags = reflection | transmission

    # -- from a hit to the face frame ---------------------------------------------------------

    def _to_face(self, w, back):
        """A shading-frame direction in the face frame of the side seen."""
        c, s = self._cos, self._sin
        return mi.Vector3f(c * w.x + s * w.y, -s * w.x + c * w.y, dr.select(back, -w.z, w.z))

    def _from_face(self, w, back):
        c, s = self._cos, self._sin
        return mi.Vector3f(c * w.x - s * w.y, s * w.x + c * w.y, dr.select(back, -w.z, w.z))

    def _fabric_uv(self, si):
        """The hit's fabric coordinates (s, t), in repeats."""
        c, s = self._cos, self._sin
        fs = (c * si.uv.x + s * si.uv.y) * self._per_repeat[0] + self._offset[0]
        ft = (-s * si.uv.x + c * si.uv.y) * self._per_repeat[1] + self._offset[1]
        return fs, ft

    def point(self, si) -> tuple[SurfacePoint, object]:
        """The maps at a hit, and whether it is seen from the back."""
        back = si.wi.z < 0.0
        return self.textures.lookup(*self._fabric_uv(si), back), back

    # -- the BSDF interface ---------------------------------------------------------------------

    def eval(self, ctx, si, wo, active=True):
        point, back = self.point(si)
        value = eval_surface(self.shading, self.colours, point, self._to_face(si.wi, back), self._to_face(wo, back))
        return dr.select(active, value, 0.0)

    def pdf(self, ctx, si, wo, active=True):
        point, back = self.point(si)
        pdf = pdf_surface(self.shading, self.colours, point, self._to_face(si.wi, back), self._to_face(wo, back))
        return dr.select(active, pdf, 0.0)

    def eval_pdf(self, ctx, si, wo, active=True):
        point, back = self.point(si)
        wi_f, wo_f = self._to_face(si.wi, back), self._to_face(wo, back)
        value = eval_surface(self.shading, self.colours, point, wi_f, wo_f)
        pdf = pdf_surface(self.shading, self.colours, point, wi_f, wo_f)
        return dr.select(active, value, 0.0), dr.select(active, pdf, 0.0)

    def sample(self, ctx, si, sample1, sample2, active=True):
        point, back = self.point(si)
        wo_f, pdf, value, lobe = sample_surface(self.shading, self.colours, point, self._to_face(si.wi, back),
                                                sample1, sample2)
        bs = mi.BSDFSample3f()
        bs.wo = self._from_face(wo_f, back)
        bs.pdf = pdf
        bs.eta = 1.0
        reflected = wo_f.z > 0.0
        bs.sampled_component = dr.select(reflected, 0, 1)
        diffuse = lobe >= 3
        bs.sampled_type = mi.UInt32(+dr.select(
            reflected,
            dr.select(diffuse, mi.UInt32(+mi.BSDFFlags.DiffuseReflection), mi.UInt32(+mi.BSDFFlags.GlossyReflection)),
            dr.select(diffuse, mi.UInt32(+mi.BSDFFlags.DiffuseTransmission),
                      mi.UInt32(+mi.BSDFFlags.GlossyTransmission))))
        ok = active & (pdf > 0.0)
        return bs, dr.select(ok, value / dr.select(ok, pdf, 1.0), 0.0)

    def eval_null_transmission(self, si, active=True):
        """1 - coverage: the gaps let light through unchanged (needs only ``si.uv``)."""
        return dr.select(active, mi.Color3f(1.0 - self.textures.coverage(*self._fabric_uv(si))), 0.0)

    def has_attribute(self, name, active=True):
        return mi.Bool(name == AMBIENT)

    def eval_attribute_3(self, name, si, active=True):
        """``"ambient"``: :func:`ambient_surface` at the hit (the capture rigs' ambient term)."""
        if name != AMBIENT:
            return mi.Color3f(0.0)
        point, back = self.point(si)
        return dr.select(active, ambient_surface(self.shading, self.colours, point, self._to_face(si.wi, back)), 0.0)

    def traverse(self, callback):
        for key, value in vars(self.shading).items():
            callback.put(key, value, mi.ParamFlags.Differentiable)

    def parameters_changed(self, keys):
        for value in vars(self.shading).values():
            dr.make_opaque(value)

    def to_string(self):
        n_e, n_a = self.textures.maps.pattern_shape
        return (f"SurfaceBSDF[{n_e}x{n_a} repeat of {self.placement.repeat_size[0]:g} x "
                f"{self.placement.repeat_size[1]:g}, {self.textures.maps.texels_per_yarn} texels/yarn]")
