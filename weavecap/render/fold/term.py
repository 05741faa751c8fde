"""The fold term of ``weavecap render``: the BLIDF's local inter-reflection, added where folds are.

Per vertex, both sides, wherever the vertex's view samples meet the garment within r on either
side (a valley, the walls of a fold, and the crest whose far side is a valley):

    G(x_o) = Σ_lights E · Σ_s V̄_s(x_o, ω_i) · S_θ,s / ρ

with the descriptors of :mod:`.descriptors` (cached per mesh), V̄_s the lit shares of the
neighbourhoods of both sides (:data:`.blidf.SHARES`; :func:`.visibility.lit_share`,
``neighbours`` rays a vertex and side, the same for every light, averaged over the computed
vertices within SMOOTH r) and S_θ the shipped BLIDF (:mod:`.blidf`) given the neighbourhood's
albedo (the fabric's, sampled where the rays met it). Lights: every delta emitter of the scene
(directional, point, spot) at its irradiance, and the environment (a constant sky or a map)
as ``sky_directions`` directions over the sphere, each with its radiance × 4π / count. Area
emitters are not modelled (said in the output).

Then one pass of ``pass_spp`` samples a pixel (the scene's own camera) interpolates G over the
triangles, takes the side the camera sees, and multiplies by the albedo the surface model
shows there (its ``ambient`` attribute: the yarns' colours, occlusion and gaps) — so the fold
light carries the weave's texture while being computed per vertex; no Python call per pixel.
A flat mesh, or one whose sides have no valley, gets no fold term at all (``has_folds``,
``--fold auto``); a flat mesh never computes descriptors.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ...backend import mitsuba
from . import blidf as B
from .descriptors import cached_descriptors
from .visibility import (SIDES, albedo, asg_value, fibonacci_sphere, fit_asg, lit_share, neighbourhood_albedo,
                         neighbourhood_samples)

mi = mitsuba()
import drjit as dr  # noqa: E402  (after the backend chose libLLVM)

NEIGHBOURS = 64  # view samples of V̄ per vertex and side (skirt, 96x54 vs LocalPT 1024 spp: gain 1.70x at 32, 1.89x at 64)
SKY_DIRECTIONS = 16  # directions an environment is taken from
PASS_SPP = 4  # samples a pixel of the pass that lays the fold term on the image
SMOOTH = 0.15  # V̄ is averaged over the computed vertices within this × r (more samples, less noise)
PLANAR = 1e-6  # a mesh thinner than this × its size across its best plane is flat
ATTRIBUTES = ("vertex_fold_front", "vertex_fold_back")


@dataclass(frozen=True)
class Light:
    """One light as the fold term sees it: per point, the unit direction towards it and its
    irradiance (RGB), and what it is (for the output)."""

    to_light: np.ndarray  # (P, 3)
    irradiance: np.ndarray  # (P, 3)
    kind: str


def is_flat(positions: np.ndarray) -> bool:
    """Whether a mesh lies in a plane (the smallest principal extent ≈ 0 against the largest)."""
    p = np.asarray(positions, np.float64)
    if len(p) < 4:
        return True
    s = np.linalg.svd(p - p.mean(axis=0), compute_uv=False)
    return bool(s[-1] <= PLANAR * max(s[0], 1e-300))


def has_folds(mesh) -> bool:
    """``weavecap render --fold auto``'s test: a side of the mesh has a valley narrower than r."""
    if is_flat(mesh.positions):
        return False
    desc, _, _ = cached_descriptors(mesh.positions, mesh.faces, normals=mesh.normals)
    return bool(desc.folded.any())


def smoothing(vertices: np.ndarray, radius: float):
    """A row-normalised sparse (V, V) average over the vertices within ``radius`` (Gaussian
    weights, σ = radius / 2): V̄ of a vertex from its own samples and its neighbours'."""
    from scipy.sparse import csr_matrix
    from scipy.spatial import cKDTree

    tree = cKDTree(vertices)
    pairs = tree.sparse_distance_matrix(tree, radius, output_type="coo_matrix")
    rows = np.concatenate([pairs.row, np.arange(len(vertices))])
    cols = np.concatenate([pairs.col, np.arange(len(vertices))])
    dist = np.concatenate([pairs.data, np.zeros(len(vertices))])
    w = np.exp(-2.0 * (dist / radius) ** 2)
    m = csr_matrix((w, (rows, cols)), shape=(len(vertices), len(vertices)))
    return csr_matrix(m.multiply(1.0 / np.asarray(m.sum(axis=1))))


def scene_lights(scene: "mi.Scene", points: np.ndarray, *, sky_directions: int = SKY_DIRECTIONS) -> tuple[list, list]:
    """The lights of ``scene`` at ``points`` (P, 3): (lights, notes about what was left out)."""
    lights, notes = [], []
    P = len(points)
    it = mi.Interaction3f()
    it.p = mi.Point3f(*np.ascontiguousarray(points.T, np.float32))
    it.t = mi.Float(0.0)
    env = scene.environment()
    for emitter in scene.emitters():
        kind = str(emitter).split("[")[0]
        if mi.has_flag(emitter.flags(), mi.EmitterFlags.Delta):
            ds, weight = emitter.sample_direction(it, mi.Point2f(0.5, 0.5))
            d = np.stack([np.broadcast_to(np.asarray(ds.d[k], np.float64), (P,)) for k in range(3)], 1)
            e = np.stack([np.broadcast_to(np.asarray(weight[k], np.float64), (P,)) for k in range(3)], 1)
            lights.append(Light(d, np.nan_to_num(e), kind))
        elif not mi.has_flag(emitter.flags(), mi.EmitterFlags.Infinite):
            notes.append(f"{kind} emitter not modelled by the fold term")
    if env is not None:
        dirs = fibonacci_sphere(sky_directions)
        si = dr.zeros(mi.SurfaceInteraction3f, sky_directions)
        si.wi = mi.Vector3f(*np.ascontiguousarray(-dirs.T, np.float32))
        radiance = env.eval(si)
        rgb = np.stack([np.broadcast_to(np.asarray(radiance[k]), (sky_directions,)) for k in range(3)], 1)
        for q in range(sky_directions):
            lights.append(Light(np.broadcast_to(dirs[q], (P, 3)), np.broadcast_to(rgb[q] * 4 * np.pi / sky_directions,
                                                                                    (P, 3)), "environment"))
    return lights, notes


def vertex_gain(scene, garment, vertices, faces, desc, model: B.BLIDF, *, neighbours: int = NEIGHBOURS,
                sky_directions: int = SKY_DIRECTIONS, seed: int = 0, asg: dict | None = None) -> tuple[np.ndarray, dict]:
    """G (2, V, 3): per side and vertex, what the albedo of a point multiplies into its fold light.

    Every vertex whose view samples meet the garment within r on either side is computed, on
    both sides (a crest sees nothing of its own but gets the light of the valley behind it
    through the fabric: :data:`.blidf.SHARES`); the others stay 0. V̄ is the lit share of
    ``neighbours`` view samples a side, averaged over the computed vertices within SMOOTH r, or
    for the side's own facing share with ``asg`` ({side: (V, lobes, 6)}, fitted by
    :func:`.visibility.fit_asg` for this mesh) the ASG lobes' value. Returns (G, facts for the
    output).
    """
    V = len(vertices)
    G = np.zeros((2, V, 3))
    facts = {"lights": 0, "sky_directions": 0, "vertices": 0, "neighbours": neighbours,
             "visibility": "asg" if asg is not None else "sampled", "notes": []}
    nb = {side: neighbourhood_samples(scene, garment, vertices, faces, desc, side, neighbours, seed=seed + side)
          for side in (0, 1)}
    at = np.flatnonzero(nb[0].found.any(axis=1) | nb[1].found.any(axis=1))
    facts["vertices"] = int(len(at))
    if len(at) == 0:
        return G, facts
    nb = {side: nb[side].take(at) for side in (0, 1)}
    around = {side: neighbourhood_albedo(nb[side].mean_albedo(), nb[1 - side].mean_albedo()) for side in (0, 1)}
    points = np.asarray(vertices, np.float64)[at]
    lights, notes = scene_lights(scene, points, sky_directions=sky_directions)
    facts["lights"] = sum(1 for l in lights if l.kind != "environment")
    facts["sky_directions"] = sum(1 for l in lights if l.kind == "environment")
    facts["notes"] = notes
    average = smoothing(points, SMOOTH * desc.radius)
    for light in lights:
        if not np.any(light.irradiance > 0):
            continue
        share = {side: average @ lit_share(scene, nb[side], light.to_light, desc.radius) for side in (0, 1)}
        if asg is not None:  # the sides' own facing shares from the lobes, the rest sampled
            for side in (0, 1):
                normal = SIDES[side] * desc.normals[at].astype(np.float64)
                share[side][:, 0] = np.clip(asg_value(asg[side][at].astype(np.float64), normal, light.to_light),
                                            0.0, 1.0)
        for side in (0, 1):
            vbar = np.concatenate([share[side], share[1 - side]], axis=1)
            lit = vbar.sum(axis=1) > 0
            if not lit.any():
                continue
            feats, light_local = B.inputs(desc, side, at[lit], light.to_light[lit])
            gains = model.gain(feats, light_local, around[side][lit])
            G[side, at[lit]] += light.irradiance[lit] * np.einsum("nck,nk->nc", gains, vbar[lit])
    return G, facts


def mesh_asg(scene, garment, vertices, faces, desc, *, directions: int = 32, neighbours: int = 64,
             seed: int = 0) -> dict:
    """ASG lobes of a mesh's valleys, per side (V, 2, 6): fitted to the share lit on the side
    seen of ``neighbours`` view samples towards ``directions`` directions over the sphere
    (geometry only — a per-mesh precomputation, as the supplement's lobes are learnt per
    garment)."""
    dirs = fibonacci_sphere(directions)
    out = {}
    for side in (0, 1):
        params = np.zeros((len(vertices), 2, 6), np.float32)
        nb = neighbourhood_samples(scene, garment, vertices, faces, desc, side, neighbours, seed=seed + 7 + side)
        at = np.flatnonzero(nb.found.any(axis=1))
        if len(at):
            nb = nb.take(at)
            target = np.stack([lit_share(scene, nb, d, desc.radius)[:, 0] for d in dirs], axis=1)
            normal = SIDES[side] * desc.normals[at].astype(np.float64)
            params[at] = fit_asg(np.zeros_like(target), target, normal, dirs, seed=seed, steps=150)
        out[side] = params
    return out


def _set_attribute(shape, name: str, values: np.ndarray) -> None:
    flat = mi.Float(np.ascontiguousarray(values, np.float32).ravel())
    if shape.has_attribute(name):
        params = mi.traverse(shape)
        params[name] = flat
        params.update()
    else:
        shape.add_attribute(name, 3, flat)


class FoldPassIntegrator(mi.SamplingIntegrator):
    """Plugin ``"fold_pass"``: at the first hit on a shape carrying the fold attributes, their
    interpolated value on the side seen, times the albedo there; 0 elsewhere."""

    def __init__(self, props):
        super().__init__(props)

    def sample(self, scene, sampler, ray, medium=None, active=True):
        si = scene.ray_intersect(mi.Ray3f(ray), ray_flags=mi.RayFlags.All, coherent=True, active=active)
        valid = si.is_valid()
        carries = valid & si.shape.has_attribute(ATTRIBUTES[0], valid)
        front = dr.dot(si.n, -ray.d) > 0.0
        gain = dr.select(front, si.shape.eval_attribute_3(ATTRIBUTES[0], si, carries & front),
                         si.shape.eval_attribute_3(ATTRIBUTES[1], si, carries & ~front))
        return mi.Spectrum(dr.select(carries, gain * albedo(si, carries), 0.0)), valid, []

    def aov_names(self):
        return []

    def to_string(self):
        return "FoldPassIntegrator[]"


mi.register_integrator("fold_pass", lambda props: FoldPassIntegrator(props))


def garment_of(scene, name: str = "garment"):
    """The scene's shape named ``name`` (weavecap render's mesh)."""
    for shape in scene.shapes():
        if shape.id() == name:
            return shape
    raise LookupError(f"the scene has no shape {name!r}")


def fold_image(scene, garment, G: np.ndarray, *, spp: int = PASS_SPP, seed: int = 0) -> np.ndarray:
    """The fold light (H, W, 3) of per-vertex gains ``G`` (2, V, 3), through the scene's camera."""
    for side in (0, 1):
        _set_attribute(garment, ATTRIBUTES[side], G[side])
    integrator = mi.load_dict({"type": "fold_pass"})
    return np.array(mi.render(scene, integrator=integrator, spp=spp, seed=seed), dtype=np.float32)


def fold_light(scene, mesh, *, seed: int = 0, neighbours: int = NEIGHBOURS, asg: dict | None = None,
               model: B.BLIDF | None = None) -> tuple[np.ndarray, dict]:
    """The fold term's image (H, W, 3) for ``mesh`` (a RenderMesh) in ``scene`` (``weavecap
    render``'s, garment named ``"garment"``), and what was modelled."""
    t0 = time.perf_counter()
    desc, radius, cached = cached_descriptors(mesh.positions, mesh.faces, normals=mesh.normals)
    t1 = time.perf_counter()
    model = model or B.BLIDF.load()
    garment = garment_of(scene)
    G, facts = vertex_gain(scene, garment, mesh.positions, mesh.faces, desc, model, seed=seed, neighbours=neighbours,
                           asg=asg)
    t2 = time.perf_counter()
    fold = fold_image(scene, garment, G, seed=seed)
    t3 = time.perf_counter()
    info = {
        "radius_m": radius.value, "radius_rule": radius.how,
        "vertices": {"computed": facts["vertices"], "of": len(mesh.positions),
                     "valleys": {"front": int(desc.folded[:, 0].sum()), "back": int(desc.folded[:, 1].sum())}},
        "lights": facts["lights"], "sky_directions": facts["sky_directions"], "neighbours": facts["neighbours"],
        "visibility": facts["visibility"], "pass_spp": PASS_SPP, "weights_parameters": model.parameters,
        "descriptors_cached": cached, "fold_mean": float(fold.mean()), "notes": facts["notes"],
        "timings": {"descriptors": t1 - t0, "vertices": t2 - t1, "pass": t3 - t2},
    }
    return fold, info


def apply(context) -> tuple[np.ndarray, dict]:
    """:class:`weavecap.render.modes.FoldTerm` ``apply``: the image with the fold term added, and what was modelled."""
    fold, info = fold_light(context.scene, context.mesh, seed=context.options.seed)
    return np.asarray(context.image, np.float32) + fold, info
