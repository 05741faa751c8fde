"""Training data for the woven neural renderer (Chen et al. 2024, §5.1), made smarter.

The paper averages 2048 Monte-Carlo samples for each of 3.2 million queries a material
(22 minutes a material, 165 GPU hours). Here a material is one side of a random fabric
(:func:`weavecap.estimate.sampling.random_pattern` / ``random_fabric``: plain, twills,
satins, baskets, ribs and random patterns up to 8×8, square or not, every parameter over
Table 1's :data:`~weavecap.params.FIT_RANGES`), and for each (ω_i, ω_o) pair

1. the seven colour-free terms (:mod:`.terms`) are evaluated at every texel of the baked
   repeat at once — one Dr.Jit kernel over pairs × texels;
2. every footprint of that pair is then a box mean of that image, read from one periodic
   summed-area table (:mod:`.footprint`): any centre, any size from a texel to many repeats,
   for free and without noise;
3. footprints smaller than a texel are *point* queries: the maps interpolated at the point as
   the reference renderer does (:meth:`~weavecap.render.bsdf.SurfaceTextures.lookup`).

Directions are stratified (jittered grids mapped to the disk, lifted to the hemisphere, as the
paper's 8×8 grids of x, y): half the pairs with the light on the viewer's side (BRDF), half
below (BTDF). Footprint centres are uniform over the repeat, sizes log-uniform from a fraction
of a yarn (``MIN_FOOTPRINT`` pitches) to ``MAX_REPEATS`` repeats.

Shards of ``shard_fabrics`` fabrics are written as ``.npz`` (plain arrays) under a folder,
atomically; a shard already there is skipped, so an interrupted run resumes. Every draw of
shard ``k`` comes from ``numpy.random.default_rng([seed, k])``: a seed gives the same data
whatever was interrupted. Every ``held_out_every``-th fabric is held out of training.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from ...params import FIT_RANGES, Fabric
from ..surface import BACK, FACE, HORIZON_AZIMUTHS, SurfaceMaps, bake
from . import terms as _terms
from .footprint import FEATURES, baseline_channels, box_mean, fabric_to_texel, feature_image, footprint_features, periodic_sat

MIN_FOOTPRINT = 1.0 / 16.0  # yarn pitches: the smallest box footprint
MAX_REPEATS = 5.0  # the largest footprint, in repeats of the longer side
ENCODER_TEXELS = 8  # texels per yarn of the encoder's input image
ENCODER_SIZE = 64  # the encoder's input image is ENCODER_SIZE² texels (the repeat tiled)
#: non-colour parameters the encoder is given (normalised over FIT_RANGES), then log2 of the
#: repeat's wefts and warps / 3
ENCODER_PARAMS = ("specular.roughness", "specular.roughness_exit", "specular.ior", "specular.ior_exit",
                  "specular.attenuation", "body_attenuation", "shadowing.ply", "shadowing.fiber", "plies", "fibers")
N_PARAMS = len(ENCODER_PARAMS) + 2
#: the encoder image's channels
ENCODER_CHANNELS = ("coverage", "warp", "normal_x", "normal_y", "height", "groove_p", "groove_f", "horizon",
                    "horizon_cos", "horizon_sin", "through", "through_tilted")
#: a query's inputs: footprint centre (s, t) in repeats, its side in yarn pitches (0: a
#: point), the viewer's and the light's face-frame directions
INPUTS = ("s", "t", "size", "wi_x", "wi_y", "wi_z", "wo_x", "wo_y", "wo_z")
CHUNK_LANES = 1 << 21  # pairs × texels per Dr.Jit call


@dataclass(frozen=True)
class DataConfig:
    """How much data, and how it is drawn (see the module docstring)."""

    fabrics: int = 320
    shard_fabrics: int = 8
    grid: int = 10  # direction pairs: 2 · grid² a material (grid² BRDF, grid² BTDF)
    footprints: int = 48  # box footprints per pair
    points: int = 4  # point queries per pair
    texels_per_yarn: int = 16
    held_out_every: int = 16
    seed: int = 0

    @property
    def shards(self) -> int:
        return math.ceil(self.fabrics / self.shard_fabrics)

    @property
    def queries_per_material(self) -> int:
        return 2 * self.grid ** 2 * (self.footprints + self.points)


# ---------------------------------------------------------------------------------------------
# what the encoder sees


def _to_encoder_resolution(a: np.ndarray, t: int) -> np.ndarray:
    """(H, W, C) at ``t`` texels a yarn → ENCODER_TEXELS a yarn (box mean or periodic
    bilinear resampling)."""
    from scipy import ndimage

    if t % ENCODER_TEXELS == 0:
        k = t // ENCODER_TEXELS
        h, w, c = a.shape
        return a.reshape(h // k, k, w // k, k, c).mean(axis=(1, 3))
    zoom = ENCODER_TEXELS / t
    return np.stack([ndimage.zoom(a[..., i], zoom, order=1, mode="grid-wrap") for i in range(a.shape[-1])], -1)


def encoder_image(maps: SurfaceMaps, side: int) -> np.ndarray:
    """(len(ENCODER_CHANNELS), ENCODER_SIZE, ENCODER_SIZE) float32: the maps of ``side`` at
    ENCODER_TEXELS texels a yarn, the repeat tiled over the image (cropped beyond 8 yarns)."""
    phi = 2.0 * np.pi * np.arange(HORIZON_AZIMUTHS) / HORIZON_AZIMUTHS
    hz, th = maps.horizon[side], maps.through[side]
    planes = np.stack([maps.coverage[side], maps.warp[side], maps.normal[side, ..., 0], maps.normal[side, ..., 1],
                       maps.height[side], maps.grooves[side, ..., 0], maps.grooves[side, ..., 1], hz.mean(axis=-1),
                       2.0 * (hz * np.cos(phi)).mean(axis=-1), 2.0 * (hz * np.sin(phi)).mean(axis=-1), th[..., 0],
                       th[..., 1:].mean(axis=-1)], axis=-1)
    small = _to_encoder_resolution(planes, maps.texels_per_yarn)
    rows = np.arange(ENCODER_SIZE) % small.shape[0]
    cols = np.arange(ENCODER_SIZE) % small.shape[1]
    return np.ascontiguousarray(small[rows][:, cols].transpose(2, 0, 1), dtype=np.float32)


def encoder_params(fabric: Fabric) -> np.ndarray:
    """(N_PARAMS,) float32: ENCODER_PARAMS scaled to [0, 1] over FIT_RANGES, and log2 of the
    repeat's wefts and warps over 3 (8 yarns → 1)."""
    values = []
    for key in ENCODER_PARAMS:
        lo, hi = FIT_RANGES[key]
        values.append((float(fabric.get(key)) - lo) / (hi - lo))
    n_e, n_a = fabric.shape
    values += [math.log2(n_e) / 3.0, math.log2(n_a) / 3.0]
    return np.asarray(values, dtype=np.float32)


# ---------------------------------------------------------------------------------------------
# directions and footprints


def concentric_disk(u: np.ndarray) -> np.ndarray:
    """(..., 2) points of the unit square → the unit disk (Shirley–Chiu), area-preserving."""
    a, b = 2.0 * u[..., 0] - 1.0, 2.0 * u[..., 1] - 1.0
    first = np.abs(a) > np.abs(b)
    r = np.where(first, a, b)
    safe_a = np.where(a == 0.0, 1.0, a)
    safe_b = np.where(b == 0.0, 1.0, b)
    phi = np.where(first, (np.pi / 4) * (b / safe_a), np.pi / 2 - (np.pi / 4) * (a / safe_b))
    phi = np.where((a == 0.0) & (b == 0.0), 0.0, phi)
    return np.stack([r * np.cos(phi), r * np.sin(phi)], axis=-1)


def stratified_hemisphere(rng: np.random.Generator, grid: int) -> np.ndarray:
    """(grid², 3) unit directions with z ≥ 0: a jittered grid² of the square on the disk,
    lifted (cosine-distributed, as the paper's stratified x, y)."""
    i, j = np.meshgrid(np.arange(grid), np.arange(grid), indexing="ij")
    u = (np.stack([i, j], axis=-1).reshape(-1, 2) + rng.random((grid * grid, 2))) / grid
    xy = concentric_disk(u)
    z = np.sqrt(np.clip(1.0 - (xy ** 2).sum(axis=-1), 0.0, 1.0))
    d = np.concatenate([xy, z[:, None]], axis=-1)
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def direction_pairs(rng: np.random.Generator, grid: int) -> tuple[np.ndarray, np.ndarray]:
    """(2 grid², 3) viewer and light directions: grid² pairs with the light above (its
    stratified directions paired with the viewer's at random), then grid² with it below."""
    wi, wo = [], []
    for below in (False, True):
        v = stratified_hemisphere(rng, grid)
        light = stratified_hemisphere(rng, grid)[rng.permutation(grid * grid)]
        if below:
            light[:, 2] *= -1.0
        wi.append(v)
        wo.append(light)
    return np.concatenate(wi), np.concatenate(wo)


def footprint_sizes(rng: np.random.Generator, n: int, pattern_shape: tuple[int, int]) -> np.ndarray:
    """(n,) box sides in yarn pitches, log-uniform in [MIN_FOOTPRINT, MAX_REPEATS repeats]."""
    top = MAX_REPEATS * max(pattern_shape)
    return np.exp(rng.uniform(math.log(MIN_FOOTPRINT), math.log(top), n))


# ---------------------------------------------------------------------------------------------
# the terms over texels and at points


def texel_terms(shading, maps: SurfaceMaps, side: int, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
    """(P, H, W, 14) float32: the :data:`~.terms.CHANNELS` at every texel centre of ``side``
    for each of the P direction pairs (one Dr.Jit kernel per chunk of pairs)."""
    mi, dr = _terms._backend()
    h, w = maps.shape
    texels = h * w
    per_call = max(1, CHUNK_LANES // texels)
    out = []
    warp = maps.warp[side].reshape(-1)
    for p0 in range(0, len(wi), per_call):
        p1 = min(len(wi), p0 + per_call)
        lane = dr.arange(mi.UInt32, (p1 - p0) * texels)
        index, pair = lane % texels, lane // texels
        point = _terms.texel_point(maps, side, index)

        def dirs(d):
            return mi.Vector3f(*(dr.gather(mi.Float, mi.Float(d[p0:p1, k].astype(np.float32)), pair) for k in range(3)))

        values = _terms.point_terms(shading, point, dirs(wi), dirs(wo))
        dr.eval(*values)
        t7 = np.stack([np.asarray(v) for v in values], axis=-1).reshape(p1 - p0, texels, len(_terms.TERMS))
        out.append(_terms.split_by_yarn(t7, np.broadcast_to(warp, t7.shape[:2])).astype(np.float32))
    return np.concatenate(out).reshape(len(wi), h, w, len(_terms.CHANNELS))


def point_queries(shading, textures, side: int, s: np.ndarray, t: np.ndarray, wi: np.ndarray,
                  wo: np.ndarray) -> np.ndarray:
    """(Q, 14) float32: the channels at points (s, t) (repeats) of ``side``, the maps
    interpolated as :class:`~weavecap.render.bsdf.SurfaceTextures` does for the reference."""
    mi, dr = _terms._backend()
    f = lambda a: mi.Float(np.ascontiguousarray(a, dtype=np.float32))  # noqa: E731
    point = textures.lookup(f(s), f(t), mi.Bool(side == BACK))
    point.gain = mi.Float(1.0)
    values = _terms.point_terms(shading, point, mi.Vector3f(*(f(wi[:, k]) for k in range(3))),
                                mi.Vector3f(*(f(wo[:, k]) for k in range(3))))
    dr.eval(*values, point.warp)
    t7 = np.stack([np.asarray(v) for v in values], axis=-1)
    return _terms.split_by_yarn(t7, np.asarray(point.warp)).astype(np.float32)


# ---------------------------------------------------------------------------------------------
# one material, one shard


def material_queries(fabric: Fabric, maps: SurfaceMaps, side: int, config: DataConfig,
                     rng: np.random.Generator) -> dict:
    """The queries of one material (``side`` of ``fabric``): dict of ``inputs`` (Q, 9) float32
    (INPUTS) and ``targets`` (Q, 14) float32 (:data:`~.terms.CHANNELS`). Their features and
    baselines are added from the shard's stored maps (:func:`complete_shard`)."""
    from ..bsdf import SurfaceTextures, shading_of

    shading, _ = shading_of(fabric)
    h, w = maps.shape
    t_yarn = maps.texels_per_yarn
    wi, wo = direction_pairs(rng, config.grid)
    n_pairs = len(wi)
    images = texel_terms(shading, maps, side, wi, wo)
    inputs, targets = [], []
    per = max(1, (1 << 24) // (h * w * 14 * 8))  # pairs per summed-area table batch (~128 MB)
    for p0 in range(0, n_pairs, per):
        p1 = min(n_pairs, p0 + per)
        sat, mean = periodic_sat(images[p0:p1])
        k = config.footprints
        pair = np.repeat(np.arange(p1 - p0), k)
        s, t = rng.random(len(pair)), rng.random(len(pair))
        size = footprint_sizes(rng, len(pair), maps.pattern_shape)
        x, y = fabric_to_texel(s, t, (h, w))
        half = size * t_yarn / 2.0
        targets.append(box_mean(sat, mean, x, y, half, lead=(pair,)))
        inputs.append(np.concatenate([np.stack([s, t, size], -1), wi[p0 + pair], wo[p0 + pair]], axis=-1))
    if config.points:
        textures = SurfaceTextures(maps)
        pair = np.repeat(np.arange(n_pairs), config.points)
        s, t = rng.random(len(pair)), rng.random(len(pair))
        targets.append(point_queries(shading, textures, side, s, t, wi[pair], wo[pair]))
        inputs.append(np.concatenate([np.stack([s, t, np.zeros_like(s)], -1), wi[pair], wo[pair]], axis=-1))
    return {"inputs": np.concatenate(inputs).astype(np.float32),
            "targets": np.concatenate(targets).astype(np.float32)}


def fixture_fabrics() -> list[Fabric]:
    """The project's fixture fabrics (fixtures/params/*.json): the first fabrics of the data,
    so the bench has fabrics the network has seen."""
    from ... import params
    from ...fixtures import path as fixture_path

    folder = Path(fixture_path("params"))
    return [params.load(p) for p in sorted(folder.glob("*.json"))]


def shard_fabrics(config: DataConfig, shard: int) -> list[tuple[int, Fabric]]:
    """The (index, fabric) pairs of shard ``shard``: the fixtures first (shard 0), then
    random fabrics drawn from the shard's own generator (the family uniform over
    :data:`~weavecap.estimate.sampling.FAMILIES`, then the pattern and every parameter)."""
    from ...estimate.sampling import random_fabric, random_pattern

    fixtures = fixture_fabrics()
    rng = np.random.default_rng([config.seed, shard, 0])
    out = []
    for index in range(shard * config.shard_fabrics, min(config.fabrics, (shard + 1) * config.shard_fabrics)):
        if index < len(fixtures):
            out.append((index, fixtures[index]))
            continue
        _, pattern = random_pattern(rng)
        out.append((index, random_fabric(rng, pattern)))
    return out


def make_shard(config: DataConfig, shard: int) -> dict:
    """Every array of shard ``shard`` (both sides of each of its fabrics): per material
    (``material_*``) the encoder's image and parameters, the fabric's index, side, repeat
    shape and colour coefficients (:func:`~.terms.colour_coefficients`, to judge errors in
    RGB); per query ``inputs``, ``targets`` and ``material``; and each fabric's baked maps
    (``maps{index}_{field}``, float16), from which :func:`complete_shard` adds the features."""
    rng = np.random.default_rng([config.seed, shard, 1])
    mats = {"image": [], "params": [], "fabric": [], "side": [], "shape": [], "colours": []}
    maps_out = {}
    queries = {"inputs": [], "targets": [], "material": []}
    for index, fabric in shard_fabrics(config, shard):
        maps = bake(fabric, texels_per_yarn=config.texels_per_yarn)
        for key in ("coverage", "warp", "normal", "height", "grooves", "through", "horizon"):
            maps_out[f"maps{index}_{key}"] = getattr(maps, key).astype(np.float16)
        for side in (FACE, BACK):
            m = len(mats["fabric"])
            mats["image"].append(encoder_image(maps, side).astype(np.float16))
            mats["params"].append(encoder_params(fabric))
            mats["fabric"].append(index)
            mats["side"].append(side)
            mats["shape"].append(fabric.shape)
            mats["colours"].append(_terms.colour_coefficients(_terms.fabric_colours(fabric)).astype(np.float32))
            q = material_queries(fabric, maps, side, config, rng)
            for key in ("inputs", "targets"):
                queries[key].append(q[key])
            queries["material"].append(np.full(len(q["inputs"]), m, dtype=np.int32))
    out = {f"material_{k}": np.asarray(v) for k, v in mats.items()}
    out.update({k: np.concatenate(v) for k, v in queries.items()})
    out.update(maps_out)
    return out


def stored_maps(z, index: int, pattern_shape, texels_per_yarn: int) -> SurfaceMaps:
    """The maps of fabric ``index`` as a shard stores them (the fields the features, the
    encoder and the BSDF's terms read; the others zero)."""
    def get(key):
        return np.asarray(z[f"maps{index}_{key}"], dtype=np.float32)

    coverage = get("coverage")
    zeros = np.zeros_like(coverage)
    return SurfaceMaps(pattern_shape=tuple(int(v) for v in pattern_shape), texels_per_yarn=int(texels_per_yarn),
                       coverage=coverage, warp=get("warp"), normal=get("normal"),
                       tangent=np.zeros_like(get("normal")), height=get("height"),
                       tube_uv=np.stack([zeros, zeros], axis=-1), grooves=get("grooves"), occlusion=zeros,
                       through=get("through"), horizon=get("horizon"))


def prefilter_queries(fabric: Fabric, maps: SurfaceMaps, side: int, inputs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(features (Q, 16) float16, baseline (Q, 14) float32) of queries ``inputs`` (Q, 9) on
    ``side``: the footprints' map statistics (:func:`~.footprint.footprint_features`, as the
    renderer reads them) and the surface model at their mean maps
    (:func:`~.footprint.baseline_channels`)."""
    from ..bsdf import shading_of

    mi, dr = _terms._backend()
    shading, _ = shading_of(fabric)
    h, w = maps.shape
    image = feature_image(maps, side)
    sat, mean = periodic_sat(image)
    x, y = fabric_to_texel(inputs[:, 0], inputs[:, 1], (h, w))
    features = footprint_features(image, sat, mean, x, y, inputs[:, 2] * maps.texels_per_yarn / 2.0)
    f = lambda a: mi.Float(np.ascontiguousarray(a, dtype=np.float32))  # noqa: E731
    base = baseline_channels(shading, [f(features[:, k]) for k in range(features.shape[1])],
                             mi.Vector3f(*(f(inputs[:, k]) for k in (3, 4, 5))),
                             mi.Vector3f(*(f(inputs[:, k]) for k in (6, 7, 8))))
    dr.eval(*base)
    return features.astype(np.float16), np.stack([np.asarray(b) for b in base], axis=-1).astype(np.float32)


def complete_shard(path: Path, config: DataConfig, shard: int) -> bool:
    """Add each query's ``features`` and ``baseline`` (:func:`prefilter_queries`) to a shard
    from its stored maps, unless it has them. Returns whether it wrote."""
    from ...io import atomic_path

    with np.load(path) as z:
        if "baseline" in z.files:
            return False
        arrays = {k: z[k] for k in z.files}
    fabrics = dict(shard_fabrics(config, shard))
    features = np.zeros((len(arrays["inputs"]), len(FEATURES)), dtype=np.float16)
    baseline = np.zeros((len(arrays["inputs"]), len(_terms.CHANNELS)), dtype=np.float32)
    for m, (index, side) in enumerate(zip(arrays["material_fabric"], arrays["material_side"])):
        sel = np.flatnonzero(arrays["material"] == m)
        fabric = fabrics[int(index)]
        maps = stored_maps(arrays, int(index), fabric.shape, config.texels_per_yarn)
        features[sel], baseline[sel] = prefilter_queries(fabric, maps, int(side), arrays["inputs"][sel])
    arrays["features"], arrays["baseline"] = features, baseline
    with atomic_path(path) as tmp:
        np.savez(tmp, **arrays)
    return True


def shard_path(folder: Path, shard: int) -> Path:
    return Path(folder) / f"shard_{shard:04d}.npz"


def generate(folder: Path, config: DataConfig, *, progress=None) -> dict:
    """Write every shard of ``config`` not yet in ``folder`` (resumable). Returns a summary:
    shards made and skipped, queries, seconds. ``progress(done, total, message)``."""
    from ...io import atomic_path

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "config.json").write_text(json.dumps(asdict(config), indent=1) + "\n")
    made = skipped = 0
    start = time.perf_counter()
    for shard in range(config.shards):
        path = shard_path(folder, shard)
        if path.exists():
            skipped += 1
        else:
            arrays = make_shard(config, shard)
            with atomic_path(path) as tmp:
                np.savez(tmp, **arrays)
            made += 1
        complete_shard(path, config, shard)
        if progress is not None:
            elapsed = time.perf_counter() - start
            progress(shard + 1, config.shards, f"data shard {shard + 1}/{config.shards} ({elapsed:.0f} s)")
    return {"shards_made": made, "shards_skipped": skipped, "seconds": time.perf_counter() - start,
            "queries": config.fabrics * 2 * config.queries_per_material}


def is_held_out(config: DataConfig, fabric_index: int) -> bool:
    """Whether fabric ``fabric_index`` is kept out of training (for the held-out errors): every
    ``held_out_every``-th, or the last one when there are fewer fabrics than that."""
    every = config.held_out_every
    if every <= 0:
        return False
    if config.fabrics < every:
        return fabric_index == config.fabrics - 1
    return fabric_index % every == every - 1
