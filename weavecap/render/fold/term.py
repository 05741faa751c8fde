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

All of it on a subset of the vertices :data:`SPACING` × r apart, interpolated to the others
(:func:`vertex_gain`): the fold light varies over r, and the cost follows the garment's area
over r², not its tessellation.

Then one pass of :data:`PASS_SPP` samples a pixel (the scene's own camera) interpolates G over the
triangles, takes the side the camera sees, and multiplies by the albedo the surface model
shows there (its ``ambient`` attribute: the yarns' colours, occlusion and gaps) — so the fold
light carries the weave's texture while being computed per vertex; no Python call per pixel.
A flat mesh, or one whose sides have no valley, gets no fold term at all (``has_folds``,
``--fold auto``); a flat mesh never computes descriptors.
"""

from __future__ import annotations

import time
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from ...backend import mitsuba
from . import blidf as B
from .descriptors import cached_descriptors, mesh_key
from .visibility import (SIDES, Neighbours, albedo, aligned, asg_value, both_sides_samples, fibonacci_sphere, fit_asg,
                         jit_vec3, lit_share, neighbourhood_albedo, neighbourhood_samples)

mi = mitsuba()
import drjit as dr  # noqa: E402  (after the backend chose libLLVM)

NEIGHBOURS = 64  # view samples of V̄ per vertex and side (skirt, 96x54 vs LocalPT 1024 spp: gain 1.70x at 32, 1.89x at 64)
# directions an environment is taken from: gains over direct at 0.35 r (bench, seeds 1|2) with 8 the same as with 16
# within their noise (skirt 2.07|2.09 vs 2.06|2.09, crumpled 2.56|2.55 vs 2.57|2.55, drape 2.41|2.38 vs 2.33|2.30),
# with 4 not (skirt 1.90, drape 2.01); the shadow rays and the BLIDF's rows scale with the lights (crumpled 0.6 -> 0.45 s)
SKY_DIRECTIONS = 8
PASS_SPP = 4  # samples a pixel of the pass that lays the fold term on the image
SMOOTH = 0.15  # V̄ is averaged over the computed vertices within this × r (more samples, less noise)
PLANAR = 1e-6  # a mesh thinner than this × its size across its best plane is flat
ATTRIBUTES = ("vertex_fold_front", "vertex_fold_back")
SPACING = 0.35  # the term is computed on vertices this × r apart, interpolated to the rest (vertex_gain says why)
NEAREST = 16  # subset vertices an interpolated vertex may draw on (those within 2 spacing: ~12 on a surface)
CHUNK = 200_000  # rows of (light, vertex) the BLIDF evaluates at a time
LAYOUTS = 4  # meshes whose layout (vertex subset, interpolation) is kept in memory (:func:`layout`)


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
    it.p = jit_vec3(points, mi.Point3f)
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
        si.wi = jit_vec3(-dirs, mi.Vector3f)
        radiance = env.eval(si)
        rgb = np.stack([np.broadcast_to(np.asarray(radiance[k]), (sky_directions,)) for k in range(3)], 1)
        for q in range(sky_directions):
            lights.append(Light(np.broadcast_to(dirs[q], (P, 3)), np.broadcast_to(rgb[q] * 4 * np.pi / sky_directions,
                                                                                    (P, 3)), "environment"))
    return lights, notes


def vertex_subset(vertices: np.ndarray, normals: np.ndarray, spacing: float) -> np.ndarray:
    """Indices (A,) of vertices about ``spacing`` apart, sorted: in each occupied cell of a grid
    of that size, and for each of the six axis directions (±x, ±y, ±z) the vertex normals are
    nearest to, the vertex nearest the mean of the cell's vertices of that orientation — so every vertex
    lies within √3 spacing of one that faces about its way, and the two walls of a fold narrower
    than the spacing (normals apart) each keep their own; every vertex where ``spacing`` ≤ 0."""
    v = np.asarray(vertices, np.float64)
    if spacing <= 0 or len(v) == 0:
        return np.arange(len(v))
    facing = np.argmax(np.asarray(normals, np.float64) @ np.hstack([np.eye(3), -np.eye(3)]), axis=1)
    key = np.column_stack([np.floor((v - v.min(axis=0)) / spacing).astype(np.int64), facing])
    _, cell = np.unique(key, axis=0, return_inverse=True)
    cell = cell.ravel()
    centre = np.stack([np.bincount(cell, v[:, k]) for k in range(3)], axis=1) / np.bincount(cell)[:, None]
    order = np.lexsort((np.linalg.norm(v - centre[cell], axis=1), cell))
    return np.sort(order[np.concatenate([[0], np.flatnonzero(np.diff(cell[order])) + 1])])


def interpolation(vertices: np.ndarray, normals: np.ndarray, at: np.ndarray, spacing: float):
    """A row-normalised sparse (V, A): each vertex's value from those of the subset ``at``
    (:func:`vertex_subset` at ``spacing``). A vertex of the subset keeps its own; any other takes
    the average of the subset's within 2 spacing, Gaussian weights (σ = spacing / 2) times how
    nearly their normals agree (max(n·n_a, 0): the other wall of a thin fold is near in space
    but faces elsewhere and has its own light), or the nearest one's if none agrees."""
    from scipy.sparse import csr_matrix
    from scipy.spatial import cKDTree

    V, A = len(vertices), len(at)
    v, n = np.asarray(vertices, np.float64), np.asarray(normals, np.float64)
    own = np.full(V, -1)
    own[at] = np.arange(A)
    rest = np.flatnonzero(own < 0)
    rows, cols, weights = [at], [np.arange(A)], [np.ones(A)]
    if len(rest) and A:
        tree = cKDTree(v[at])
        dist, idx = tree.query(v[rest], k=min(NEAREST, A), distance_upper_bound=2 * spacing)
        dist, idx = dist.reshape(len(rest), -1), idx.reshape(len(rest), -1)
        near = idx < A
        idx = np.where(near, idx, 0)
        agree = np.maximum(np.einsum("rk,rmk->rm", n[rest], n[at[idx]]), 0.0)
        w = np.where(near, np.exp(-2.0 * (np.where(near, dist, 0.0) / spacing) ** 2) * agree, 0.0)
        lonely = w.sum(axis=1) <= 0
        if lonely.any():
            w[lonely] = 0.0
            w[lonely, 0] = 1.0  # the nearest (the subset covers every vertex within √3 spacing)
            idx[lonely, 0] = tree.query(v[rest[lonely]])[1]
        keep = w > 0
        rows.append(np.broadcast_to(rest[:, None], w.shape)[keep])
        cols.append(idx[keep])
        weights.append(w[keep])
    m = csr_matrix((np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))), shape=(V, A))
    return csr_matrix(m.multiply(1.0 / np.maximum(np.asarray(m.sum(axis=1)), 1e-300)))


@dataclass(frozen=True)
class Layout:
    """Where a mesh's fold term is computed and how it spreads to every vertex: the subset
    (A,) of :func:`vertex_subset` and the (V, A) :func:`interpolation` from it."""

    subset: np.ndarray
    spread: object  # scipy.sparse.csr_matrix (V, A)


_LAYOUTS: "OrderedDict[str, Layout]" = OrderedDict()


def layout(vertices: np.ndarray, faces: np.ndarray, normals: np.ndarray, spacing: float) -> Layout:
    """The :class:`Layout` of a mesh at ``spacing`` (scene units), kept for the last
    :data:`LAYOUTS` meshes (keyed by their content, :func:`.descriptors.mesh_key`): geometry
    only, as the descriptors are, so the frames and lights of one garment compute it once
    (crumpled sheet, 14,641 vertices: 0.09 s a call)."""
    key = mesh_key(vertices, faces, normals, spacing=float(spacing))
    if key in _LAYOUTS:
        _LAYOUTS.move_to_end(key)
        return _LAYOUTS[key]
    subset = vertex_subset(vertices, normals, spacing)
    made = Layout(subset=subset, spread=interpolation(vertices, normals, subset, spacing))
    _LAYOUTS[key] = made
    while len(_LAYOUTS) > LAYOUTS:
        _LAYOUTS.popitem(last=False)
    return made


def vertex_gain(scene, garment, vertices, faces, desc, model: B.BLIDF, *, neighbours: int = NEIGHBOURS,
                sky_directions: int = SKY_DIRECTIONS, seed: int = 0, asg: dict | None = None,
                spacing: float = SPACING) -> tuple[np.ndarray, dict]:
    """G (2, V, 3): per side and vertex, what the albedo of a point multiplies into its fold light.

    Computed on a subset of the vertices ``spacing`` × r apart (:func:`vertex_subset`), then
    interpolated to every vertex (:func:`interpolation`): so its cost follows the garment's area
    over r², not its tessellation. The fold light varies over r, as the descriptors it comes from
    do (fits over a sphere of radius r). Why 0.35 (:data:`SPACING`), measured on the bench's
    seven meshes (192×108 against their 4096-spp LocalPT references, seeds 1 | 2; load ~3): the
    gain over direct at every vertex / 0.35 / 0.5 × r: crumpled sheet 2.68|2.70 / 2.57|2.55 /
    2.48|2.54, wave 3.08|2.90 / 2.94|2.97 / 2.76|2.76, skirt 2.14|2.05 / 2.06|2.09 / 2.06|2.00,
    horseshoe 2.12|2.13 / 2.19|2.19 / 2.43|2.47, sine 2.60|2.61 / 2.46|2.47 / 2.53|2.57, drape
    2.23|2.28 / 2.33|2.30 / 2.43|2.36, towel 2.83|2.87 / 2.96|2.83 / 2.76|2.84 (at 0.7 the wave
    fell to 2.15, the crumpled sheet to 2.27); the term's image at 0.35 differs from every
    vertex's at the same seed by 14–26 % RMS, where every vertex's at two seeds differ by
    19–31 %: within its own Monte Carlo noise. 0.5 would leave the skirt at 2.00. The crumpled
    sheet's term (14,641 vertices, r = 23 mm) took 4.2 s at every vertex, 0.6 s at 0.35 (2,039);
    meshes coarser than 0.35 r keep most of their vertices. Every vertex of the subset whose view
    samples meet the garment within r on either side is computed, on
    both sides (a crest sees nothing of its own but gets the light of the valley behind it
    through the fabric: :data:`.blidf.SHARES`); the others stay 0. V̄ is the lit share of
    ``neighbours`` view samples a side (both sides' from one ray query,
    :func:`.visibility.both_sides_samples`), averaged over the computed vertices within SMOOTH r,
    or for the side's own facing share with ``asg`` ({side: (V, lobes, 6)}, fitted by
    :func:`.visibility.fit_asg` for this mesh) the ASG lobes' value. All lights and both sides
    at once: one shadow-ray query, and one evaluation of the BLIDF a side (:data:`CHUNK` rows at
    a time). The subset and its interpolation are the mesh's :func:`layout`, computed once for
    it. Returns (G, facts for the output).
    """
    V = len(vertices)
    G = np.zeros((2, V, 3))
    step = spacing * desc.radius
    plan = layout(vertices, faces, desc.normals, step)
    subset = plan.subset
    facts = {"lights": 0, "sky_directions": 0, "vertices": 0, "sampled": int(len(subset)), "spacing_m": step,
             "neighbours": neighbours, "visibility": "asg" if asg is not None else "sampled", "notes": []}
    nb = dict(enumerate(both_sides_samples(scene, garment, vertices, faces, desc, neighbours, seed=seed, at=subset)))
    found = np.flatnonzero(nb[0].found.any(axis=1) | nb[1].found.any(axis=1))
    at = subset[found]
    facts["vertices"] = int(len(at))
    if len(at) == 0:
        return G, facts
    nb = {side: nb[side].take(found) for side in (0, 1)}
    around = {side: neighbourhood_albedo(nb[side].mean_albedo(), nb[1 - side].mean_albedo()) for side in (0, 1)}
    points = np.asarray(vertices, np.float64)[at]
    lights, notes = scene_lights(scene, points, sky_directions=sky_directions)
    facts["lights"] = sum(1 for l in lights if l.kind != "environment")
    facts["sky_directions"] = sum(1 for l in lights if l.kind == "environment")
    facts["notes"] = notes
    lights = [l for l in lights if np.any(l.irradiance > 0)]
    if not lights:
        return G, facts
    A, L = len(at), len(lights)
    to_light = np.stack([l.to_light for l in lights])  # (L, A, 3)
    irradiance = np.stack([l.irradiance for l in lights])
    average = smoothing(points, SMOOTH * desc.radius)
    raw = lit_share(scene, Neighbours.concat([nb[0], nb[1]]), np.concatenate([to_light, to_light], axis=1),
                    desc.radius)  # (L, 2A, 2): both sides' shadow rays in one query
    share = {side: (average @ raw[:, side * A:(side + 1) * A].transpose(1, 0, 2).reshape(A, 2 * L))
             .reshape(A, L, 2).transpose(1, 0, 2) for side in (0, 1)}
    if asg is not None:  # the sides' own facing shares from the lobes, the rest sampled
        for side in (0, 1):
            normal = SIDES[side] * desc.normals[at].astype(np.float64)
            lobes = asg[side][at].astype(np.float64)
            for k in range(L):
                share[side][k, :, 0] = np.clip(asg_value(lobes, normal, to_light[k]), 0.0, 1.0)
    Gs = np.zeros((2, A, 3))
    for side in (0, 1):
        vbar = np.concatenate([share[side], share[1 - side]], axis=2).reshape(L * A, 4)  # row: light k, vertex i
        rows = np.flatnonzero(vbar.sum(axis=1) > 0)
        frame = B.side_inputs(desc, side, at)
        for part in np.array_split(rows, max(1, -(-len(rows) // CHUNK))):
            vertex = part % A
            feats, light_local = B.light_inputs(frame, vertex, to_light.reshape(L * A, 3)[part])
            gains = model.gain(feats, light_local, around[side][vertex])
            light = irradiance.reshape(L * A, 3)[part] * np.einsum("nck,nk->nc", gains, vbar[part])
            for c in range(3):
                Gs[side, :, c] += np.bincount(vertex, light[:, c], minlength=A)
    for side in (0, 1):  # the subset's uncomputed vertices carry their 0
        full = np.zeros((len(subset), 3))
        full[found] = Gs[side]
        G[side] = plan.spread @ full
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
    flat = mi.Float(aligned(np.ravel(values)))
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
               model: B.BLIDF | None = None, spacing: float = SPACING) -> tuple[np.ndarray, dict]:
    """The fold term's image (H, W, 3) for ``mesh`` (a RenderMesh) in ``scene`` (``weavecap
    render``'s, garment named ``"garment"``), and what was modelled."""
    t0 = time.perf_counter()
    desc, radius, cached = cached_descriptors(mesh.positions, mesh.faces, normals=mesh.normals)
    t1 = time.perf_counter()
    model = model or B.BLIDF.load()
    garment = garment_of(scene)
    G, facts = vertex_gain(scene, garment, mesh.positions, mesh.faces, desc, model, seed=seed, neighbours=neighbours,
                           asg=asg, spacing=spacing)
    t2 = time.perf_counter()
    fold = fold_image(scene, garment, G, seed=seed)
    t3 = time.perf_counter()
    info = {
        "radius_m": radius.value, "radius_rule": radius.how,
        "vertices": {"computed": facts["vertices"], "sampled": facts["sampled"], "of": len(mesh.positions),
                     "valleys": {"front": int(desc.folded[:, 0].sum()), "back": int(desc.folded[:, 1].sum())}},
        "lights": facts["lights"], "sky_directions": facts["sky_directions"], "neighbours": facts["neighbours"],
        "spacing_m": facts["spacing_m"], "visibility": facts["visibility"], "pass_spp": PASS_SPP, "weights_parameters": model.parameters,
        "descriptors_cached": cached, "fold_mean": float(fold.mean()), "notes": facts["notes"],
        "timings": {"descriptors": t1 - t0, "vertices": t2 - t1, "pass": t3 - t2},
    }
    return fold, info


def apply(context) -> tuple[np.ndarray, dict]:
    """:class:`weavecap.render.modes.FoldTerm` ``apply``: the image with the fold term added, and what was modelled."""
    fold, info = fold_light(context.scene, context.mesh, seed=context.options.seed)
    return np.asarray(context.image, np.float32) + fold, info
