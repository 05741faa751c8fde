"""The surface model of a fabric: maps of one pattern repeat baked from Algorithm 1's yarns.

A garment is seen from much further away than the close-up photo a fabric was captured from,
so it is rendered as a surface: a thin sheet whose appearance at each point is looked up in
maps of one repeat of the weave, tiled at the fabric's physical size. The maps are baked by
casting the forward model's own rays (:mod:`weavecap.model.scene`'s tube meshes of
:mod:`weavecap.model.geometry`, Mitsuba's ray queries) through the yarns: from above for the
face, from below for the back, ``supersamples²`` rays a texel, so they agree with the forward
model by construction. :mod:`weavecap.render.bsdf` shades them with the BYSDF lobes of
:mod:`weavecap.model.bysdf`; the woven neural renderer encodes them and the exports write them.

Conventions
-----------
- UV: one repeat is ``[0, 1]²``; ``u`` grows to the right across the warps (warp ``j`` covers
  ``u ∈ [j/n_a, (j+1)/n_a]``), ``v`` grows upwards across the wefts, weft 0 at the top
  (weft ``i`` covers ``v ∈ [1 - (i+1)/n_e, 1 - i/n_e]``) — the photo's layout: pattern row
  ``i`` is weft ``i`` from the top, column ``j`` warp ``j`` from the left.
- Arrays are images of the repeat, ``(2, H, W, ...)`` with ``H = n_e · t``, ``W = n_a · t``
  for ``t`` texels per yarn; ``[0]`` is the face (seen from the side the surface normal
  points to), ``[1]`` the back (seen from behind, same UV). Row 0 is the top (``v = 1``):
  texel ``(r, c)`` has its centre at ``u = (c + ½)/W``, ``v = 1 - (r + ½)/H``.
- Vectors are in the face's tangent frame: ``x`` along ``+u``, ``y`` along ``+v``, ``z``
  out of the side seen (the surface normal for the face, its opposite for the back). In the
  forward model's coordinates (camera on +z, image rows along +y) a vector ``(a, b, c)`` is
  ``(a, -b, c)`` on the face and ``(a, -b, -c)`` on the back.
- Heights are in yarn pitches (the forward model's ``PITCH``) above the fabric's mid-plane,
  towards the side seen; ``scale.pitch_mm`` turns them into millimetres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..model import bysdf as _bysdf
from ..model.geometry import PITCH, fabric_meshes
from ..model.render import ambient_occlusion
from ..model.scene import BACK as BACK_LIGHT
from ..model.scene import SHADING_KEYS, height_range, parameter_store, yarn_mesh
from ..params import Fabric

mi = _bysdf.mi
dr = _bysdf.dr

TEXELS_PER_YARN = 16  # default resolution: texels across one yarn pitch
SUPERSAMPLES = 4  # rays per texel along each axis (16 a texel)
MAX_TEXELS = 1 << 20  # per side; a large repeat gets fewer texels per yarn (64×64 yarns: 16)
MIN_TEXELS_PER_YARN = 4
HORIZON_AZIMUTHS = 8  # directions of the horizon map, 45° apart, counter-clockwise from +u
HORIZON_STEPS = 7  # bisections of the horizon's elevation: 90° / 2⁷ = 0.7°
#: tilt from the normal of the tilted ``through`` directions: that of the capture rigs' back
#: light (weavecap.model.scene.BACK, §6.4), so the surface model is exact under its own rig
THROUGH_TILT_DEG = math.degrees(math.acos(-BACK_LIGHT.direction[2]))
#: azimuth (face frame, counter-clockwise from +u) of the first tilted direction: the rig's
#: back light's, the others K-fold around it
THROUGH_AZIMUTH_DEG = math.degrees(math.atan2(-BACK_LIGHT.direction[1], BACK_LIGHT.direction[0]))
MARGIN_CELLS = 4  # yarns built beyond the repeat on every side: shadows come from neighbours
CHUNK = 1 << 20  # rays cast per Mitsuba call (bounds memory)
NOISE_TEXELS_PER_YARN = 8  # the noise spectrum, in cycles per pitch, up to 4
NOISE_REPEATS = 8  # the noise tile spans this many repeats a side (its own period)
NOISE_MAX_TEXELS = 1024  # per side of the noise tile
FACE, BACK = 0, 1


@dataclass(frozen=True)
class SurfaceMaps:
    """The baked maps of one repeat (see the module docstring for UV, frame and units).

    Attributes
    ----------
    pattern_shape : (n_e, n_a), wefts × warps of the repeat
    texels_per_yarn : int, t; the maps are ``H × W = (n_e t) × (n_a t)``
    coverage : (2, H, W) float32 in [0, 1]
        Opacity: the share of a texel's rays that hit a yarn (0 in the gaps between yarns).
    warp : (2, H, W) float32 in [0, 1]
        The share of the hits that are on a warp (1 - it on a weft); 0 where nothing is hit.
    normal : (2, H, W, 3) float32, unit
        The yarn surface's mean shading normal over the hits (``(0, 0, 1)`` in gaps).
    tangent : (2, H, W, 3) float32, unit
        The direction of the yarn on top (the majority kind, warp or weft): a weft's along
        ``+u``, a warp's along ``+v``, tilted by the crimp (``(1, 0, 0)`` in gaps).
    height : (2, H, W) float32, yarn pitches above the mid-plane (0 in gaps)
    tube_uv : (2, H, W, 2) float32
        The forward model's tube texture coordinates at the texel centre's hit (u along the
        yarn in circumferences, v around it / 2π; 0 in gaps): the coordinates procedural plies
        and fibres are drawn in.
    grooves : (2, H, W, 2) float32 in [0, 1]
        Mean groove depth between plies and between fibres over the texel's hits
        (:func:`weavecap.model.bysdf.grooves`, box-filtered).
    occlusion : (2, H, W) float32 in [AO_FLOOR, 1]
        The forward model's ambient occlusion (:func:`weavecap.model.render.ambient_occlusion`
        of the hits' heights), mean over the hits; 0 in gaps.
    through : (2, H, W, 1 + K) float32 in [0, 1]
        The share of the hits from which light through the yarn from the far side leaves the
        fabric (the forward model's exit-point rays; 0 where a second yarn lies under it):
        ``[..., 0]`` straight through, ``[..., 1 + k]`` tilted by THROUGH_TILT_DEG towards
        azimuth ``THROUGH_AZIMUTH_DEG + 360° k / K`` (:func:`through_directions`).
    horizon : (2, H, W, K) float32 in [0, 1]
        Sine of the elevation above which the sky is seen from the texel centre's hit, in K
        azimuths ``φ_k = 2πk/K`` counter-clockwise from ``+u`` (the other yarns' shadows).
    """

    pattern_shape: tuple[int, int]
    texels_per_yarn: int
    coverage: np.ndarray
    warp: np.ndarray
    normal: np.ndarray
    tangent: np.ndarray
    height: np.ndarray
    tube_uv: np.ndarray
    grooves: np.ndarray
    occlusion: np.ndarray
    through: np.ndarray
    horizon: np.ndarray

    @property
    def shape(self) -> tuple[int, int]:
        """(H, W) texels of one side."""
        return (int(self.coverage.shape[1]), int(self.coverage.shape[2]))

    def yarn_id(self, side: int = FACE) -> np.ndarray:
        """(H, W) uint8: which yarn is on top: 0 gap (coverage < ½), 1 warp, 2 weft."""
        yarn = np.where(self.warp[side] >= 0.5, 1, 2).astype(np.uint8)
        return np.where(self.coverage[side] >= 0.5, yarn, 0).astype(np.uint8)


@dataclass(frozen=True)
class NoiseMap:
    """The §6.3 irregularity of a fabric as a brightness gain tiled over ``repeats`` repeats.

    ``gain`` is (H, W) float32 ≥ 0 over ``repeats × repeats`` repeats (same UV convention,
    ``[0, 1]²`` per repeat, so one tile covers ``[0, repeats]²``): one plus the synthesized
    noise, which is relative brightness (:func:`weavecap.noise.irregularity`), so the BSDF is
    multiplied by it as ``synth`` multiplies its image (:func:`weavecap.noise.add_noise`).
    """

    gain: np.ndarray
    repeats: int


def noise_map(fabric: Fabric, *, texels_per_yarn: int = NOISE_TEXELS_PER_YARN, seed: int = 0) -> NoiseMap | None:
    """The fabric's §6.3 noise (``params.noise``) synthesized over a few repeats, or None
    when it has none."""
    if not fabric.noise or not fabric.noise.get("gaussians"):
        return None
    from ..noise import synthesize  # (after the test: importing it takes seconds)

    n_e, n_a = fabric.shape
    t = int(texels_per_yarn)
    repeats = int(max(1, min(NOISE_REPEATS, NOISE_MAX_TEXELS // (max(n_e, n_a) * t))))
    tile = synthesize(fabric.noise, (n_e * repeats * t, n_a * repeats * t), pitch_px=float(t), seed=seed)
    return NoiseMap(gain=np.clip(1.0 + tile, 0.0, None).astype(np.float32), repeats=repeats)


def texels_for(pattern_shape: tuple[int, int], requested: int = TEXELS_PER_YARN) -> int:
    """Texels per yarn for a repeat: ``requested``, fewer when a side would exceed MAX_TEXELS."""
    n_e, n_a = pattern_shape
    cap = int(math.floor(math.sqrt(MAX_TEXELS / (n_e * n_a))))
    return int(max(MIN_TEXELS_PER_YARN, min(int(requested), cap)))


def _yarn_scene(fabric: Fabric):
    """The forward model's tube meshes over the repeat and MARGIN_CELLS around it."""
    n_e, n_a = fabric.shape
    m = MARGIN_CELLS
    wefts, warps = fabric_meshes(fabric.pattern, r_warp=fabric.warp.radius, r_weft=fabric.weft.radius,
                                 rows=(-m, n_e + m), cols=(-m, n_a + m))
    diffuse = mi.load_dict({"type": "diffuse"})
    warp_mesh = yarn_mesh("warps", warps, diffuse)
    scene = mi.load_dict({"type": "scene", "wefts": yarn_mesh("wefts", wefts, diffuse), "warps": warp_mesh})
    return scene, mi.ShapePtr(warp_mesh), height_range(fabric)[1] + 1.0


def _to_face(vec: np.ndarray, side: int) -> np.ndarray:
    """Forward-model vectors (..., 3) → the face's tangent frame of ``side`` (module docstring)."""
    out = vec.copy()
    out[..., 1] *= -1.0
    if side == BACK:
        out[..., 2] *= -1.0
    return out


def _cast(scene, warp_ptr, shading, x: np.ndarray, y: np.ndarray, z0: float, side: int) -> dict:
    """Cast vertical rays at forward-model points (x, y) from height ``z0`` towards the fabric,
    and return per ray (numpy): hit, is_warp, normal, tangent, z, tube uv, grooves, through."""
    direction = mi.Vector3f(0.0, 0.0, -1.0 if side == FACE else 1.0)
    ray = mi.Ray3f(mi.Point3f(mi.Float(x), mi.Float(y), mi.Float(np.full_like(x, z0))), direction)
    si = scene.ray_intersect(ray)
    hit = si.is_valid()
    n = si.sh_frame.n
    n = dr.select(dr.dot(n, direction) > 0.0, -n, n)  # towards the side the ray came from
    tangent = dr.normalize(si.dp_du)
    groove_p, groove_f = _bysdf.grooves(shading, si.uv)
    out = dict(hit=hit, is_warp=hit & (si.shape == warp_ptr), normal=n, tangent=tangent, z=si.p.z, uv=si.uv,
               groove=mi.Point2f(groove_p, groove_f), p=si.p, frame_n=si.n)
    # the forward model's exit-point rays (weavecap.model.render.geometry_pass): through the
    # yarn, then on out of the fabric unless another yarn is in the way; straight through and
    # tilted by THROUGH_TILT in each azimuth
    for k, d in enumerate(through_directions(side)):
        d = mi.Vector3f(*(float(c) for c in d))
        exit_si = scene.ray_intersect(si.spawn_ray(d), hit)
        out[f"through{k}"] = hit & ~scene.ray_test(exit_si.spawn_ray(d), hit & exit_si.is_valid())
    dr.eval(*out.values())
    res = {}
    for key, value in out.items():
        a = np.array(value)
        res[key] = a.T if a.ndim == 2 else a
    res["through"] = np.stack([res.pop(f"through{k}") for k in range(1 + HORIZON_AZIMUTHS)], axis=-1)
    return res


def through_directions(side: int = FACE) -> np.ndarray:
    """(1 + K, 3) directions of light through the fabric the ``through`` map is baked for, in
    the forward model's coordinates, leaving the side opposite ``side``: straight through,
    then tilted by THROUGH_TILT_DEG at K azimuths from THROUGH_AZIMUTH_DEG."""
    k = HORIZON_AZIMUTHS
    phi = math.radians(THROUGH_AZIMUTH_DEG) + 2.0 * np.pi * np.arange(k) / k
    tilt = math.radians(THROUGH_TILT_DEG)
    face = np.concatenate([[[0.0, 0.0, -1.0]], np.stack([np.sin(tilt) * np.cos(phi), np.sin(tilt) * np.sin(phi),
                                                         np.full(k, -np.cos(tilt))], axis=-1)])
    return _to_face(face, side)


def _horizon(scene, points: np.ndarray, normals: np.ndarray, hit: np.ndarray, side: int) -> np.ndarray:
    """(N, K) sine of the lowest elevation at which the sky is seen from each point (the
    forward model's shadow rays, from the hit along Mitsuba's offset), in each azimuth, by
    bisection of ray tests (the sky is taken to be seen at every elevation above); 0 where
    nothing was hit."""
    n = points.shape[0]
    k = HORIZON_AZIMUTHS
    phi = 2.0 * np.pi * np.arange(k) / k
    lo = np.zeros((n, k))
    hi = np.full((n, k), np.pi / 2)
    si = dr.zeros(mi.SurfaceInteraction3f, n * k)
    si.p = mi.Point3f(*np.repeat(points, k, axis=0).T.astype(np.float32))
    si.n = mi.Normal3f(*np.repeat(normals, k, axis=0).T.astype(np.float32))
    active = mi.Bool(np.repeat(hit, k))
    for _ in range(HORIZON_STEPS):
        mid = 0.5 * (lo + hi)
        face = np.stack([np.cos(mid) * np.cos(phi), np.cos(mid) * np.sin(phi), np.sin(mid)], axis=-1).reshape(-1, 3)
        fwd = _to_face(face, side)  # (a, b, c) ↔ (a, -b, ±c) is its own inverse
        blocked = np.array(scene.ray_test(si.spawn_ray(mi.Vector3f(*fwd.T.astype(np.float32))), active)).reshape(n, k)
        lo = np.where(blocked, mid, lo)
        hi = np.where(blocked, hi, mid)
    return np.where(hit[:, None], np.sin(hi), 0.0).astype(np.float32)


def bake(fabric: Fabric, *, texels_per_yarn: int = TEXELS_PER_YARN, supersamples: int = SUPERSAMPLES) -> SurfaceMaps:
    """Bake the surface model of one repeat of ``fabric`` from its yarn geometry.

    Parameters
    ----------
    fabric : the captured fabric (pattern, radii, plies and fibres are what the maps depend on)
    texels_per_yarn : texels across one yarn pitch (lowered by :func:`texels_for` for large
        repeats)
    supersamples : rays per texel along each axis (coverage, normals and grooves are means)

    Returns
    -------
    SurfaceMaps
    """
    t = texels_for(fabric.shape, texels_per_yarn)
    s = int(max(1, supersamples))
    n_e, n_a = fabric.shape
    h, w = n_e * t, n_a * t
    scene, warp_ptr, z_top = _yarn_scene(fabric)
    store = parameter_store(fabric)
    shading = _bysdf.Shading(**{sk: store[fk] for sk, fk in SHADING_KEYS.items()})
    sub = (np.arange(s) + 0.5) / s
    centre = s // 2  # the supersample nearest the texel centre (its centre exactly when s is odd)
    maps = {key: [] for key in ("coverage", "warp", "normal", "tangent", "height", "tube_uv", "grooves",
                                "occlusion", "through", "horizon")}
    z_range = height_range(fabric)
    rows_per_chunk = max(1, CHUNK // (w * s * s))
    for side in (FACE, BACK):
        z0 = z_top if side == FACE else -z_top
        parts = {key: [] for key in maps}
        for r0 in range(0, h, rows_per_chunk):
            r1 = min(h, r0 + rows_per_chunk)
            rr, cc, aa, bb = np.meshgrid(np.arange(r0, r1), np.arange(w), np.arange(s), np.arange(s), indexing="ij")
            x = ((cc + sub[bb]) / t * PITCH).astype(np.float32).ravel()
            y = ((rr + sub[aa]) / t * PITCH).astype(np.float32).ravel()
            ray = _cast(scene, warp_ptr, shading, x, y, z0, side)
            shape = (r1 - r0, w, s * s)
            hit = ray["hit"].reshape(shape)
            count = hit.sum(axis=-1)
            safe = np.maximum(count, 1)
            is_warp = ray["is_warp"].reshape(shape)
            parts["coverage"].append(count / (s * s))
            parts["warp"].append(is_warp.sum(axis=-1) / safe)
            normal = np.where(hit[..., None], ray["normal"].reshape(shape + (3,)), 0.0).sum(axis=2)
            norm = np.linalg.norm(normal, axis=-1, keepdims=True)
            normal = np.where(norm > 1e-6, normal / np.maximum(norm, 1e-12), (0.0, 0.0, 1.0 if side == FACE else -1.0))
            parts["normal"].append(_to_face(normal, side))
            # the majority yarn's direction, each sample's sign turned along +x (weft) / +y (warp)
            tangent = ray["tangent"].reshape(shape + (3,))
            warp_major = (is_warp.sum(axis=-1) * 2 >= np.maximum(count, 1))[..., None]
            axis = np.where(is_warp[..., None], tangent[..., 1:2], tangent[..., 0:1])
            tangent = tangent * np.where(axis < 0, -1.0, 1.0)
            keep = (hit & (is_warp == warp_major))[..., None]
            tangent = np.where(keep, tangent, 0.0).sum(axis=2)
            norm = np.linalg.norm(tangent, axis=-1, keepdims=True)
            fallback = np.where(warp_major & (count[..., None] > 0), (0.0, 1.0, 0.0), (1.0, 0.0, 0.0))
            tangent = np.where(norm > 1e-6, tangent / np.maximum(norm, 1e-12), fallback)
            parts["tangent"].append(_to_face(tangent, side))
            height = np.where(hit, ray["z"].reshape(shape), 0.0).sum(axis=-1) / safe / PITCH
            parts["height"].append(height if side == FACE else -height)
            parts["tube_uv"].append(np.where(hit[..., centre * s + centre, None],
                                             ray["uv"].reshape(shape + (2,))[:, :, centre * s + centre], 0.0))
            groove = np.where(hit[..., None], ray["groove"].reshape(shape + (2,)), 0.0).sum(axis=2)
            parts["grooves"].append(groove / safe[..., None])
            parts["through"].append(ray["through"].reshape(shape + (-1,)).sum(axis=2) / safe[..., None])
            occlusion = np.array(ambient_occlusion(mi.Float(ray["z"]), z_range)).reshape(shape)
            parts["occlusion"].append(np.where(hit, occlusion, 0.0).sum(axis=-1) / safe)
            # the horizons from each texel centre's hit (the nearest supersample)
            pick = centre * s + centre
            parts["horizon"].append(_horizon(scene, ray["p"].reshape(shape + (3,))[:, :, pick].reshape(-1, 3),
                                             ray["frame_n"].reshape(shape + (3,))[:, :, pick].reshape(-1, 3),
                                             hit[:, :, pick].ravel(), side).reshape(r1 - r0, w, -1))
        for key in maps:
            maps[key].append(np.concatenate(parts[key], axis=0))
    arrays = {key: np.stack(value).astype(np.float32) for key, value in maps.items()}
    return SurfaceMaps(pattern_shape=(n_e, n_a), texels_per_yarn=t, **arrays)
