"""The woven neural renderer's training data and training (Chen et al. 2024, §5).

**Data.** Training data for the woven neural renderer (Chen et al. 2024, §5.1), made smarter.

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

**Training.** Training the woven network (Chen et al. 2024, §5.2), resumable, and its held-out errors.

The paper trains with SGD for 10 epochs of 160 million queries (4 days on a GPU). Here, on a
shared 2-core CPU: Adam with a cosine learning-rate decay, batches of ``materials`` materials ×
``queries`` queries each (the encoder runs once per material in a batch, so its cost is shared
by the queries), for ``steps`` steps. Batch ``k`` is drawn from
``numpy.random.default_rng([seed, k])`` alone, so a run stopped and resumed from its
checkpoint (every ``checkpoint_every`` steps) goes on exactly as if it had not stopped.

Held-out errors are measured in RGB — the channels combined with each material's own colours
(:func:`.terms.combine`) — on fabrics the network never saw (:func:`.data.is_held_out`), per
footprint size (points, sub-yarn, up to a repeat, beyond) and for reflection / transmission.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from ..params import Fabric
from ..render.surface import BACK, FACE, SurfaceMaps, bake
from ..render.woven import terms as _terms
from ..render.woven.encoding import encoder_image, encoder_params
from ..render.woven.footprint import (FEATURES, baseline_channels, box_mean, fabric_to_texel, feature_image,
                                      footprint_features, periodic_sat)
from ..render.woven.terms import CHANNELS
from .trainer import Trainer, make_shards, shard_path, write_weights

MIN_FOOTPRINT = 1.0 / 16.0  # yarn pitches: the smallest box footprint
MAX_REPEATS = 5.0  # the largest footprint, in repeats of the longer side
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
    from ..render.bsdf import SurfaceTextures, shading_of

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
    from .. import params
    from ..fixtures import path as fixture_path

    folder = Path(fixture_path("params"))
    return [params.load(p) for p in sorted(folder.glob("*.json"))]


def shard_fabrics(config: DataConfig, shard: int) -> list[tuple[int, Fabric]]:
    """The (index, fabric) pairs of shard ``shard``: the fixtures first (shard 0), then
    random fabrics drawn from the shard's own generator (the family uniform over
    :data:`~weavecap.estimate.sampling.FAMILIES`, then the pattern and every parameter)."""
    from ..estimate.sampling import random_fabric, random_pattern

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
    from ..render.bsdf import shading_of

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


def add_prefiltered(arrays: dict, config: DataConfig, shard: int) -> dict:
    """Shard ``shard``'s arrays (:func:`make_shard`) with each query's ``features`` and
    ``baseline`` (:func:`prefilter_queries`) from its stored maps (float16, as training sees
    them)."""
    fabrics = dict(shard_fabrics(config, shard))
    features = np.zeros((len(arrays["inputs"]), len(FEATURES)), dtype=np.float16)
    baseline = np.zeros((len(arrays["inputs"]), len(_terms.CHANNELS)), dtype=np.float32)
    for m, (index, side) in enumerate(zip(arrays["material_fabric"], arrays["material_side"])):
        sel = np.flatnonzero(arrays["material"] == m)
        fabric = fabrics[int(index)]
        maps = stored_maps(arrays, int(index), fabric.shape, config.texels_per_yarn)
        features[sel], baseline[sel] = prefilter_queries(fabric, maps, int(side), arrays["inputs"][sel])
    return arrays | {"features": features, "baseline": baseline}


def generate(folder: Path, config: DataConfig, *, progress=lambda message: None) -> float:
    """Write every shard of ``config`` not yet in ``folder`` (:func:`weavecap.training.trainer.
    make_shards`: resumable, seeded by shard); return the seconds all shards took to make,
    those of earlier runs included."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = [shard_path(folder, shard) for shard in range(config.shards)]
    return make_shards(paths, lambda shard: add_prefiltered(make_shard(config, shard), config, shard),
                       progress=progress, describe=lambda a: f"{len(a['inputs'])} queries")


def is_held_out(config: DataConfig, fabric_index: int) -> bool:
    """Whether fabric ``fabric_index`` is kept out of training (for the held-out errors): every
    ``held_out_every``-th, or the last one when there are fewer fabrics than that."""
    every = config.held_out_every
    if every <= 0:
        return False
    if config.fabrics < every:
        return fabric_index == config.fabrics - 1
    return fabric_index % every == every - 1


# ---------------------------------------------------------------------------------------------
# training


@dataclass(frozen=True)
class TrainConfig:
    """Optimisation settings (see the module docstring)."""

    steps: int = 12000
    materials: int = 4
    queries: int = 1024
    lr: float = 2e-3
    lr_final: float = 2e-5
    weight_decay: float = 1e-6
    checkpoint_every: int = 250
    use_features: bool = True
    use_baseline: bool = True
    encoder_widths: tuple = (16, 32, 64, 64)
    width: int = 64  # the decoder's layers
    seed: int = 0
    threads: int = 1  # one thread: on the loaded 2 cores, 2 threads ran 8× slower (docs/woven.md)


class Dataset:
    """Every shard of a data folder in memory: per-query arrays and per-material arrays."""

    def __init__(self, folder: Path, config: DataConfig):
        inputs, features, targets, baseline, material = [], [], [], [], []
        mats = {"image": [], "params": [], "fabric": [], "side": [], "shape": [], "colours": []}
        offset = 0
        for shard in range(config.shards):
            path = shard_path(folder, shard)
            if not path.exists():
                raise FileNotFoundError(f"{path}: data shard missing; generate the data first")
            with np.load(path) as z:
                inputs.append(z["inputs"])
                features.append(z["features"])
                targets.append(z["targets"])
                baseline.append(z["baseline"])
                material.append(z["material"] + offset)
                for key in mats:
                    mats[key].append(z[f"material_{key}"])
                offset += len(z["material_fabric"])
        self.inputs = np.concatenate(inputs)
        self.features = np.concatenate(features)
        self.targets = np.concatenate(targets)
        self.baseline = np.concatenate(baseline)
        self.material = np.concatenate(material)
        for key, value in mats.items():
            setattr(self, key, np.concatenate(value))
        starts = np.searchsorted(self.material, np.arange(offset))
        self.ranges = np.stack([starts, np.append(starts[1:], len(self.material))], axis=1)
        held = np.array([is_held_out(config, int(f)) for f in self.fabric])
        self.train_materials = np.flatnonzero(~held)
        self.held_materials = np.flatnonzero(held)

    def batch(self, rng: np.random.Generator, materials: int, queries: int, pool: np.ndarray | None = None) -> dict:
        """A batch: ``materials`` materials drawn from ``pool`` (default: the training ones),
        ``queries`` random queries of each."""
        pool = self.train_materials if pool is None else pool
        chosen = rng.choice(pool, materials, replace=len(pool) < materials)
        idx = np.concatenate([rng.integers(self.ranges[m, 0], self.ranges[m, 1], queries) for m in chosen])
        return {"image": self.image[chosen].astype(np.float32), "params": self.params[chosen],
                "material": np.repeat(np.arange(materials), queries), "inputs": self.inputs[idx],
                "features": self.features[idx].astype(np.float32), "targets": self.targets[idx],
                "baseline": self.baseline[idx]}


def _tensors(batch: dict):
    import torch

    return {k: torch.from_numpy(np.ascontiguousarray(v)) for k, v in batch.items()}


def learning_rate(config: TrainConfig, step: int) -> float:
    """Cosine decay from ``lr`` to ``lr_final`` over ``steps``."""
    f = min(1.0, step / max(1, config.steps))
    return config.lr_final + 0.5 * (config.lr - config.lr_final) * (1.0 + math.cos(math.pi * f))


def build(config: TrainConfig):
    import torch

    from ..render.woven.network import WovenNet

    torch.manual_seed(config.seed)
    return WovenNet(use_features=config.use_features, use_baseline=config.use_baseline,
                    encoder_widths=tuple(config.encoder_widths), width=config.width)


def train(dataset: Dataset, folder: Path, config: TrainConfig, *, log=None):
    """Train (or resume) in ``folder`` on the skeleton's steps (:class:`weavecap.training.trainer.
    Trainer`: a checkpoint every ``checkpoint_every`` steps; step ``k``'s batch and learning rate
    from ``k`` alone). Returns (model, summary dict: steps, seconds, the running losses every 50
    steps)."""
    import torch

    from ..render.woven.network import loss as woven_loss

    torch.set_num_threads(config.threads)
    model = build(config)
    opt = torch.optim.Adam(model.parameters(), lr=config.lr, weight_decay=config.weight_decay)
    trainer = Trainer(folder, asdict(config), model, opt, progress=log or (lambda m: None))
    history, parts, running = [], {}, {}

    def loss(step: int):
        b = _tensors(dataset.batch(np.random.default_rng([config.seed, step]), config.materials, config.queries))
        for group in opt.param_groups:
            group["lr"] = learning_rate(config, step)
        out = model(b["image"], b["params"], b["material"], b["inputs"], b["features"], b["baseline"])
        total, spec, body = woven_loss(out, b["targets"], b["inputs"], use_baseline=config.use_baseline)
        parts["values"] = np.array([total.item(), spec.item(), body.item()])
        return total

    def after(step: int, _value: float) -> None:
        values = parts["values"]
        running["mean"] = values if "mean" not in running else 0.98 * running["mean"] + 0.02 * values
        if step % 50 == 0:
            history.append([step, *running["mean"].tolist()])
            if log is not None:
                total, spec, body = running["mean"]
                log(f"step {step}/{config.steps} loss {total:.5f} spec {spec:.5f} body {body:.6f} "
                    f"lr {learning_rate(config, step):.2e} ({trainer.seconds:.0f} s)")

    trainer.steps(config.steps, loss, every=config.checkpoint_every, after=after)
    return model, {"steps": trainer.done, "seconds": trainer.seconds, "history": history}


def evaluate(model, dataset: Dataset, materials: np.ndarray, *, queries: int = 2048, seed: int = 1,
             baseline_only: bool = False) -> dict:
    """Errors in RGB on ``materials`` (``queries`` random queries each): relative MSE
    (Σ err² / Σ truth²) and relative mean absolute error, overall and by footprint size and
    light side."""
    import torch

    from ..render.woven.network import to_values

    rng = np.random.default_rng(seed)
    preds, truths, sizes, below, shapes, per_material = [], [], [], [], [], []
    if model is not None:
        model.eval()
    with torch.no_grad():
        for m in materials:
            idx = rng.integers(dataset.ranges[m, 0], dataset.ranges[m, 1], queries)
            inputs = torch.from_numpy(dataset.inputs[idx])
            if baseline_only:
                values = dataset.baseline[idx].astype(np.float64)
            else:
                out = model(torch.from_numpy(dataset.image[m:m + 1].astype(np.float32)),
                            torch.from_numpy(dataset.params[m:m + 1]), torch.zeros(len(idx), dtype=torch.long), inputs,
                            torch.from_numpy(dataset.features[idx].astype(np.float32)),
                            torch.from_numpy(dataset.baseline[idx]))
                values = to_values(out, inputs, use_baseline=model.decoder.use_baseline).numpy().astype(np.float64)
            coef = dataset.colours[m].astype(np.float64)
            preds.append(_terms.combine(values, coef))
            truths.append(_terms.combine(dataset.targets[idx].astype(np.float64), coef))
            per_material.append(float(((preds[-1] - truths[-1]) ** 2).sum() / max((truths[-1] ** 2).sum(), 1e-30)))
            sizes.append(dataset.inputs[idx, 2] / max(dataset.shape[m]))
            below.append(dataset.inputs[idx, 8] < 0.0)
            shapes.append(np.full(len(idx), 1.0 / max(dataset.shape[m])))
    if model is not None:
        model.train()
    pred, truth = np.concatenate(preds), np.concatenate(truths)
    size, under, yarn = np.concatenate(sizes), np.concatenate(below), np.concatenate(shapes)

    def errors(sel):
        if not sel.any():
            return None
        e = pred[sel] - truth[sel]
        return {"queries": int(sel.sum()), "rel_mse": float((e ** 2).sum() / max((truth[sel] ** 2).sum(), 1e-30)),
                "rel_mae": float(np.abs(e).sum() / max(np.abs(truth[sel]).sum(), 1e-30))}

    out = {"median_material_rel_mse": float(np.median(per_material)),
           "all": errors(np.ones_like(size, dtype=bool)), "reflection": errors(~under), "transmission": errors(under),
           "point": errors(size == 0.0), "sub_yarn": errors((size > 0) & (size < yarn)),
           "yarn_to_repeat": errors((size >= yarn) & (size < 1.0)), "beyond_repeat": errors(size >= 1.0)}
    return out


def export(model, path: Path, record: dict) -> None:
    """Write the weights as plain float32 arrays (``.npz``, no pickle) and ``record`` beside
    them as JSON (``path`` with ``.json``): :func:`weavecap.training.trainer.write_weights`."""
    write_weights(path, model, record)


def record(data_config: DataConfig, train_config: TrainConfig, *, data_seconds: float, train_summary: dict,
           held_out: dict, seen: dict, dataset: Dataset) -> dict:
    """How the weights were made: configs, sizes, times and errors (the JSON beside them)."""
    return {"format": "weavecap.woven/1", "paper": "Chen et al. 2024, Real-time Neural Woven Fabric Rendering",
            "channels": list(CHANNELS), "data": asdict(data_config), "train": asdict(train_config),
            "queries": int(len(dataset.inputs)), "materials": int(len(dataset.fabric)),
            "held_out_materials": int(len(dataset.held_materials)), "data_seconds": data_seconds,
            "train_seconds": train_summary["seconds"], "steps": train_summary["steps"],
            "loss_history": train_summary["history"][-20:], "held_out_errors": held_out, "seen_errors": seen}
