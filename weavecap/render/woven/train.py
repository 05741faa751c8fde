"""Training the woven network (Chen et al. 2024, §5.2), resumable, and its held-out errors.

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

import json
import math
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from . import data as _data
from . import terms as _terms
from .terms import CHANNELS


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

    def __init__(self, folder: Path, config: _data.DataConfig):
        inputs, features, targets, baseline, material = [], [], [], [], []
        mats = {"image": [], "params": [], "fabric": [], "side": [], "shape": [], "colours": []}
        offset = 0
        for shard in range(config.shards):
            path = _data.shard_path(folder, shard)
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
        held = np.array([_data.is_held_out(config, int(f)) for f in self.fabric])
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

    from .network import WovenNet

    torch.manual_seed(config.seed)
    return WovenNet(use_features=config.use_features, use_baseline=config.use_baseline,
                    encoder_widths=tuple(config.encoder_widths), width=config.width)


def train(dataset: Dataset, folder: Path, config: TrainConfig, *, progress=None, log=None):
    """Train (or resume) in ``folder`` (checkpoint ``checkpoint.pt``, loaded with
    ``weights_only=True``). Returns (model, summary dict: steps, seconds, last losses)."""
    import torch

    from .network import loss

    torch.set_num_threads(config.threads)
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    model = build(config)
    opt = torch.optim.Adam(model.parameters(), lr=config.lr, weight_decay=config.weight_decay)
    ckpt = folder / "checkpoint.pt"
    step, seconds = 0, 0.0
    if ckpt.exists():
        state = torch.load(ckpt, weights_only=True)
        model.load_state_dict(state["model"])
        opt.load_state_dict(state["optimizer"])
        step, seconds = int(state["step"]), float(state["seconds"])
    history = []
    start = time.perf_counter() - seconds
    running = None
    while step < config.steps:
        rng = np.random.default_rng([config.seed, step])
        b = _tensors(dataset.batch(rng, config.materials, config.queries))
        for group in opt.param_groups:
            group["lr"] = learning_rate(config, step)
        out = model(b["image"], b["params"], b["material"], b["inputs"], b["features"], b["baseline"])
        total, spec, body = loss(out, b["targets"], b["inputs"], use_baseline=config.use_baseline)
        opt.zero_grad()
        total.backward()
        opt.step()
        step += 1
        values = np.array([total.item(), spec.item(), body.item()])
        running = values if running is None else 0.98 * running + 0.02 * values
        if step % 50 == 0:
            history.append([step, *running.tolist()])
            if log is not None:
                log(f"step {step}/{config.steps} loss {running[0]:.5f} spec {running[1]:.5f} body {running[2]:.6f} "
                    f"lr {learning_rate(config, step):.2e} ({time.perf_counter() - start:.0f} s)")
        if progress is not None:
            progress(step, config.steps)
        if step % config.checkpoint_every == 0 or step == config.steps:
            from ...io import atomic_path

            with atomic_path(ckpt) as tmp:
                torch.save({"model": model.state_dict(), "optimizer": opt.state_dict(), "step": step,
                            "seconds": time.perf_counter() - start}, tmp)
    seconds = time.perf_counter() - start
    return model, {"steps": step, "seconds": seconds, "history": history}


def evaluate(model, dataset: Dataset, materials: np.ndarray, *, queries: int = 2048, seed: int = 1,
             baseline_only: bool = False) -> dict:
    """Errors in RGB on ``materials`` (``queries`` random queries each): relative MSE
    (Σ err² / Σ truth²) and relative mean absolute error, overall and by footprint size and
    light side."""
    import torch

    from .network import to_values

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
    them as JSON (``path`` with ``.json``)."""
    from ...io import atomic_path, atomic_write_text

    arrays = {k: v.detach().cpu().numpy().astype(np.float32) for k, v in model.state_dict().items()}
    with atomic_path(path) as tmp:
        np.savez_compressed(tmp, **arrays)
    atomic_write_text(Path(path).with_suffix(".json"), json.dumps(record, indent=1) + "\n")


def record(data_config: _data.DataConfig, train_config: TrainConfig, *, data_seconds: float, train_summary: dict,
           held_out: dict, seen: dict, dataset: Dataset) -> dict:
    """How the weights were made: configs, sizes, times and errors (the JSON beside them)."""
    return {"format": "weavecap.woven/1", "paper": "Chen et al. 2024, Real-time Neural Woven Fabric Rendering",
            "channels": list(CHANNELS), "data": asdict(data_config), "train": asdict(train_config),
            "queries": int(len(dataset.inputs)), "materials": int(len(dataset.fabric)),
            "held_out_materials": int(len(dataset.held_materials)), "data_seconds": data_seconds,
            "train_seconds": train_summary["seconds"], "steps": train_summary["steps"],
            "loss_history": train_summary["history"][-20:], "held_out_errors": held_out, "seen_errors": seen}
