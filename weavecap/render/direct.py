"""Direct light of the surface model, every light at every sample (``--mode direct``).

Plugin ``"fabric_direct"`` (over :class:`weavecap.render.integrator.FabricPathIntegrator`,
whose properties ``ambient`` and ``background`` and gap-aware shadow rays it shares). It
computes what ``weavecap_path`` at ``max_depth = 2`` computes — one bounce of light off the
garment, light through the gaps — with less noise per sample:

- every delta light (directional, point, spot) is lit at every camera sample, with a shadow
  ray through the gaps in the way (``weavecap_path`` picks one emitter a sample, by power: with
  the studio's three lights and sky most samples miss most of the light). The directional
  lights are a table read in a loop (:func:`directional_lights`), so their number and
  directions are data: every light of ``weavecap render`` with the same kind of sky shares
  one kernel;
- an environment (the ``sun``/``studio`` sky, a map) or any other emitter: one emitter sample
  and one BSDF sample a camera sample, combined by multiple importance sampling (power
  heuristic), their rays through the gaps;
- the capture rigs' ambient term is the BSDF's ``"ambient"`` attribute, as the forward model
  evaluates it (as ``weavecap_path`` does);
- a gap passes its share of the camera ray on, deterministically: the surface's light is
  added, then the light of the next surface behind it weighted by the null transmission (at
  most :data:`MAX_LAYERS` surfaces); what leaves the scene is the backdrop (the rigs) or the
  environment.

Both estimators have the same expectation (tested against ``weavecap_path`` at ``max_depth =
2``). The woven neural renderer (``--mode neural``) renders with it too; the surface BSDFs'
methods, the neural one's included, are traced inline (:meth:`FabricPathIntegrator._call`).
"""

from __future__ import annotations

import numpy as np

from .integrator import AMBIENT, MAX_NULL, FabricPathIntegrator, _mis

from ..model import bysdf as _bysdf

mi = _bysdf.mi
dr = _bysdf.dr

MAX_LAYERS = MAX_NULL  # surfaces a camera ray sees through gaps (as weavecap_path's crossings)


def directional_lights(scene) -> tuple[object, object, object]:
    """The scene's directional emitters as a table: (unit directions towards them (Vector3f,
    one entry each), their irradiance (Color3f), their count (UInt32)), all opaque. Evaluated
    eagerly, before a render is traced."""
    dirs, irradiance = [], []
    it = dr.zeros(mi.Interaction3f)
    for emitter in scene.emitters():
        if emitter.class_name() == "DirectionalEmitter":
            ds, weight = emitter.sample_direction(it, mi.Point2f(0.5, 0.5))
            dirs.append([float(ds.d[k][0]) for k in range(3)])
            irradiance.append([float(weight[k][0]) for k in range(3)])
    table = np.asarray(dirs or [[0.0, 0.0, 1.0]], np.float32), np.asarray(irradiance or [[0.0] * 3], np.float32)
    out = (mi.Vector3f(*(mi.Float(table[0][:, k]) for k in range(3))),
           mi.Color3f(*(mi.Float(table[1][:, k]) for k in range(3))), mi.UInt32(len(dirs)))
    dr.make_opaque(*out)
    return out


class DirectIntegrator(FabricPathIntegrator):
    """``{"type": "fabric_direct", "ambient": a, "background": b}`` (see the module docstring)."""

    def render(self, scene, sensor=0, seed=0, spp=0, develop=True, evaluate=True):
        self._directional = directional_lights(scene)  # eagerly, before sample() is traced
        return mi.SamplingIntegrator.render(self, scene, sensor, seed, spp, develop, evaluate)

    def _escaped(self, scene, si, throughput, mask):
        """What a camera ray that left the scene brings: the backdrop (rigs), else the environment."""
        if self.has_background:
            return dr.select(mask, throughput * self.background, 0.0)
        env = scene.environment()
        if env is None:
            return mi.Color3f(0.0)
        return dr.select(mask, throughput * env.eval(si, mask), 0.0)

    def _environment_light(self, scene, sampler, si, bsdf, bsdfs, emitter, active):
        """One emitter sample and one BSDF sample of a non-delta ``emitter`` (Color3f), MIS."""
        ctx = mi.BSDFContext()
        infinite = mi.has_flag(emitter.flags(), mi.EmitterFlags.Infinite)
        ds, weight = emitter.sample_direction(si, sampler.next_2d(active), active)
        lit = active & (ds.pdf != 0.0)
        seen = self.transmittance(scene, si, ds, lit, bsdfs)
        wo = si.to_local(ds.d)
        value = self._call(bsdfs, bsdf, lit, "eval", ctx, si, wo)
        L = mi.Color3f(0.0)
        if infinite:  # MIS with the BSDF sample below
            pdf_bsdf = self._call(bsdfs, bsdf, lit, "pdf", ctx, si, wo)
            L += dr.select(lit, value * weight * seen * _mis(ds.pdf, pdf_bsdf), 0.0)
            bs, bsdf_weight = self._call(bsdfs, bsdf, active, "sample", ctx, si, sampler.next_1d(active),
                                         sampler.next_2d(active))
            sampled = active & (bs.pdf > 0.0)
            towards = dr.zeros(mi.DirectionSample3f)
            towards.d = si.to_world(bs.wo)
            towards.dist = dr.inf
            seen_b = self.transmittance(scene, si, towards, sampled, bsdfs)
            sky = dr.zeros(mi.SurfaceInteraction3f)
            sky.wi = -towards.d
            radiance = emitter.eval(sky, sampled)
            pdf_em = emitter.pdf_direction(si, towards, sampled)
            L += dr.select(sampled, bsdf_weight * radiance * seen_b * _mis(bs.pdf, pdf_em), 0.0)
        else:  # an area light: its own sample only
            L += dr.select(lit, value * weight * seen, 0.0)
        return L

    def _direct(self, scene, sampler, si, bsdf, bsdfs, active):
        """The light every emitter sends off the hit ``si`` towards the camera (Color3f); a
        plain Python loop over the emitters, unrolled into the kernel."""
        ctx = mi.BSDFContext()
        L = self._directional_light(scene, si, bsdf, bsdfs, active)
        for emitter in scene.emitters():
            if emitter.class_name() == "DirectionalEmitter":
                continue  # in the table
            if not mi.has_flag(emitter.flags(), mi.EmitterFlags.Delta):
                L += self._environment_light(scene, sampler, si, bsdf, bsdfs, emitter, active)
                continue
            ds, weight = emitter.sample_direction(si, sampler.next_2d(active), active)
            lit = active & (ds.pdf != 0.0)
            seen = self.transmittance(scene, si, ds, lit, bsdfs)
            value = self._call(bsdfs, bsdf, lit, "eval", ctx, si, si.to_local(ds.d))
            L += dr.select(lit, value * weight * seen, 0.0)
        if self.ambient > 0.0:
            own = active & self._call(bsdfs, bsdf, active, "has_attribute", AMBIENT)
            L += self.ambient_radiance * dr.select(own, self._call(bsdfs, bsdf, own, "eval_attribute_3", AMBIENT, si),
                                                   0.0)
        return L

    def _directional_light(self, scene, si, bsdf, bsdfs, active):
        """The light of the directional lights' table (:func:`directional_lights`) off the
        hit (Color3f): a loop over its entries, one BSDF evaluation and shadow ray each."""
        ctx = mi.BSDFContext()
        directions, irradiance, count = self._directional

        def body(k, L):
            ds = dr.zeros(mi.DirectionSample3f)
            ds.d = dr.gather(mi.Vector3f, directions, k)
            ds.dist = dr.inf
            ds.pdf = 1.0
            seen = self.transmittance(scene, si, ds, active, bsdfs)
            value = self._call(bsdfs, bsdf, active, "eval", ctx, si, si.to_local(ds.d))
            return k + 1, L + dr.select(active, value * dr.gather(mi.Color3f, irradiance, k) * seen, 0.0)

        _, L = dr.while_loop((mi.UInt32(0), mi.Color3f(0.0)), lambda k, L: k < count, body,
                             labels=("light", "radiance"), label="directional lights")
        return L

    @dr.syntax
    def sample(self, scene, sampler, ray, medium=None, active=True):
        # (the sensor's RayDifferential3f as given: a copy would drop its differentials)
        bsdfs = self._bsdfs(scene)
        si = scene.ray_intersect(ray, mi.RayFlags.All, True, active)
        si.compute_uv_partials(ray)
        L = self._escaped(scene, si, mi.Color3f(1.0), active & ~si.is_valid())
        throughput = mi.Color3f(1.0)
        layers = mi.UInt32(0)
        active = mi.Bool(active) & si.is_valid()
        while active:
            bsdf = si.bsdf(ray)
            L += throughput * self._direct(scene, sampler, si, bsdf, bsdfs, active)
            # what the gaps let through: go on to the next surface behind
            throughput *= self._call(bsdfs, bsdf, active, "eval_null_transmission", si)
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
        return "DirectIntegrator[]"


def register() -> None:
    """Make ``{"type": "fabric_direct"}`` available to ``mi.load_dict`` (idempotent)."""
    mi.register_integrator("fabric_direct", lambda props: DirectIntegrator(props))


register()
