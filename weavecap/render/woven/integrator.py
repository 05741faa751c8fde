"""The neural renderer's integrator: one sample a pixel, the BSDF at the pixel's footprint.

Plugin ``"woven_direct"`` (over :class:`weavecap.render.integrator.FabricPathIntegrator`, whose
properties ``ambient`` and ``background`` and gap-aware shadow rays it shares). Per camera
sample:

- the camera ray's differentials (Mitsuba's ``sample_ray_differential``, scaled by
  1/√spp) give the hit's UV partials (``si.compute_uv_partials``): the footprint the
  :class:`~.bsdf.NeuralSurfaceBSDF` is evaluated at;
- every emitter is lit at once: a delta light (directional, point) deterministically, any
  other by one emitter sample; its shadow ray passes through the gaps of the fabric in the way
  (macro visibility), the BSDF's value is the network's for that footprint and direction;
- the capture rigs' ambient term is the BSDF's ``"ambient"`` attribute;
- what the footprint's gaps let through is added behind it: the ray goes on through the
  surface, weighted by the footprint's mean null transmission (deterministic — no noise from
  the gaps), for at most ``MAX_LAYERS`` surfaces; what it leaves the scene with is the
  background (the rigs' backdrop) or the environment.

This is direct lighting, as the paper's renders ("only direct illumination from a point or
directional light source") and as the reference it is compared with (``--mode direct``).
"""

from __future__ import annotations

from ..integrator import AMBIENT, FabricPathIntegrator
from . import terms as _terms

mi, dr = _terms._backend()

MAX_LAYERS = 4  # surfaces a camera ray sees through gaps


class WovenDirectIntegrator(FabricPathIntegrator):
    """``{"type": "woven_direct", "ambient": a, "background": b}`` (see the module docstring)."""

    def _escaped(self, scene, si, throughput, mask):
        """What a ray that left the scene brings: the backdrop (rigs), else the environment."""
        if self.has_background:
            return dr.select(mask, throughput * self.background, 0.0)
        env = scene.environment()
        if env is None:
            return mi.Color3f(0.0)
        return dr.select(mask, throughput * env.eval(si, mask), 0.0)

    @dr.syntax
    def sample(self, scene, sampler, ray, medium=None, active=True):
        ctx = mi.BSDFContext()
        # (the sensor's RayDifferential3f as given: a copy would drop its differentials)
        emitters = scene.emitters()
        si = scene.ray_intersect(ray, mi.RayFlags.All, True, active)
        si.compute_uv_partials(ray)
        L = self._escaped(scene, si, mi.Color3f(1.0), active & ~si.is_valid())
        throughput = mi.Color3f(1.0)
        layers = mi.UInt32(0)
        active = mi.Bool(active) & si.is_valid()
        while active:
            bsdf = si.bsdf(ray)
            for emitter in emitters:
                ds, weight = emitter.sample_direction(si, sampler.next_2d(active), active)
                lit = active & (ds.pdf != 0.0)
                seen = self.transmittance(scene, si, ds, lit)
                value = bsdf.eval(ctx, si, si.to_local(ds.d), lit)
                L += dr.select(lit, throughput * value * weight * seen, 0.0)
            if dr.hint(self.ambient > 0.0, mode="scalar"):
                own = active & bsdf.has_attribute(AMBIENT, active)
                L += dr.select(own, throughput * self.ambient * bsdf.eval_attribute_3(AMBIENT, si, own), 0.0)
            # what the footprint's gaps let through: go on to the next surface behind
            throughput *= bsdf.eval_null_transmission(si, active)
            layers += 1
            going = active & (dr.max(throughput) > 1e-4) & (layers < MAX_LAYERS)
            ray.o = si.spawn_ray(ray.d).o  # the differentials stay the camera's: the next
            # surface's footprint is still the pixel's
            si = scene.ray_intersect(ray, mi.RayFlags.All, False, going)
            si.compute_uv_partials(ray)
            L += self._escaped(scene, si, throughput, going & ~si.is_valid())
            active = going & si.is_valid()
        return L, mi.Bool(True), []

    def to_string(self):
        return "WovenDirectIntegrator[]"


def register() -> None:
    """Make ``{"type": "woven_direct"}`` available to ``mi.load_dict`` (idempotent)."""
    mi.register_integrator("woven_direct", lambda props: WovenDirectIntegrator(props))


register()
