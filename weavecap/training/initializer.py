"""Training data and training of the initializer network (Wu et al. 2025 §5.3).

Data: for each *geometry* (a random pattern from :mod:`.sampling`, randomly shifted
cyclically, and random yarn radii) the forward model casts its rays once, then renders
``per_geometry`` random appearances over Table 1 (shading only: ~2 ms each). Each render is a
6 × 6-cell window at ``CELL_PX`` per cell under the default light rig (§6.4), from which the
network's 4 × 4-cell input is cut with the cell grid off by up to ±3 px (the grid of a real
photo is never exact), then blurred (σ up to 1.2 px, like §4.2's regularization) and given
pixel noise. Data are written in shards (``.npz``) and a shard that exists is not made again,
so an interrupted run resumes; the last ``heldout_shards`` shards are held out.

Training: AdamW on the mean squared error of the outputs in units of their ranges, one-cycle
learning rate (cosine decay), epochs of shuffled batches with a checkpoint after each
(:class:`weavecap.training.trainer.Trainer`: an interrupted run resumes at the next epoch).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Callable

import cv2
import numpy as np

from ..estimate.initializer import (CELL_PX, INPUT_CELLS, INPUT_PX, OUTPUT_KEYS, WEIGHTS_FILE, NetConfig,
                                    build_network, network_input, output_slices, range_arrays, to_vector)
from ..estimate.sampling import random_fabric, random_pattern
from ..params import FIT_RANGES
from . import trainer as skeleton

WINDOW_CELLS = INPUT_CELLS + 2  # rendered window: one spare cell on each side for the grid jitter
MAX_JITTER_PX = 3
Progress = Callable[[str], None]


@dataclass(frozen=True)
class TrainConfig:
    """Every knob of a training run (recorded beside the weights)."""

    seed: int = 0
    geometries: int = 600
    per_geometry: int = 8
    shard_geometries: int = 50
    heldout_shards: int = 1
    max_pattern: int = 8
    spp: int = 4
    epochs: int = 12
    batch: int = 64
    lr: float = 2e-3
    weight_decay: float = 1e-4
    network: NetConfig = field(default_factory=NetConfig)

    def __post_init__(self):
        if self.shards <= self.heldout_shards:
            raise ValueError(f"{self.geometries} geometries make {self.shards} shards of {self.shard_geometries}: "
                             f"too few to hold {self.heldout_shards} out; render more geometries")

    def data_settings(self) -> dict:
        """The settings the rendered shards depend on (a work folder holds one such set)."""
        return {k: getattr(self, k) for k in ("seed", "geometries", "per_geometry", "shard_geometries",
                                              "heldout_shards", "max_pattern", "spp")}

    def train_settings(self) -> dict:
        """The settings a checkpoint depends on."""
        return {"seed": self.seed, "epochs": self.epochs, "batch": self.batch, "lr": self.lr,
                "weight_decay": self.weight_decay, "network": self.network.to_json()}

    @property
    def shards(self) -> int:
        return -(-self.geometries // self.shard_geometries)


def _values_of(fabric) -> dict:
    return {k: fabric.get(k) for k in OUTPUT_KEYS}


def render_window(fabric, *, spp: int):
    """A FabricScene showing at least WINDOW_CELLS × WINDOW_CELLS cells at CELL_PX per cell."""
    from ..model.scene import View, build_scene

    n_e, n_a = fabric.shape
    tiles = (-(-WINDOW_CELLS // n_e), -(-WINDOW_CELLS // n_a))
    size = CELL_PX * max(tiles[0] * n_e, tiles[1] * n_a)
    return build_scene(fabric, View(tiles=tiles, size=size, spp=spp, camera="orthographic"), light="both")


def make_shard(config: TrainConfig, index: int) -> dict:
    """Render shard ``index``: ``shard_geometries × per_geometry`` examples (fewer in the last).

    Returns arrays: ``x`` (N, 4, INPUT_PX, INPUT_PX) float16 network inputs, ``y`` (N, N_OUTPUTS)
    float32 true values, ``family`` (N,) str, ``shape`` (N, 2) int pattern sizes.
    """
    from ..model.render import render_numpy

    rng = np.random.default_rng([config.seed, index])
    xs, ys, fams, shapes = [], [], [], []
    count = min(config.shard_geometries, config.geometries - index * config.shard_geometries)
    for _ in range(count):
        family, pattern = random_pattern(rng, max_size=config.max_pattern)
        pattern = np.roll(pattern, (int(rng.integers(pattern.shape[0])), int(rng.integers(pattern.shape[1]))),
                          axis=(0, 1))
        fs, radii = None, {}
        for _ in range(config.per_geometry):
            fabric = random_fabric(rng, pattern)
            if fs is None:  # the first appearance fixes the geometry (pattern and radii)
                fs = render_window(fabric, spp=config.spp)
                radii = {"warp.radius": fabric.warp.radius, "weft.radius": fabric.weft.radius}
            values = _values_of(fabric) | radii
            for key, value in values.items():
                if key not in radii:
                    fs.set(key, value)
            image = render_numpy(fs)  # one G-buffer per geometry: the same sample positions
            dy, dx = rng.integers(-MAX_JITTER_PX, MAX_JITTER_PX + 1, 2)
            y0, x0 = CELL_PX + dy, CELL_PX + dx
            crop = image[y0:y0 + INPUT_PX, x0:x0 + INPUT_PX]
            sigma = rng.uniform(0.0, 1.2)
            if sigma > 0.3:
                crop = cv2.GaussianBlur(crop, (0, 0), sigma)
            crop = crop + rng.normal(0.0, rng.uniform(0.0, 0.01), crop.shape).astype(np.float32)
            pat = np.tile(pattern, (-(-(INPUT_CELLS + 1) // pattern.shape[0]), -(-(INPUT_CELLS + 1) // pattern.shape[1])))
            xs.append(network_input(crop, pat[1:INPUT_CELLS + 1, 1:INPUT_CELLS + 1]).astype(np.float16))
            ys.append(to_vector(values))
            fams.append(family)
            shapes.append(pattern.shape)
    return {"x": np.stack(xs), "y": np.stack(ys).astype(np.float32), "family": np.array(fams),
            "shape": np.array(shapes, dtype=np.int32)}


def shard_paths(work: Path, config: TrainConfig) -> list[Path]:
    """The data shards of ``config`` under ``work/data``, in order."""
    return [skeleton.shard_path(work / "data", index) for index in range(config.shards)]


def generate_data(work: Path, config: TrainConfig, *, progress: Progress = lambda s: None) -> float:
    """Make the missing shards under ``work/data``; return the seconds all shards took to render
    (those of earlier, interrupted runs included)."""
    return skeleton.make_shards(shard_paths(work, config), lambda index: make_shard(config, index),
                                progress=progress, describe=lambda shard: f"{len(shard['y'])} images")


def load_data(work: Path, config: TrainConfig) -> tuple[dict, dict]:
    """(train, held-out) dicts of concatenated shard arrays."""
    paths, n_train = shard_paths(work, config), config.shards - config.heldout_shards
    keys = ("x", "y", "family", "shape")
    return skeleton.concatenate_shards(paths[:n_train], keys), skeleton.concatenate_shards(paths[n_train:], keys)


def _unit(y: np.ndarray) -> np.ndarray:
    lo, hi = range_arrays()
    return (y - lo) / (hi - lo)


def heldout_errors(net, data: dict) -> dict:
    """Mean absolute error per dotted key (Table 1 units; colours averaged over channels) of the
    network and of always predicting the middle of the range, on ``data``."""
    import torch

    net.eval()
    with torch.no_grad():
        pred = np.concatenate([net(torch.from_numpy(data["x"][i:i + 256].astype(np.float32))).numpy()
                               for i in range(0, len(data["x"]), 256)])
    lo, hi = range_arrays()
    truth = data["y"]
    out = {}
    for key, sl in output_slices().items():
        err = np.abs(pred[:, sl] - truth[:, sl]).mean()
        mid = np.abs(0.5 * (lo[sl] + hi[sl]) - truth[:, sl]).mean()
        out[key] = {"mae": round(float(err), 4), "mae_middle": round(float(mid), 4),
                    "ratio": round(float(err / mid), 3) if mid > 0 else None}
    return out


def train(work: Path, config: TrainConfig, *, progress: Progress = lambda s: None) -> tuple[object, float]:
    """Train (resuming from ``work/checkpoint.pt``); return the network and seconds spent."""
    import torch

    torch.manual_seed(config.seed)
    net = build_network(config.network)
    opt = torch.optim.AdamW(net.parameters(), lr=config.lr, weight_decay=config.weight_decay)
    train_set, held = load_data(work, config)
    steps_per_epoch = -(-len(train_set["y"]) // config.batch)
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, max_lr=config.lr, total_steps=config.epochs * steps_per_epoch,
                                                pct_start=0.15)
    trainer = skeleton.Trainer(work, config.train_settings(), net, opt, sched, progress=progress)
    x_all = torch.from_numpy(train_set["x"])
    y_all = torch.from_numpy(_unit(train_set["y"]).astype(np.float32))

    def loss(idx):
        return torch.mean((net.unit(x_all[idx].float()) - y_all[idx]) ** 2)

    def report(epoch: int, mean_loss: float) -> None:
        held_err = heldout_errors(net, held)
        mean_ratio = np.mean([v["ratio"] for v in held_err.values() if v["ratio"] is not None])
        progress(f"train: epoch {epoch}/{config.epochs} loss {mean_loss:.4f} "
                 f"held-out error/middle {mean_ratio:.3f} ({trainer.seconds:.0f} s)")

    trainer.epochs(config.epochs, len(y_all), config.batch, config.seed, loss, after=report)
    return net, trainer.seconds


def write_weights(out: Path, net, config: TrainConfig, *, data_seconds: float, train_seconds: float,
                  held: dict, counts: dict) -> dict:
    """Write ``initializer.pt`` (state dict) and ``initializer.json`` (how it was made) to ``out``."""
    cfg = asdict(config)
    cfg["network"] = config.network.to_json()
    record = {
        "format": "weavecap.initializer/1",
        "paper": "Wu et al. 2025, §5.3",
        "outputs": list(OUTPUT_KEYS),
        "ranges": {k: list(FIT_RANGES[k]) for k in OUTPUT_KEYS},
        "input": {"cells": INPUT_CELLS, "cell_px": CELL_PX, "channels": "sqrt(linear RGB), pattern - 0.5",
                  "light": "both", "camera": "orthographic", "spp": config.spp},
        "network": config.network.to_json(),
        "config": cfg,
        "counts": counts,
        "seconds": {"data": round(data_seconds, 1), "train": round(train_seconds, 1)},
        "heldout_errors": held,
        "command": f"weavecap train-initializer --seed {config.seed} --geometries {config.geometries} "
                   f"--per-geometry {config.per_geometry} --shard-size {config.shard_geometries} --epochs {config.epochs}",
    }
    skeleton.write_weights(out / WEIGHTS_FILE, net, record)
    return record
