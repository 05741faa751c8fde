"""The neural renderer's integrator: one sample a pixel, the BSDF at the pixel's footprint.

Plugin ``"woven_direct"`` (over :class:`weavecap.render.integrator.FabricPathIntegrator`, whose
properties ``ambient`` and ``background`` and gap-aware shadow rays it shares). Per camera
sample:

- the camera ray's differentials (Mitsuba's ``sample_ray_differential``, scaled by
  1/√spp) give the hit's UV partials (``si.compute_uv_partials``): the footprint the
  :class:`~.bsdf.NeuralSurfaceBSDF` is evaluated at;
- every emitter is lit at once: a delta light (directional, point) deterministically, any
  other by one emitter sample; its shadow ray passes through the gaps of the fabric in the way
  (macro visibility), the BSDF's value is the network's for that footprint and direction; a
  uniform sky (``constant``) is its radiance times the BSDF's ``"ambient"`` attribute (the
  surface's albedo × occlusion at the footprint: noise-free, an approximation of the sky's
  integral that the bench does not measure — its scene has one directional light);
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
CONSTANT = "ConstantBackgroundEmitter"  # Mitsuba's uniform environment (``constant``)


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

    @staticmethod
    def _neural(scene) -> tuple[list, bool]:
        """The scene's :class:`~.bsdf.NeuralSurfaceBSDF` instances (called inline, below),
        and whether every shape has one."""
        from .bsdf import NeuralSurfaceBSDF

        found, only = [], True
        for shape in scene.shapes():
            bsdf = shape.bsdf()
            if not isinstance(bsdf, NeuralSurfaceBSDF):
                only = False
            elif not any(bsdf is b for b in found):
                found.append(bsdf)
        return found, only

    def _call(self, neural, bsdf, active, method: str, *args):
        """``bsdf.method(*args, active)`` for the hit's BSDF: a neural BSDF's Python method
        traced inline, any other BSDF by Mitsuba's virtual call. Through the virtual call the
        same decoder ran 7.5× slower (with a single BSDF in the registry Dr.Jit inlines the
        call and its masked-off body still runs), so a scene of neural BSDFs only makes none."""
        instances, only = neural
        mi_active = mi.Bool(active)
        other = mi.Bool(mi_active)
        out = None
        for b in instances:
            mine = mi_active & (bsdf == mi.BSDFPtr(b))
            other &= ~mine
            value = getattr(b, method)(*args, mine)
            out = value if out is None else dr.select(mine, value, out)
        if only and out is not None:
            return out
        value = getattr(bsdf, method)(*args, other)
        return value if out is None else dr.select(other, value, out)

    def _direct(self, scene, sampler, si, bsdf, neural, active):
        """The light every emitter sends off the hit ``si`` towards the camera (Color3f); a
        plain Python loop over the emitters, unrolled into the kernel."""
        ctx = mi.BSDFContext()
        L = mi.Color3f(0.0)
        ambient = self.ambient > 0.0
        for emitter in scene.emitters():
            if emitter.class_name() == CONSTANT:
                # a uniform sky: its radiance times the surface's albedo × occlusion at the
                # footprint (the capture rigs' ambient term) — no noise, where one sample
                # of the sky a pixel would be grain
                sky = emitter.eval(dr.zeros(mi.SurfaceInteraction3f), active)
                L += sky * self._ambient(neural, bsdf, si, active)
                continue
            ds, weight = emitter.sample_direction(si, sampler.next_2d(active), active)
            lit = active & (ds.pdf != 0.0)
            seen = self.transmittance(scene, si, ds, lit)
            value = self._call(neural, bsdf, lit, "eval", ctx, si, si.to_local(ds.d))
            L += dr.select(lit, value * weight * seen, 0.0)
        if ambient:
            L += self.ambient * self._ambient(neural, bsdf, si, active)
        return L

    def _ambient(self, neural, bsdf, si, active):
        own = active & bsdf.has_attribute(AMBIENT, active)
        value = self._call(neural, bsdf, own, "eval_attribute_3", AMBIENT, si)
        return dr.select(own, value, 0.0)

    @dr.syntax
    def sample(self, scene, sampler, ray, medium=None, active=True):
        # (the sensor's RayDifferential3f as given: a copy would drop its differentials)
        neural = self._neural(scene)
        si = scene.ray_intersect(ray, mi.RayFlags.All, True, active)
        si.compute_uv_partials(ray)
        L = self._escaped(scene, si, mi.Color3f(1.0), active & ~si.is_valid())
        throughput = mi.Color3f(1.0)
        layers = mi.UInt32(0)
        active = mi.Bool(active) & si.is_valid()
        while active:
            bsdf = si.bsdf(ray)
            L += throughput * self._direct(scene, sampler, si, bsdf, neural, active)
            # what the footprint's gaps let through: go on to the next surface behind
            throughput *= self._call(neural, bsdf, active, "eval_null_transmission", si)
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
