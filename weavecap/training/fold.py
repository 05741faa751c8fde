"""Training data (LocalPT) and training of the BLIDF (Son et al. supplement §3, §4.2).

Data: each mesh of the fold suite (:func:`fold_suite`) is read as ``weavecap render`` reads it
and dressed in the surface model of each fixture fabric of ``fabrics``; ``lights`` directional
lights spread over the sphere (a Fibonacci set turned at random per mesh: from above, grazing,
from behind) take the fabrics in turn. For each light, ``per_light`` vertices of a pool (most on
a valley of either side), both sides; each sample holds the BLIDF's inputs
(:func:`.blidf.inputs`), the neighbourhood's lit shares V̄ from ``neighbours`` view samples
(:func:`.visibility.lit_share`, more than the render's, for a cleaner factor), the albedos the
fabric shows there and around, and LocalPT's estimate of the local inter-reflection alone at
unit irradiance, averaged over ``hat_points`` starts spread over the vertex's faces as
barycentric interpolation weighs them (``paths`` paths each) — the value that, interpolated
between vertices, best reproduces the image. Written one shard per block of lights (``.npz``);
a shard that exists is not made again, so an interrupted run resumes.

Training: AdamW on the mean squared error of E·ρ·Σ V̄·gain against LocalPT over every sample
and channel, in units of the targets' spread (samples whose neighbourhood is lit on neither
side are left out: they predict 0 at any θ), cosine learning-rate decay; the last block of
lights of every mesh is held out. Shards, epochs (batches of a permutation seeded with (seed,
epoch)) and the checkpoint after every epoch are the skeleton's
(:mod:`weavecap.training.trainer`): an interrupted run resumes.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from ..render.fold import blidf as B
from ..render.fold.descriptors import cached_descriptors
from ..render.fold.visibility import (SIDES, fibonacci_sphere, hat_points, lit_share, neighbourhood_albedo,
                                      neighbourhood_samples)
from .trainer import Trainer, make_shards

Progress = Callable[[str], None]


@dataclass(frozen=True)
class FoldMesh:
    """A training mesh: its name and the shape (:class:`weavecap.render.shapes.Shape`) it is made from."""

    name: str
    shape: object

    def load(self, folder: Path):
        """The shape as ``weavecap render`` reads it (:func:`weavecap.render.mesh.load_mesh` of
        its OBJ, written to ``folder``): the same positions, normals and fabric coordinates."""
        from ..render.mesh import load_mesh

        path = folder / f"{self.name}.obj"
        if not path.is_file():
            from ..io import atomic_write_text

            atomic_write_text(path, self.shape.obj_text("weavecap.training.fold.fold_suite()"))
        return load_mesh(path)


@dataclass(frozen=True)
class TrainConfig:
    """Every knob of a training run (recorded beside the weights)."""

    seed: int = 0
    pool: int = 2000  # vertices of each mesh samples are drawn from
    folded_share: float = 0.5  # of the pool, on a valley of either side (the term covers the rest too)
    lights: int = 48  # directional lights per mesh, taking the fabrics in turn
    per_light: int = 300  # vertices (both sides each) lit by each light
    block: int = 8  # lights per shard; each mesh's last block is held out
    hat_points: int = 16  # LocalPT starts per sample, spread over the vertex's faces
    paths: int = 16  # LocalPT paths per start
    # view samples of V̄ per sample (the render smooths fewer over nearby vertices): the network's
    # gains are fitted against V̄ as a regressor, and its sampling noise shrinks them (regression
    # dilution): 256 samples left the held-out mean at 0.77× LocalPT's
    neighbours: int = 1024
    fabrics: tuple = ("plain", "twill_2_1", "satin_5", "custom_4x6")  # fixture params: light, dark, glossy, coloured
    texels_per_yarn: int = 16  # surface model resolution
    epochs: int = 160
    batch: int = 1024
    lr: float = 6e-3
    weight_decay: float = 1e-5

    def data_settings(self) -> dict:
        """The settings the shards depend on (a work folder holds one such set)."""
        keys = ("seed", "pool", "folded_share", "lights", "per_light", "block", "hat_points", "paths", "neighbours",
                "fabrics", "texels_per_yarn")
        return {k: getattr(self, k) for k in keys}

    def train_settings(self) -> dict:
        return {k: getattr(self, k) for k in ("seed", "epochs", "batch", "lr", "weight_decay")}

    @property
    def blocks(self) -> int:
        return -(-self.lights // self.block)

    def __post_init__(self):
        if self.blocks < 2:
            raise ValueError(f"--lights {self.lights} in blocks of {self.block} make {self.blocks} block: "
                             "at least two are needed (the last is held out)")


def fold_suite() -> list[FoldMesh]:
    """The meshes the BLIDF is trained on: :mod:`weavecap.render.shapes`' fold study (sines of
    three amplitudes and a finer one, meandering waves, horseshoes wide and narrow, a skirt, a
    drape over a sphere), tessellated finer than the fixtures (≈ 2–5 mm edges) so that a
    neighbourhood of r holds enough vertices."""
    from ..render import shapes

    made = [shapes.sine_folds(amplitude=0.004, samples_per_wave=24, rows=41, name="sine_low"),
            shapes.sine_folds(amplitude=0.008, samples_per_wave=24, rows=41, name="sine_mid"),
            shapes.sine_folds(amplitude=0.015, samples_per_wave=24, rows=41, name="sine_high"),
            shapes.sine_folds(amplitude=0.006, wavelength=0.03, samples_per_wave=20, rows=41, name="sine_fine"),
            shapes.wave(samples_per_wave=24, rows=41),
            shapes.horseshoe(opening=0.04, samples=193, rows=41, name="horseshoe_wide"),
            shapes.horseshoe(opening=0.015, samples=193, rows=41, name="horseshoe_narrow"),
            shapes.skirt(around=161, rows=41),
            shapes.drape_over_sphere(cells=64)]
    return [FoldMesh(s.name, s) for s in made]


def choose_vertices(desc, count: int, folded_share: float, rng: np.random.Generator) -> np.ndarray:
    """``count`` distinct vertices: ``folded_share`` of them on a valley of either side."""
    folded = np.flatnonzero(desc.folded.any(axis=1))
    others = np.setdiff1d(np.arange(len(desc.normals)), folded)
    n_fold = min(len(folded), int(round(count * folded_share)))
    n_other = min(len(others), count - n_fold)
    pick = np.concatenate([rng.choice(folded, n_fold, replace=False), rng.choice(others, n_other, replace=False)])
    return np.sort(pick)


def light_directions(count: int, rng: np.random.Generator) -> np.ndarray:
    """``count`` directions towards the light over the sphere, a Fibonacci set turned at random."""
    from scipy.spatial.transform import Rotation

    return Rotation.random(random_state=int(rng.integers(2**31))).apply(fibonacci_sphere(count))


def shard_path(work: Path, index: int, mesh: FoldMesh, block: int) -> Path:
    return work / "data" / f"{index:02d}_{mesh.name}_block{block:02d}.npz"


def fabric_scene(mesh, fabric, config: TrainConfig):
    """A Mitsuba scene of ``mesh`` (a RenderMesh) in ``fabric``'s surface model, as ``weavecap
    render`` makes it, under one directional light (``"sun"``): (scene, garment shape)."""
    from ..render.bsdf import Placement
    from ..render.modes import MODES
    from ..render.run import pitch_of
    from ..render.surface import bake
    from ..render.fold.localpt import mi

    pitch = pitch_of(fabric, None)[0] / 1000.0
    n_e, n_a = fabric.shape
    placement = Placement(repeat_size=(n_a * pitch, n_e * pitch), angle_deg=0.0, offset=(0.0, 0.0))
    bsdf = MODES["direct"].bsdf(fabric, bake(fabric, texels_per_yarn=config.texels_per_yarn), placement, None, True)
    garment = mesh.to_mitsuba(bsdf)
    sun = {"type": "directional", "direction": [0.0, 0.0, -1.0], "irradiance": {"type": "rgb", "value": [1.0] * 3}}
    return mi.load_dict({"type": "scene", "garment": garment, "sun": sun}), garment


def albedo_at(scene, points: np.ndarray, normals: np.ndarray, offset: float) -> np.ndarray:
    """(P, 3): the albedo the garment shows at surface points seen along their normals (the
    surface model's ``ambient`` attribute, else the diffuse reflectance)."""
    from ..render.fold.localpt import mi
    from ..render.fold.visibility import _albedo_at, jit_vec3

    ray = mi.Ray3f(jit_vec3(points + offset * normals, mi.Point3f), jit_vec3(-normals, mi.Vector3f))
    return _albedo_at(scene.ray_intersect(ray))


def make_mesh_shards(work: Path, mesh: FoldMesh, index: int, config: TrainConfig, *,
                     progress: Progress = lambda s: None) -> float:
    """Write the missing shards of one mesh (:func:`weavecap.training.trainer.make_shards`, a
    block of lights each); return the seconds its shards took to make. What every block shares
    (the mesh, its descriptors, the vertex pool, the lights, the neighbourhoods) is made with
    the first missing one and counted in its seconds."""
    paths = [shard_path(work, index, mesh, k) for k in range(config.blocks)]
    shared = {}

    def make(k: int) -> dict:
        if not shared:
            shared.update(_mesh_setup(work, mesh, index, config))
        return _block(shared, k, config)

    def describe(arrays: dict) -> str:
        return f"{mesh.name}, {len(arrays['target'])} samples"

    return make_shards(paths, make, progress=progress, describe=describe)


def _mesh_setup(work: Path, mesh: FoldMesh, index: int, config: TrainConfig) -> dict:
    """What every block of one mesh's data shares: the mesh, r, the vertex pool, the lights,
    the fabrics' scenes, the LocalPT integrator, the view samples and the hat points."""
    from .. import params as fabric_params
    from ..fixtures import path as fixture_path
    from ..render.fold.localpt import mi

    rng = np.random.default_rng([config.seed, index])
    rmesh = mesh.load(_folder(work, "meshes"))
    v, faces = rmesh.positions, rmesh.faces
    desc, radius, _ = cached_descriptors(v, faces, normals=rmesh.normals)
    r = radius.value
    pool = choose_vertices(desc, config.pool, config.folded_share, rng)
    lights = light_directions(config.lights, rng)
    fabrics = [fabric_params.load(fixture_path("params", f"{name}.json")) for name in config.fabrics]
    scenes = [fabric_scene(rmesh, fabric, config) for fabric in fabrics]
    integrator = mi.load_dict({"type": "localpt", "radius": r, "direct": False})
    seeds = rng.integers(2**31, size=(len(scenes), 2))
    near = [{side: neighbourhood_samples(scene, garment, v, faces, desc, side, config.neighbours,
                                         seed=int(seeds[f, side]), at=pool) for side in (0, 1)}
            for f, (scene, garment) in enumerate(scenes)]
    hats = {side: hat_points(v, faces, SIDES[side] * desc.normals.astype(np.float64), pool, config.hat_points,
                             rng)[:2] for side in (0, 1)}
    return {"index": index, "desc": desc, "r": r, "pool": pool, "lights": lights, "scenes": scenes,
            "integrator": integrator, "near": near, "hats": hats}


def _block(shared: dict, k: int, config: TrainConfig) -> dict:
    """The arrays of one mesh's block ``k`` of lights."""
    from ..render.fold.localpt import mi, radiance_leaving

    desc, r, pool, lights, scenes = shared["desc"], shared["r"], shared["pool"], shared["lights"], shared["scenes"]
    block = range(k * config.block, min((k + 1) * config.block, config.lights))
    block_rng = np.random.default_rng([config.seed, shared["index"], k])
    rows = {name: [] for name in ("features", "light_local", "vbar", "albedo", "albedo_here", "target", "vertex",
                                  "side", "fabric")}
    for light in block:
        f = light % len(scenes)
        scene, _ = scenes[f]
        params = mi.traverse(scene)
        params["sun.to_world"] = _towards(lights[light])
        params.update()
        pick = np.sort(block_rng.choice(len(pool), min(config.per_light, len(pool)), replace=False))
        at = pool[pick]
        to_light = np.broadcast_to(lights[light], (len(at), 3))
        for side in (0, 1):
            nb = shared["near"][f][side].take(pick)
            feats, light_local = B.inputs(desc, side, at, to_light)
            points, normals = (a[pick].reshape(-1, 3) for a in shared["hats"][side])
            target = radiance_leaving(scene, shared["integrator"], points, normals, normals, spp=config.paths,
                                      seed=int(block_rng.integers(2**31)), offset=1e-3 * r)
            here = albedo_at(scene, points, normals, 1e-3 * r)
            rows["features"].append(feats)
            rows["light_local"].append(light_local)
            rows["vbar"].append(lit_share(scene, nb, lights[light], r))
            rows["albedo"].append(nb.mean_albedo())
            rows["albedo_here"].append(here.reshape(len(at), config.hat_points, 3).mean(axis=1))
            rows["target"].append(target.reshape(len(at), config.hat_points, 3).mean(axis=1))
            rows["vertex"].append(at)
            rows["side"].append(np.full(len(at), side))
            rows["fabric"].append(np.full(len(at), f))
    shard = {name: np.concatenate(parts).astype(np.int32 if name in ("vertex", "side", "fabric") else np.float32)
             for name, parts in rows.items()}
    return shard | {"radius": np.float64(r)}


def _folder(work: Path, name: str) -> Path:
    folder = work / name
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def _towards(to_light: np.ndarray):
    """A directional emitter's to_world for light travelling along −to_light."""
    from ..render.fold.localpt import mi

    d = -np.asarray(to_light, float)
    up = [0.0, 0.0, 1.0] if abs(d[2]) < 0.99 else [0.0, 1.0, 0.0]
    return mi.ScalarTransform4f().look_at(origin=[0.0, 0.0, 0.0], target=d.tolist(), up=up)


def generate_data(work: Path, meshes: Sequence[FoldMesh], config: TrainConfig, *,
                  progress: Progress = lambda s: None) -> float:
    """Make the missing shards of every mesh; return the seconds all shards took (earlier runs too)."""
    return sum(make_mesh_shards(work, m, i, config, progress=progress) for i, m in enumerate(meshes))


def both_sides(shard) -> dict:
    """A shard's rows with both sides of their vertex: ``vbar`` (N, 4), the four shares of
    :data:`.blidf.SHARES` (the row's own two and those of the same vertex and light on the other
    side), and ``albedo`` (N, 3), the neighbourhood's albedo — the row's side's, or where that
    side found no neighbourhood the other side's (:func:`.visibility.neighbourhood_albedo`).

    A shard holds, light after light, one run of rows on side 0 then the same vertices on side
    1 (:func:`make_mesh_shards`); a run pairs with the run next to it.
    """
    side, vertex = np.asarray(shard["side"]), np.asarray(shard["vertex"])
    vbar, albedo = np.asarray(shard["vbar"]), np.asarray(shard["albedo"])
    starts = np.flatnonzero(np.diff(np.concatenate([[-1], side])) != 0)
    runs = np.split(np.arange(len(side)), starts[1:])
    if len(runs) % 2 or any(side[a[0]] != 0 or side[b[0]] != 1 or len(a) != len(b) or np.any(vertex[a] != vertex[b])
                            for a, b in zip(runs[::2], runs[1::2])):
        raise ValueError("a fold training shard whose rows are not runs of side 0 and side 1 of the same vertices")
    other = np.empty(len(side), np.int64)
    for a, b in zip(runs[::2], runs[1::2]):
        other[a], other[b] = b, a
    return {"vbar": np.concatenate([vbar, vbar[other]], axis=1),
            "albedo": neighbourhood_albedo(albedo, albedo[other])}


def load_data(work: Path, meshes: Sequence[FoldMesh], config: TrainConfig) -> tuple[dict, dict]:
    """(train, held-out) arrays: every shard but each mesh's last block of lights, and those
    blocks; ``vbar`` and ``albedo`` of both sides (:func:`both_sides`)."""
    def cat(items):
        parts = [dict(np.load(shard_path(work, i, m, k))) for i, m, k in items]
        for p in parts:
            p.update(both_sides(p))
        keys = ("features", "light_local", "vbar", "albedo", "albedo_here", "target", "vertex", "side", "fabric")
        out = {key: np.concatenate([p[key] for p in parts]) for key in keys}
        out["mesh"] = np.concatenate([np.full(len(p["target"]), i) for (i, _, _), p in zip(items, parts)])
        return out

    last = config.blocks - 1
    train = [(i, m, k) for i, m in enumerate(meshes) for k in range(last)]
    held = [(i, m, last) for i, m in enumerate(meshes)]
    return cat(train), cat(held)


def mesh_radii(work: Path, meshes: Sequence[FoldMesh], config: TrainConfig) -> dict:
    """The neighbourhood radius r each mesh's shards were made with (metres), by name."""
    return {m.name: round(float(np.load(shard_path(work, i, m, 0))["radius"]), 5) for i, m in enumerate(meshes)}


def torch_network(blidf_arrays: dict | None = None):
    """The BLIDF as a torch module (same layers as :class:`.blidf.BLIDF`), optionally from arrays."""
    import torch
    from torch import nn

    def mlp(sizes):
        layers = []
        for a, b in zip(sizes[:-1], sizes[1:]):
            layers += [nn.Linear(a, b), nn.SiLU()]
        return nn.Sequential(*layers[:-1])

    class Net(nn.Module):
        def __init__(self):
            super().__init__()
            self.intensity = mlp(B.INTENSITY_LAYERS)
            self.direction = mlp(B.DIRECTION_LAYERS)
            self.register_buffer("mean", torch.zeros(len(B.FEATURES)))
            self.register_buffer("std", torch.ones(len(B.FEATURES)))

        def forward(self, features, light_local, albedo):
            """The gains (N, C, 4) for neighbourhood albedos (N, C); the same function as BLIDF.gain."""
            x = ((features - self.mean) / self.std).clamp(-B.INPUT_CLIP, B.INPUT_CLIP)
            sh = torch_sh(light_local)
            direction = torch.relu(1.0 + (sh * self.direction(x)).sum(dim=1))
            n, c = albedo.shape
            per_channel = torch.cat([x.repeat(c, 1), albedo.T.reshape(-1, 1)], dim=1)  # channel-major rows
            inten = nn.functional.softplus(self.intensity(per_channel)).reshape(c, n, len(B.SHARES)).permute(1, 0, 2)
            return albedo[..., None] * inten * direction[:, None, None]

    net = Net()
    if blidf_arrays is not None:
        net.load_state_dict(_state_from_arrays(net, blidf_arrays))
    return net


def torch_sh(w):
    """:func:`.blidf.sh_basis` in torch."""
    import torch

    x, y, z = w[:, 0], w[:, 1], w[:, 2]
    c1, c2, c20, c22 = 0.4886025119029199, 1.0925484305920792, 0.31539156525252005, 0.5462742152960396
    return torch.stack([c1 * y, c1 * z, c1 * x, c2 * x * y, c2 * y * z, c20 * (3 * z * z - 1), c2 * x * z,
                        c22 * (x * x - y * y)], dim=1) / B.Y00


def arrays_of(net) -> dict:
    """The plain arrays :class:`.blidf.BLIDF` evaluates (weights transposed to (in, out))."""
    arrays = {"mean": net.mean.detach().numpy().astype(np.float64), "std": net.std.detach().numpy().astype(np.float64)}
    for prefix, seq in (("i", net.intensity), ("d", net.direction)):
        linears = [m for m in seq if hasattr(m, "weight")]
        for k, lin in enumerate(linears):
            arrays[f"{prefix}.w{k}"] = lin.weight.detach().numpy().T.astype(np.float64)
            arrays[f"{prefix}.b{k}"] = lin.bias.detach().numpy().astype(np.float64)
    return arrays


def _state_from_arrays(net, arrays: dict) -> dict:
    import torch

    state = {"mean": torch.as_tensor(arrays["mean"], dtype=torch.float32),
             "std": torch.as_tensor(arrays["std"], dtype=torch.float32)}
    for prefix, name, seq in (("i", "intensity", net.intensity), ("d", "direction", net.direction)):
        positions = [i for i, m in enumerate(seq) if hasattr(m, "weight")]
        for k, pos in enumerate(positions):
            state[f"{name}.{pos}.weight"] = torch.as_tensor(arrays[f"{prefix}.w{k}"].T, dtype=torch.float32)
            state[f"{name}.{pos}.bias"] = torch.as_tensor(arrays[f"{prefix}.b{k}"], dtype=torch.float32)
    return state


def _tensors(data: dict, lit_only: bool = True):
    import torch

    keep = data["vbar"].sum(axis=1) > 0 if lit_only else np.ones(len(data["vbar"]), bool)
    return {k: torch.as_tensor(np.asarray(data[k][keep], np.float32)) for k in
            ("features", "light_local", "vbar", "albedo", "albedo_here", "target")}


def prediction_error(net, data: dict) -> dict:
    """RMSE (radiance, unit irradiance) of E·ρ·Σ V̄·gain and of 0 (no fold term) over all samples and
    channels, and the prediction's mean over LocalPT's (1: no bias on the whole)."""
    import torch

    t = _tensors(data, lit_only=False)
    with torch.no_grad():
        pred = t["albedo_here"] * torch.einsum("nck,nk->nc", net(t["features"], t["light_local"], t["albedo"]),
                                               t["vbar"])
    err = float(torch.sqrt(torch.mean((pred - t["target"]) ** 2)))
    zero = float(torch.sqrt(torch.mean(t["target"] ** 2)))
    ratio = float(pred.mean() / t["target"].mean().clamp_min(1e-30))
    return {"rmse": round(err, 6), "rmse_without": round(zero, 6), "mean_ratio": round(ratio, 4),
            "samples": int(len(t["vbar"]))}


def train(work: Path, meshes: Sequence[FoldMesh], config: TrainConfig, *,
          progress: Progress = lambda s: None) -> tuple[object, float, dict]:
    """Train on the skeleton's epochs (:class:`weavecap.training.trainer.Trainer`, resuming
    from ``work/checkpoint.pt``); return the network, seconds spent and held-out errors."""
    import torch

    torch.manual_seed(config.seed)
    train_set, held = load_data(work, meshes, config)
    net = torch_network()
    t = _tensors(train_set)
    net.mean.copy_(t["features"].mean(dim=0))
    net.std.copy_(t["features"].std(dim=0).clamp_min(1e-3))
    opt = torch.optim.AdamW(net.parameters(), lr=config.lr, weight_decay=config.weight_decay)
    # the loss in units of the targets' spread: radiances of 1e-4 would leave Adam's steps to its ε
    scale = float(1.0 / torch.sqrt(torch.mean(t["target"] ** 2)).clamp_min(1e-12))
    examples = len(t["vbar"])
    sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, T_max=config.epochs * -(-examples // config.batch))
    trainer = Trainer(work, config.train_settings(), net, opt, sched, progress=progress)

    def loss(idx):
        gains = net(t["features"][idx], t["light_local"][idx], t["albedo"][idx])
        pred = t["albedo_here"][idx] * torch.einsum("nck,nk->nc", gains, t["vbar"][idx])
        return torch.mean(((pred - t["target"][idx]) * scale) ** 2)

    def after(done: int, mean_loss: float) -> None:
        if done % 5 == 0 or done == config.epochs:
            err = prediction_error(net, held)
            progress(f"train: epoch {done}/{config.epochs} train RMSE {np.sqrt(mean_loss) / scale:.6f} held-out "
                     f"{err['rmse']:.6f} (no fold term {err['rmse_without']:.6f}; mean {err['mean_ratio']:.3f}× "
                     f"LocalPT's; {trainer.seconds:.0f} s)")

    trainer.epochs(config.epochs, examples, config.batch, config.seed, loss, after=after)
    return net, trainer.seconds, {"train": prediction_error(net, train_set), "heldout": prediction_error(net, held)}


def write_weights(path: Path, net, meshes: Sequence[FoldMesh], config: TrainConfig, *, data_seconds: float,
                  train_seconds: float, errors: dict, radii: dict) -> B.BLIDF:
    """Write the weights and the record of how they were made (one JSON file); return the BLIDF."""
    arrays = arrays_of(net)
    record = {
        "paper": "Son et al., Neural Local Inter-reflection Modeling for Garment Fold Rendering (supplement)",
        "made_by": "weavecap train-renderer --fold",
        "features": list(B.FEATURES),
        "network": {"intensity": list(B.INTENSITY_LAYERS), "direction": list(B.DIRECTION_LAYERS),
                    "sh_bands": 3, "activation": "SiLU"},
        "parameters": int(sum(a.size for k, a in arrays.items() if k.startswith(("i.", "d.")))),
        "config": asdict(config),
        "meshes": [{"name": m.name, "vertices": int(len(m.shape.positions)), "radius": radii.get(m.name)}
                   for m in meshes],
        "ground_truth": "LocalPT (weavecap.render.fold.localpt), local inter-reflection only, max depth 16, RR "
                        "from 5, same shape, the surface model of each fixture fabric; directional lights of unit "
                        "irradiance",
        "seconds": {"data": round(data_seconds, 1), "train": round(train_seconds, 1)},
        "errors": errors,
    }
    model = B.BLIDF(arrays=arrays, record=record)
    path.parent.mkdir(parents=True, exist_ok=True)
    model.save(path)
    return model
