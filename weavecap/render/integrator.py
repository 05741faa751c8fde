"""The reference renderer: a unidirectional path tracer over Mitsuba 3's ray queries.

Mitsuba's own ``path`` integrator treats every surface as opaque to shadow rays, so light
could never reach a garment through the gaps between its yarns. This one is ``path`` with the
null interactions the surface model needs (one file over Mitsuba's ``SamplingIntegrator``, as
Mitsuba's ``python/ad/integrators`` are written):

- at a hit, a share ``eval_null_transmission`` of the light passes straight through (a gap
  in the weave); the path picks that share at random and goes on without scattering (at most
  MAX_NULL such crossings a path);
- shadow rays of next-event estimation pass through the same gaps, their throughput
  multiplied by each crossing's null transmission (deterministic, no noise);
- otherwise it is ``path``: emitter sampling and BSDF sampling combined by multiple
  importance sampling (power heuristic), Russian roulette from ``rr_depth``, at most
  ``max_depth`` vertices (``max_depth = 2`` is direct lighting only);
- ``ambient``: the §6.4 rigs' ambient light of this radiance, evaluated as the forward model
  does (no rays): each scattering vertex adds the BSDF's ``"ambient"`` attribute (the
  surface model's albedo × occlusion), or for other BSDFs its sampled weight;
- ``background``: the radiance a camera ray sees when it leaves the scene without having
  scattered (through gaps too), in place of the environment's. The capture rigs of §6.4 use
  it for the lit panel behind the swatch, which the forward model shows through the gaps but
  does not light the yarns with.

Everything is deterministic for a given ``mi.render(..., seed=)``.
"""

from __future__ import annotations

from ..model import bysdf as _bysdf

mi = _bysdf.mi
dr = _bysdf.dr

AMBIENT = "ambient"  # the BSDF attribute of the rigs' ambient term (weavecap.render.bsdf.AMBIENT)
MAX_NULL = 16  # gaps crossed by one path segment or shadow ray before it counts as blocked


def _mis(pdf_a, pdf_b):
    """Power heuristic weight of strategy a."""
    a2 = dr.square(pdf_a)
    w = a2 / (a2 + dr.square(pdf_b))
    return dr.select(dr.isfinite(w) & (pdf_a > 0.0), w, 0.0)


def _grey(spectrum):
    return (spectrum[0] + spectrum[1] + spectrum[2]) / 3.0


class FabricPathIntegrator(mi.SamplingIntegrator):
    """Plugin ``"weavecap_path"``: properties ``max_depth`` (int, default 8; -1 unlimited),
    ``rr_depth`` (int, default 5), ``ambient`` (float, default 0), ``background`` (RGB;
    default: the environment's radiance)."""

    def __init__(self, props):
        mi.SamplingIntegrator.__init__(self, props)
        max_depth = int(props.get("max_depth", 8))
        self.max_depth = max_depth if max_depth >= 0 else 2**31 - 1
        self.rr_depth = int(props.get("rr_depth", 5))
        self.ambient = float(props.get("ambient", 0.0))
        self.ambient_radiance = mi.Float(self.ambient)  # read from memory: every rig shares the kernels
        self.has_background = "background" in props
        background = props.get("background", 0.0)
        self.background = mi.Color3f(*background) if hasattr(background, "__len__") else mi.Color3f(float(background))
        dr.make_opaque(self.ambient_radiance, self.background)

    @staticmethod
    def _bsdfs(scene) -> tuple[list, bool]:
        """The scene's :class:`weavecap.render.bsdf.SurfaceBSDF` instances (the neural one
        included), whose methods :meth:`_call` traces inline, and whether every shape has one."""
        from .bsdf import SurfaceBSDF

        found, only = [], True
        for shape in scene.shapes():
            bsdf = shape.bsdf()
            if not isinstance(bsdf, SurfaceBSDF):
                only = False
            elif not any(bsdf is b for b in found):
                found.append(bsdf)
        return found, only

    @staticmethod
    def _call(bsdfs, bsdf, active, method: str, *args):
        """``bsdf.method(*args, active)`` for the hits' BSDFs (``bsdfs`` from :meth:`_bsdfs`):
        a surface BSDF's Python method traced inline, any other BSDF by Mitsuba's virtual call.

        Mitsuba's virtual call traces the method of *every* BSDF instance alive in the process
        into the kernel, masked-off bodies included: the neural decoder ran 7.5× slower that
        way, and in a process that had made other renders (a batch, the tests) each new render
        compiled the bodies of every BSDF still alive — a new, ever larger kernel each time.
        A scene whose only BSDF is one surface BSDF (a garment, without ``--ground``) makes
        no call at all, and no instance's address enters its kernel, so the next render of
        another fabric reuses it."""
        instances, only = bsdfs
        active = mi.Bool(active)
        if only and len(instances) == 1:
            return getattr(instances[0], method)(*args, active)
        other = mi.Bool(active)
        out = None
        for b in instances:
            mine = active & (bsdf == mi.BSDFPtr(b))
            other &= ~mine
            value = getattr(b, method)(*args, mine)
            out = value if out is None else dr.select(mine, value, out)
        if only and out is not None:
            return out
        value = getattr(bsdf, method)(*args, other)
        return value if out is None else dr.select(other, value, out)

    @dr.syntax
    def transmittance(self, scene, si, ds, active, bsdfs=None):
        """Light reaching ``si`` from the emitter sample ``ds`` through the gaps on the way
        (Color3f; 0 when an opaque surface is in the way)."""
        bsdfs = bsdfs if bsdfs is not None else self._bsdfs(scene)
        ray = si.spawn_ray(ds.d)
        ray.maxt = dr.select(dr.isfinite(ds.dist), ds.dist * (1.0 - mi.math.ShadowEpsilon), dr.largest(mi.Float))
        throughput = mi.Color3f(1.0)
        crossings = mi.UInt32(0)
        active = mi.Bool(active)
        while active:
            hit = scene.ray_intersect(ray, mi.RayFlags.Minimal | mi.RayFlags.UV, False, active)
            blocked = active & hit.is_valid()
            null = self._call(bsdfs, hit.bsdf(ray), blocked, "eval_null_transmission", hit)
            throughput = dr.select(blocked, throughput * null, throughput)
            crossings += 1
            remaining = ray.maxt - hit.t
            ray = hit.spawn_ray(ray.d)
            ray.maxt = remaining
            active = blocked & (dr.max(throughput) > 0.0) & (crossings < MAX_NULL)
        return dr.select(crossings >= MAX_NULL, 0.0, throughput)

    @dr.syntax
    def sample(self, scene, sampler, ray, medium=None, active=True):
        ctx = mi.BSDFContext()
        bsdfs = self._bsdfs(scene)
        ray = mi.Ray3f(ray)
        L = mi.Color3f(0.0)
        beta = mi.Color3f(1.0)
        depth = mi.UInt32(0)
        nulls = mi.UInt32(0)
        scattered = mi.Bool(False)
        prev_si = dr.zeros(mi.SurfaceInteraction3f)
        prev_pdf = mi.Float(1.0)
        prev_delta = mi.Bool(True)
        active = mi.Bool(active)
        while active:
            si = scene.ray_intersect(ray, mi.RayFlags.All, depth == 0, active)
            valid = active & si.is_valid()

            # light arriving along the ray: an emitter hit, or the environment
            ds = mi.DirectionSample3f(scene, si=si, ref=prev_si)
            mis = dr.select(prev_delta, 1.0, _mis(prev_pdf, scene.pdf_emitter_direction(prev_si, ds, ~prev_delta)))
            emitted = ds.emitter.eval(si, active)
            if dr.hint(self.has_background, mode="scalar"):
                emitted = dr.select(~si.is_valid() & ~scattered, self.background, emitted)  # mis is 1 there
            L += dr.select(active, beta * mis * emitted, 0.0)

            # a gap: go straight on with probability of the null transmission
            bsdf = si.bsdf(ray)
            t_null = dr.clip(_grey(self._call(bsdfs, bsdf, valid, "eval_null_transmission", si)), 0.0, 1.0)
            null = valid & (sampler.next_1d(valid) < t_null) & (nulls < MAX_NULL)
            surface = valid & ~null
            beta = dr.select(surface, beta / dr.maximum(1.0 - t_null, 1e-6), beta)

            # emitter sampling, shadow rays through the gaps
            active_next = surface & (depth + 1 < self.max_depth)
            em_active = active_next
            ds_em, em_weight = scene.sample_emitter_direction(si, sampler.next_2d(em_active), False, em_active)
            em_active &= ds_em.pdf != 0.0
            seen = self.transmittance(scene, si, ds_em, em_active, bsdfs)
            wo = si.to_local(ds_em.d)
            bsdf_value, bsdf_pdf = self._call(bsdfs, bsdf, em_active, "eval_pdf", ctx, si, wo)
            mis_em = dr.select(ds_em.delta, 1.0, _mis(ds_em.pdf, bsdf_pdf))
            L += dr.select(em_active, beta * mis_em * bsdf_value * em_weight * seen, 0.0)

            # BSDF sampling
            bs, weight = self._call(bsdfs, bsdf, active_next, "sample", ctx, si, sampler.next_1d(active_next),
                                    sampler.next_2d(active_next))

            # the capture rigs' ambient term: the BSDF's own (the surface model's: albedo ×
            # the forward model's occlusion), else a one-sample estimate of its albedo
            if dr.hint(self.ambient > 0.0, mode="scalar"):
                own = self._call(bsdfs, bsdf, active_next, "has_attribute", AMBIENT)
                albedo = dr.select(own, self._call(bsdfs, bsdf, active_next & own, "eval_attribute_3", AMBIENT, si),
                                   weight)
                L += dr.select(active_next, beta * self.ambient_radiance * albedo, 0.0)
            beta = dr.select(active_next, beta * weight, beta)
            prev_si = dr.select(active_next, si, prev_si)
            prev_pdf = dr.select(active_next, bs.pdf, prev_pdf)
            prev_delta = dr.select(active_next, mi.has_flag(bs.sampled_type, mi.BSDFFlags.Delta), prev_delta)
            scattered |= active_next
            ray = dr.select(null, si.spawn_ray(ray.d), dr.select(active_next, si.spawn_ray(si.to_world(bs.wo)), ray))
            nulls = dr.select(null, nulls + 1, dr.select(active_next, 0, nulls))
            depth = dr.select(active_next, depth + 1, depth)

            # Russian roulette
            beta_max = dr.max(beta)
            rr_prob = dr.minimum(beta_max, 0.95)
            rr = active_next & (depth >= self.rr_depth)
            survive = sampler.next_1d(rr) < rr_prob
            beta = dr.select(rr, beta / rr_prob, beta)
            active_next &= (beta_max > 0.0) & (~rr | survive)
            active = null | active_next
        return L, mi.Bool(True), []

    def aov_names(self):
        return []

    def to_string(self):
        return f"FabricPathIntegrator[max_depth={self.max_depth}, rr_depth={self.rr_depth}]"


def register() -> None:
    """Make ``{"type": "weavecap_path"}`` available to ``mi.load_dict`` (idempotent)."""
    mi.register_integrator("weavecap_path", lambda props: FabricPathIntegrator(props))


register()
