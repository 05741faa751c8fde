"""Neighbourhood visibility V̄_N(x_o, ω_i) (supplement §2): sampled, and ASG lobes.

V̄_N is the share of the neighbourhood N(x_o) that a light in direction ω_i reaches. Two ways:

- *View samples* (what the fold term uses; training-free, any mesh; the supplement's §2.2
  heuristic casts N_s probe rays down onto N(x_o) from above instead — see docs/fold.md): rays leave points of the
  vertex's faces in cosine-distributed directions and keep the garment points they meet within
  r (:func:`neighbourhood_samples`); V̄ = their share lit, each weighted by how squarely it faces
  the light, on the side x_o sees and on the far side, whose light a translucent fabric lets
  through (:func:`lit_share`). Up to the albedos this is the local irradiance of one bounce.
- *ASG* (§2.1): anisotropic spherical Gaussians per vertex and side (6 parameters each: lobe
  axis z, bandwidths σ_x, σ_y, amplitude C; eq. 2), fitted to sampled V̄ over many directions
  (:func:`fit_asg`; the supplement learns them jointly with the BLIDF).

Everything is evaluated per vertex, batched over all vertices in one Mitsuba ray query.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...backend import mitsuba
from .descriptors import Descriptors, tangent_frame

mi = mitsuba()
import drjit as dr  # noqa: E402  (after the backend chose libLLVM)

SIDES = (1.0, -1.0)  # front (along the vertex normal), back


ALIGN = 64  # bytes: Dr.Jit reads a NumPy buffer in place, and a kernel reading one off this boundary is another kernel


def aligned(a: np.ndarray) -> np.ndarray:
    """A float32 copy of ``a`` (its shape, C order) whose buffer starts on an :data:`ALIGN`-byte
    boundary. Dr.Jit maps a NumPy array without copying it and compiles the kernels that read
    it for the pointer's alignment (``align 64`` or ``align 1`` in the LLVM IR): the rows of one
    (3, N) array, or a buffer where malloc happened to put it, made the fold term's kernels
    compile again on calls picked by chance (one ray kernel in 16 alignment variants, 0.5–0.9 s a
    compile at 192×108 under load)."""
    a = np.asarray(a, np.float32)
    buf = np.empty(a.size + ALIGN // 4, np.float32)
    start = (-buf.ctypes.data % ALIGN) // 4
    out = buf[start:start + a.size].reshape(a.shape)
    out[...] = a
    return out


def jit_vec3(a: np.ndarray, kind):
    """Points or vectors (N, 3) as the Dr.Jit 3-vector type ``kind``, each coordinate :func:`aligned`."""
    a = np.asarray(a, np.float64).reshape(-1, 3)
    return kind(*(aligned(a[:, k]) for k in range(3)))


def _np3(v) -> np.ndarray:
    return np.stack([np.asarray(v[k], np.float64) for k in range(3)], axis=-1)


def ray_offset(radius: float, points: np.ndarray) -> float:
    """How far off a surface shadow and probe rays start (scene units)."""
    return 1e-4 * radius + 1e-6 * float(np.max(np.abs(points))) if len(points) else 1e-4 * radius


def lit(scene: "mi.Scene", points: np.ndarray, normals: np.ndarray, to_light: np.ndarray, radius: float) -> np.ndarray:
    """Whether each point is lit from ``to_light``: facing it and unoccluded (bool, shape of points[..., 0]).

    points, normals : (..., 3); to_light : (..., 3) unit directions towards the light (broadcast).
    """
    shape = points.shape[:-1]
    to_light = np.broadcast_to(to_light, points.shape)
    facing = np.einsum("...k,...k->...", normals, to_light) > 0
    eps = ray_offset(radius, points.reshape(-1, 3))
    origin = points + eps * normals
    ray = mi.Ray3f(jit_vec3(origin, mi.Point3f), jit_vec3(to_light, mi.Vector3f))
    blocked = np.asarray(scene.ray_test(ray)).reshape(shape)
    return facing & ~blocked


@dataclass(frozen=True)
class Neighbours:
    """Points of each vertex's neighbourhood that its surroundings see, on one side.

    Attributes
    ----------
    points, normals : (V, K, 3) float64 — hits of the rays, normals turned towards the ray
    found : (V, K) bool — the ray met the garment within r of the point it left
    albedo : (V, K, 3) float64 — the garment's albedo there (0 where not found)
    """

    points: np.ndarray
    normals: np.ndarray
    found: np.ndarray
    albedo: np.ndarray

    def take(self, rows) -> "Neighbours":
        return Neighbours(self.points[rows], self.normals[rows], self.found[rows], self.albedo[rows])

    @staticmethod
    def concat(parts: "list[Neighbours]") -> "Neighbours":
        """The vertices of ``parts`` one after the other (same K): several sides in one query."""
        return Neighbours(*(np.concatenate([getattr(p, name) for p in parts])
                            for name in ("points", "normals", "found", "albedo")))

    def mean_albedo(self) -> np.ndarray:
        """(V, 3): the mean albedo of each vertex's samples found (0 where none was) — φ_M of the side."""
        return self.albedo.sum(axis=1) / np.maximum(self.found.sum(axis=1), 1)[:, None]


def neighbourhood_albedo(own: np.ndarray, other: np.ndarray) -> np.ndarray:
    """φ_M (N, 3): the albedo of the neighbourhood a side sees (:meth:`Neighbours.mean_albedo`,
    0 where it found none), or the other side's where it found none — a crest sees nothing of
    its own, its light comes from the valley behind it."""
    return np.where(np.any(own > 0, axis=1, keepdims=True), own, other)


def incident_faces(faces: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """CSR incidence of a mesh: (start (V+1,), face (3F,), slot (3F,)) — vertex i is corner
    ``slot[j]`` of face ``face[j]`` for j in start[i]:start[i+1]."""
    flat = np.asarray(faces).ravel()
    order = np.argsort(flat, kind="stable")
    start = np.concatenate([[0], np.cumsum(np.bincount(flat, minlength=count))])
    return start, order // 3, order % 3


def hat_points(vertices: np.ndarray, faces: np.ndarray, normals: np.ndarray, at: np.ndarray, count: int,
               rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``count`` points per vertex on its faces, with the density of its linear hat function.

    A face is drawn in proportion to its area, then the vertex's barycentric coordinate from
    Beta(2, 2) (area density × the coordinate itself) and the other two uniformly: so a value
    averaged over these points is what barycentric interpolation of per-vertex values
    reproduces best. Returns points (A, count, 3), interpolated unit normals (A, count, 3), both
    float32, and faces (A, count); a vertex on no face gets itself.
    """
    v = np.asarray(vertices, np.float64)
    f = np.asarray(faces, np.int64)
    start, face, slot = incident_faces(f, len(v))
    area = 0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1)
    cum = np.concatenate([[0.0], np.cumsum(area[face] + 1e-30)])
    lo, hi = cum[start[at]], cum[start[at + 1]]
    pick = np.searchsorted(cum, lo[:, None] + rng.random((len(at), count)) * (hi - lo)[:, None], side="right") - 1
    lonely = start[at + 1] == start[at]
    pick = np.clip(pick, start[at][:, None], np.maximum(start[at + 1] - 1, start[at])[:, None])
    pick = np.where(lonely[:, None], 0, pick)
    fi = face[pick]
    # each incidence's corners in the order (the vertex, the next, the one before), then one
    # gather of positions and normals together for every sample: float32, as the rays they start are
    ordered = f[face[:, None], (slot[:, None] + np.arange(3)) % 3]  # (3F, 3)
    both = np.hstack([v, np.asarray(normals, np.float64)]).astype(np.float32)  # (V, 6)
    b0 = rng.beta(2.0, 2.0, (len(at), count)).astype(np.float32)
    u = rng.random((len(at), count), dtype=np.float32)
    weights = np.stack([b0, (1 - b0) * u, (1 - b0) * (1 - u)], axis=-1)  # (A, count, 3)
    mixed = np.einsum("ack,ackj->acj", weights, both[ordered[pick]])  # (A, count, 6)
    points, nrm = mixed[..., :3], mixed[..., 3:]
    nrm /= np.maximum(np.linalg.norm(nrm, axis=-1, keepdims=True), 1e-12)
    points = np.where(lonely[:, None, None], both[at, None, :3], points)
    nrm = np.where(lonely[:, None, None], both[at, None, 3:], nrm)
    return points, nrm, np.where(lonely[:, None], -1, fi)


def stratified_unit_square(rows: int, count: int, rng: np.random.Generator) -> np.ndarray:
    """``count`` points of [0, 1)² per row (rows, count, 2), stratified: one scrambled Sobol'
    set (the first ``count`` of the next power of two), shifted by a random offset per row (a Cranley–Patterson rotation, so each row's
    points are uniformly distributed and the rows independent) — an average over them has far
    less variance than over as many independent points."""
    from scipy.stats import qmc

    base = qmc.Sobol(d=2, scramble=True, seed=rng).random_base2(max(0, int(np.ceil(np.log2(max(count, 1))))))[:count]
    return np.mod(base[None] + rng.random((rows, 1, 2)), 1.0)


def cosine_directions(normal: np.ndarray, rng: np.random.Generator, u: np.ndarray | None = None) -> np.ndarray:
    """One cosine-distributed unit direction about each normal (..., 3), from the points ``u``
    of the unit square (..., 2; independent ones if not given)."""
    shape = normal.shape
    n = normal.reshape(-1, 3)
    t, b = tangent_frame(n)
    u = rng.random((len(n), 2)) if u is None else np.asarray(u, np.float64).reshape(-1, 2)
    r, phi = np.sqrt(u[:, 0]), 2 * np.pi * u[:, 1]
    d = (r * np.cos(phi))[:, None] * t + (r * np.sin(phi))[:, None] * b + np.sqrt(1 - u[:, :1]) * n
    return (d / np.linalg.norm(d, axis=1, keepdims=True)).reshape(shape)


def albedo(si, active):
    """The BSDF's albedo at hits ``si`` (Dr.Jit Color3f): its ``"ambient"`` attribute if it has
    one (the surface model), else its diffuse reflectance — what the neighbour samples see and
    the fold pass multiplies by."""
    bsdf = si.bsdf()
    has = bsdf.has_attribute("ambient", active)
    return dr.select(has, bsdf.eval_attribute_3("ambient", si, active & has),
                     bsdf.eval_diffuse_reflectance(si, active & ~has))


def _albedo_at(si) -> np.ndarray:
    """:func:`albedo` at every valid hit, (N, 3)."""
    return _np3(albedo(si, si.is_valid()))


def view_rays(vertices: np.ndarray, faces: np.ndarray, normals: np.ndarray, at: np.ndarray, count: int,
              rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The rays that sample each vertex's neighbourhood on its front side: ``count`` points of
    its faces (:func:`hat_points`), their interpolated normals and faces, and a stratified
    cosine-distributed direction about each normal (origins, normals, directions (A, count, 3),
    faces (A, count)). The back side's rays are the same, mirrored (:func:`mirrored`)."""
    origin, normal, face = hat_points(vertices, faces, normals, at, count, rng)
    direction = cosine_directions(normal, rng, stratified_unit_square(len(at), count, rng))
    return origin, normal, face, direction


def mirrored(direction: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """``direction`` (..., 3) mirrored in the plane normal to ``normal``: a cosine-distributed
    direction about n becomes one about −n, stratified as it was."""
    return direction - 2.0 * np.einsum("...k,...k->...", direction, normal)[..., None] * normal


def neighbourhood_samples(scene: "mi.Scene", shape: "mi.Shape", vertices: np.ndarray, faces: np.ndarray,
                          desc: Descriptors, side: int, count: int, *, seed: int = 0, at=None) -> Neighbours:
    """``count`` points per vertex of the neighbourhood its surroundings see, on ``side``.

    Each ray leaves a point of the vertex's faces (:func:`hat_points`) in a cosine-distributed
    direction about the side's normal there (:func:`view_rays`, mirrored for the back); where it
    meets the garment within r of the point it left (as LocalPT's N is the sphere about its
    first hit) and not on the face it left, it found a neighbour. This samples N(x_o) as the
    light it sends towards x_o's surroundings is weighted: by what they see of it. Geometry
    only — the same samples serve every light. :func:`both_sides_samples` gives both sides of
    one ``seed`` in one ray query, each as this function gives it.
    """
    return _sides(scene, shape, vertices, faces, desc, (side,), count, seed, at)[0]


def both_sides_samples(scene: "mi.Scene", shape: "mi.Shape", vertices: np.ndarray, faces: np.ndarray,
                       desc: Descriptors, count: int, *, seed: int = 0, at=None) -> tuple[Neighbours, Neighbours]:
    """:func:`neighbourhood_samples` of the front and the back at ``seed`` (each the same as its
    own call gives), from one set of hat points and one ray query: the back's rays are the
    front's mirrored, so the two sides cost one set of points and directions."""
    return tuple(_sides(scene, shape, vertices, faces, desc, (0, 1), count, seed, at))


def _sides(scene, shape, vertices, faces, desc: Descriptors, sides: tuple[int, ...], count: int, seed: int,
           at) -> list[Neighbours]:
    at = np.arange(len(vertices)) if at is None else np.asarray(at)
    rng = np.random.default_rng(seed)
    v = np.asarray(vertices, np.float64)
    origin, normal, face, direction = view_rays(v, faces, desc.normals, at, count, rng)
    normals = [SIDES[s] * normal for s in sides]
    directions = [direction if s == 0 else mirrored(direction, normal) for s in sides]
    eps = ray_offset(desc.radius, v)
    nb = _trace_neighbours(scene, shape, np.concatenate([origin + eps * n for n in normals]),
                           np.concatenate(directions), np.concatenate([face] * len(sides)), desc.radius)
    A = len(at)
    return [nb.take(slice(k * A, (k + 1) * A)) for k in range(len(sides))]


def _trace_neighbours(scene, shape, origin: np.ndarray, direction: np.ndarray, face: np.ndarray,
                      radius: float) -> Neighbours:
    """Trace the view rays (origins, directions (V, K, 3), the faces they leave (V, K)) up to
    ``radius``: the neighbours found (:class:`Neighbours`).

    In two stages: a preliminary intersection of every ray (distance, shape and triangle only),
    then the full surface interaction (shading normal, albedo) of the rays that met the garment
    — on an open side most rays meet nothing (crumpled sheet: 13,421 of 261,000), and the full
    interaction of every ray was most of the trace's cost.
    """
    V, K = face.shape
    o, d = origin.reshape(-1, 3), direction.reshape(-1, 3)
    ray = mi.Ray3f(jit_vec3(o, mi.Point3f), jit_vec3(d, mi.Vector3f))
    ray.maxt = mi.Float(radius)  # N(x_o): within r of where the ray left (on a coarse mesh a face can reach beyond)
    pi = scene.ray_intersect_preliminary(ray)
    hit = pi.is_valid() & (pi.shape == mi.ShapePtr(shape))
    dr.eval(hit, pi.prim_index)
    found = np.asarray(hit) & (np.asarray(pi.prim_index) != face.ravel())
    rows = np.flatnonzero(found)
    points, normals, albedos = (np.zeros((V * K, 3)) for _ in range(3))
    if len(rows):
        ray = mi.Ray3f(jit_vec3(o[rows], mi.Point3f), jit_vec3(d[rows], mi.Vector3f))
        ray.maxt = mi.Float(radius)
        si = scene.ray_intersect(ray)
        valid = si.is_valid()
        hit_albedo = albedo(si, valid)
        dr.eval(valid, si.p, si.sh_frame.n, hit_albedo)  # one kernel
        found[rows] &= np.asarray(valid)  # the same rays meet the same hits; a miss (none seen) is no neighbour
        points[rows], n = _np3(si.p), _np3(si.sh_frame.n)
        normals[rows] = np.where((np.einsum("mj,mj->m", n, d[rows]) > 0)[:, None], -n, n)
        albedos[rows] = _np3(hit_albedo)
    shape3 = (V, K, 3)
    return Neighbours(points=points.reshape(shape3), normals=normals.reshape(shape3), found=found.reshape(V, K),
                      albedo=albedos.reshape(shape3))


def lit_share(scene: "mi.Scene", nb: Neighbours, to_light: np.ndarray, radius: float) -> np.ndarray:
    """V̄ (V, 2) in [0, 1]: the neighbour samples' share lit from ω_i, on the side x_o sees and through it.

    Column 0: Σ_k [found, facing ω_i, unoccluded] (n_k·ω_i) / K — what a vertex's surroundings
    see of its neighbourhood that the light reaches, each sample weighted by how squarely it
    faces the light: with the cosine-distributed rays this is, up to the albedos, the local
    irradiance of one bounce. Column 1: the same for samples lit on their far side (−n_k·ω_i > 0,
    unoccluded that way) — light a translucent fabric lets through towards x_o (the surface
    model transmits: its yarns' body transmission and its gaps).

    ``to_light``: (3,) or (V, 3) unit directions towards one light; or (L, V, 3), L lights at
    once (then (L, V, 2), their shadow rays in one Mitsuba query — one call a light costs a
    kernel launch and the numpy round trip each).
    """
    V, K = nb.found.shape
    d = np.asarray(to_light, np.float64)
    many = d.ndim == 3
    d = np.broadcast_to(d if many else d.reshape(1, -1, 3), (len(d) if many else 1, V, 3))
    L = len(d)
    out = np.zeros((L, V, 2))
    row, _ = np.nonzero(nb.found)  # shadow rays only from the samples found (most rays of an open side find nothing)
    if len(row):
        d = d[:, row]  # (L, M, 3)
        points, normals = nb.points[nb.found], nb.normals[nb.found]
        cos = np.einsum("mj,lmj->lm", normals, d)
        up = cos > 0  # the side of each sample the light faces; the other is unlit
        weight = lit(scene, np.broadcast_to(points, d.shape), np.where(up[..., None], normals, -normals), d,
                     radius) * np.abs(cos)
        index = (np.arange(L)[:, None] * V + row).ravel()
        for column, part in enumerate((np.where(up, weight, 0.0), np.where(up, 0.0, weight))):
            out[..., column] = np.bincount(index, part.ravel(), minlength=L * V).reshape(L, V) / K
    return out if many else out[0]


# --------------------------------------------------------------------------- ASG

def asg_axes(z: np.ndarray, normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tangent and bitangent axes (x, y) of lobes with axes ``z`` (..., 3), x in the plane of z and the normal."""
    x = np.cross(np.cross(z, normal), z)
    bad = np.linalg.norm(x, axis=-1) < 1e-6
    if np.any(bad):
        x[bad] = tangent_frame(z[bad])[0]
    x /= np.linalg.norm(x, axis=-1, keepdims=True)
    return x, np.cross(z, x)


def asg_value(params: np.ndarray, normal: np.ndarray, to_light: np.ndarray) -> np.ndarray:
    """Σ_l C max(ω·z, 0) exp(−σ_x (ω·x)² − σ_y (ω·y)²) (eq. 2).

    params : (..., L, 6) — lobe axis z (3, normalised here), σ_x, σ_y, C; normal : (..., 3);
    to_light : (..., 3) unit ω. Returns (...).
    """
    z = params[..., :3] / np.maximum(np.linalg.norm(params[..., :3], axis=-1, keepdims=True), 1e-12)
    x, y = asg_axes(z, np.broadcast_to(normal[..., None, :], z.shape).copy())
    w = to_light[..., None, :]
    lobe = np.maximum(np.sum(w * z, -1), 0.0) * np.exp(-params[..., 3] * np.sum(w * x, -1) ** 2
                                                        - params[..., 4] * np.sum(w * y, -1) ** 2)
    return np.sum(params[..., 5] * lobe, axis=-1)


def fibonacci_sphere(count: int) -> np.ndarray:
    """``count`` nearly uniform unit directions (count, 3)."""
    i = np.arange(count) + 0.5
    z = 1 - 2 * i / count
    phi = np.pi * (1 + 5**0.5) * i
    s = np.sqrt(1 - z * z)
    return np.stack([s * np.cos(phi), s * np.sin(phi), z], axis=1)


def fit_asg(direct: np.ndarray, target: np.ndarray, normal: np.ndarray, directions: np.ndarray, *,
            lobes: int = 2, steps: int = 300, seed: int = 0) -> np.ndarray:
    """Fit ``lobes`` ASGs per vertex so that max(V, ΣASG) matches the sampled V̄ over directions.

    Parameters
    ----------
    direct, target : (V, K) — the vertex's own visibility V and the sampled V̄ towards each of K
        directions.
    normal : (V, 3) — the side's vertex normals; directions : (K, 3) unit, towards the light.

    Returns
    -------
    (V, lobes, 6) float32: z (3), σ_x, σ_y, C — the parameters of eq. 2.
    """
    import torch

    gen = torch.Generator().manual_seed(seed)
    V, K = target.shape
    d = torch.as_tensor(directions, dtype=torch.float32)
    nrm = torch.as_tensor(normal, dtype=torch.float32)
    direct_t = torch.as_tensor(direct, dtype=torch.float32)
    target_t = torch.as_tensor(target, dtype=torch.float32)
    # start the lobes at the directions where the residual V̄ − V is largest, and around the normal
    resid = np.clip(target - direct, 0, None)
    order = np.argsort(-resid, axis=1)[:, :lobes]
    z0 = directions[order] + 0.3 * normal[:, None]
    z = torch.nn.Parameter(torch.as_tensor(z0, dtype=torch.float32)
                           + 0.01 * torch.randn(V, lobes, 3, generator=gen))
    log_sigma = torch.nn.Parameter(torch.full((V, lobes, 2), float(np.log(2.0))))
    amp = torch.nn.Parameter(torch.full((V, lobes), 0.3))
    opt = torch.optim.Adam([z, log_sigma, amp], lr=0.05)
    for _ in range(steps):
        zz = z / z.norm(dim=-1, keepdim=True).clamp_min(1e-6)
        x = torch.cross(torch.cross(zz, nrm[:, None].expand_as(zz), dim=-1), zz, dim=-1)
        x = x / x.norm(dim=-1, keepdim=True).clamp_min(1e-6)
        y = torch.cross(zz, x, dim=-1)
        dz = torch.einsum("vlk,dk->vld", zz, d)
        dx = torch.einsum("vlk,dk->vld", x, d)
        dy = torch.einsum("vlk,dk->vld", y, d)
        sig = log_sigma.exp()
        g = amp[..., None] * dz.clamp_min(0) * torch.exp(-sig[..., 0:1] * dx**2 - sig[..., 1:2] * dy**2)
        pred = torch.maximum(direct_t, g.sum(dim=1))
        loss = ((pred - target_t) ** 2).mean()
        opt.zero_grad()
        loss.backward()
        opt.step()
    out = torch.cat([(z / z.norm(dim=-1, keepdim=True).clamp_min(1e-6)), log_sigma.exp(), amp[..., None]], dim=-1)
    return out.detach().numpy().astype(np.float32)
