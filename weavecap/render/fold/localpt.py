"""LocalPT: path tracing whose bounces stay within the neighbourhood of the first hit (§4.2).

The ground truth of the fold renderer. A camera ray's first hit x_o gets its direct light as
in any path tracer (emitter sampling and BSDF sampling, combined by multiple importance
sampling); the path then continues by BSDF sampling, but a bounce is kept only while it lands
within the sphere N(x_o) of radius r — and, by default, on the same shape as x_o (the garment
itself: the descriptors describe its folds, not the body under it) — else the path ends there.
Light reaching a kept vertex from an emitter counts, whatever occludes it: shadow rays see the
whole scene. Max depth 16 and Russian roulette from depth 5, the supplement's settings; full
path tracing is Mitsuba's ``path`` with the same two.

Written as Mitsuba 3's ``python/ad/integrators`` are (a :class:`mitsuba.SamplingIntegrator`
with a Dr.Jit loop; primal only), registered as ``{"type": "localpt"}``:

- ``radius`` (float): r, in scene units;
- ``max_depth`` (int, 16), ``rr_depth`` (int, 5): as Mitsuba's ``path``;
- ``direct`` / ``indirect`` (bool, both true): keep the light that reaches x_o straight from
  an emitter / the light that reached it by at least one more bounce within N(x_o)
  (``direct=False`` gives the fold term's target, the local inter-reflection alone);
- ``same_shape`` (bool, true): bounces must stay on x_o's shape.

:meth:`LocalPathIntegrator.trace` runs it from a given first hit, and :func:`radiance_leaving`
at given surface points and directions (for training data, without a camera).
"""

from __future__ import annotations

import numpy as np

from ...backend import mitsuba

mi = mitsuba()
import drjit as dr  # noqa: E402  (after the backend chose libLLVM)

from mitsuba.ad.integrators.common import mis_weight  # noqa: E402


class LocalPathIntegrator(mi.SamplingIntegrator):
    """LocalPT (see the module docstring for its properties)."""

    def __init__(self, props):
        super().__init__(props)
        self.max_depth = int(props.get("max_depth", 16))
        self.rr_depth = int(props.get("rr_depth", 5))
        if self.max_depth < 1 or self.rr_depth < 1:
            raise ValueError("localpt: max_depth and rr_depth must be at least 1")
        radius = float(props.get("radius", 1.0))
        if not (np.isfinite(radius) and radius > 0):
            raise ValueError(f"localpt: radius must be a positive number, got {radius}")
        self.radius = radius
        self.radius_sq = dr.opaque(mi.Float, radius * radius)  # opaque: a new r does not recompile
        self.keep_direct = bool(props.get("direct", True))
        self.keep_indirect = bool(props.get("indirect", True))
        self.same_shape = bool(props.get("same_shape", True))

    def _keep(self, direct: mi.Bool) -> mi.Float:
        """1 for the parts of the light this integrator keeps, 0 for the others."""
        return dr.select(direct, mi.Float(float(self.keep_direct)), mi.Float(float(self.keep_indirect)))

    def sample(self, scene: mi.Scene, sampler: mi.Sampler, ray: mi.RayDifferential3f,
               medium: mi.Medium = None, active: mi.Bool = True):
        ray = mi.Ray3f(ray)
        si = scene.ray_intersect(ray, ray_flags=mi.RayFlags.All, coherent=True, active=active)
        return self.trace(scene, sampler, ray, si, mi.Bool(active))

    @dr.syntax
    def trace(self, scene: mi.Scene, sampler: mi.Sampler, ray: mi.Ray3f, si: mi.SurfaceInteraction3f,
              active: mi.Bool):
        """The LocalPT estimate of the radiance leaving the first hit ``si`` towards ``si.wi``.

        Returns (radiance, whether ``si`` is a hit, no AOVs), as :meth:`sample` does.
        """
        bsdf_ctx = mi.BSDFContext()
        ray = mi.Ray3f(ray)
        active = mi.Bool(active)
        depth = mi.UInt32(0)  # index of the current vertex: 0 is x_o
        L = mi.Spectrum(0)
        beta = mi.Spectrum(1)
        eta = mi.Float(1)
        si = mi.SurfaceInteraction3f(si)
        valid = si.is_valid()
        x_o = mi.Point3f(si.p)
        shape_o = si.shape
        prev_si = dr.zeros(mi.SurfaceInteraction3f)
        prev_pdf = mi.Float(1.0)
        prev_delta = mi.Bool(True)

        while dr.hint(active, max_iterations=self.max_depth, label="LocalPT"):
            active_next = mi.Bool(active)

            # Emission met here: seen by the camera (depth 0) or reached by BSDF sampling from
            # the previous vertex, weighted against that vertex's emitter sample (MIS). Light
            # straight from an emitter to x_o (depth ≤ 1) is direct.
            ds = mi.DirectionSample3f(scene, si=si, ref=prev_si)
            mis = mis_weight(prev_pdf, scene.pdf_emitter_direction(prev_si, ds, ~prev_delta))
            L += self._keep(depth <= 1) * beta * mis * ds.emitter.eval(si, active)

            # Only vertices inside N(x_o) (on x_o's shape) shade and continue the path
            inside = dr.squared_norm(si.p - x_o) < self.radius_sq
            if dr.hint(self.same_shape, mode="scalar"):
                inside &= si.shape == shape_o
            active_next &= si.is_valid() & ((depth == 0) | inside) & (depth + 1 < self.max_depth)
            bsdf = si.bsdf(ray)

            # Emitter sampling: direct at x_o, indirect at later vertices
            active_em = active_next & mi.has_flag(bsdf.flags(), mi.BSDFFlags.Smooth)
            ds, em_weight = scene.sample_emitter_direction(si, sampler.next_2d(), True, active_em)
            active_em &= ds.pdf != 0.0
            bsdf_val, bsdf_pdf = bsdf.eval_pdf(bsdf_ctx, si, si.to_local(ds.d), active_em)
            mis_em = dr.select(ds.delta, 1.0, mis_weight(ds.pdf, bsdf_pdf))
            L += dr.select(active_em, self._keep(depth == 0) * beta * mis_em * bsdf_val * em_weight, 0.0)

            # BSDF sampling of the next direction
            bs, bsdf_weight = bsdf.sample(bsdf_ctx, si, sampler.next_1d(), sampler.next_2d(), active_next)
            ray = si.spawn_ray(si.to_world(bs.wo))
            eta *= bs.eta
            beta *= bsdf_weight
            prev_si = dr.detach(si, True)
            prev_pdf = bs.pdf
            prev_delta = mi.has_flag(bs.sampled_type, mi.BSDFFlags.Delta)

            # Russian roulette from rr_depth (cancelling η² for a unitless throughput)
            beta_max = dr.max(mi.unpolarized_spectrum(beta))
            active_next &= beta_max != 0.0
            rr_prob = dr.minimum(beta_max * eta**2, 0.95)
            rr_active = depth >= self.rr_depth
            beta[rr_active] *= dr.rcp(rr_prob)
            active_next &= ~rr_active | (sampler.next_1d() < rr_prob)

            si = scene.ray_intersect(ray, ray_flags=mi.RayFlags.All, coherent=False, active=active_next)
            depth += 1
            active = active_next

        return L, valid, []

    def aov_names(self):
        return []

    def to_string(self):
        return (f"LocalPathIntegrator[radius={self.radius}, max_depth={self.max_depth}, rr_depth={self.rr_depth}, "
                f"direct={self.keep_direct}, indirect={self.keep_indirect}, same_shape={self.same_shape}]")


def register() -> None:
    """Make ``{"type": "localpt"}`` available to ``mi.load_dict`` (idempotent)."""
    mi.register_integrator("localpt", lambda props: LocalPathIntegrator(props))


register()


def radiance_leaving(scene: mi.Scene, integrator: LocalPathIntegrator, points: np.ndarray, normals: np.ndarray,
                     directions: np.ndarray, *, spp: int, seed: int = 0, offset: float) -> np.ndarray:
    """LocalPT's estimate of the radiance leaving surface points towards directions.

    Each point is found by a ray down its normal from ``offset`` above it (robust on a
    triangulated surface, where a vertex of a valley lies below its faces and a ray arriving
    along a grazing view direction could slip under them), then the path starts there with
    the view direction as its ω_o.

    Parameters
    ----------
    points, normals : (P, 3) arrays
        Points on the scene's surfaces (mesh vertices) and the normals of the side wanted.
    directions : (P, 3) array
        Unit directions leaving the points (the view), on the side of ``normals``.
    spp : int
        Paths per point.
    offset : float
        How far above the surface the rays start (scene units; small against the geometry).

    Returns
    -------
    (P, 3) float64 — the mean RGB radiance over ``spp`` paths (0 where the ray missed).
    """
    points = np.asarray(points, np.float64)
    normals = np.asarray(normals, np.float64)
    n = len(points)
    if n == 0:
        return np.zeros((0, 3))

    def lanes(a):
        return np.ascontiguousarray(np.repeat(np.asarray(a, np.float64), spp, axis=0).T.astype(np.float32))

    origin = lanes(points + offset * normals)
    ray = mi.Ray3f(mi.Point3f(*origin), mi.Vector3f(*lanes(-normals)))
    si = scene.ray_intersect(ray, ray_flags=mi.RayFlags.All, coherent=True, active=mi.Bool(True))
    si.wi = si.to_local(mi.Vector3f(*lanes(directions)))
    sampler = mi.load_dict({"type": "independent"})
    sampler.seed(seed, n * spp)
    L, valid, _ = integrator.trace(scene, sampler, ray, si, mi.Bool(True))
    L = dr.select(valid, L, 0.0)
    rgb = np.stack([np.asarray(L[k]) for k in range(3)], axis=1).astype(np.float64)
    return rgb.reshape(n, spp, 3).mean(axis=1)
