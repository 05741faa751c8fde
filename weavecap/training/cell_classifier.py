"""Training data and training of the cell classifier (:mod:`weavecap.estimate.cell_classifier`).

Data: :func:`weavecap.estimate.cell_photos.cell_sample` images of random weaves
(:data:`~weavecap.estimate.cell_photos.WEAVE_KINDS`, drawn equally often) and, for a fifth,
the forward model's renders of them (:func:`forward_samples`: smooth, clean yarns of other
shading, which the fit's own renders and photos like them look like), each a canvas of
``cells`` × ``cells`` cells at :data:`~weavecap.estimate.cell_classifier.CELL_PX` with every
cell's state. They are written in shards (:func:`weavecap.training.trainer.make_shards`:
``.npz`` of the canvases as 8-bit sRGB, as a photo holds them, the labels — soft where a canvas
is half a cell off — and the weave kind of each); a shard that exists is not made again, so an
interrupted run resumes; the last ``heldout_shards`` shards are held out, never trained on.

Training: AdamW on the binary cross-entropy of every cell's logit, one-cycle learning rate,
epochs of shuffled batches with a checkpoint after each (:class:`weavecap.training.trainer.Trainer`:
an interrupted run resumes at the next epoch), each batch flipped up–down and left–right at
random (a flip keeps which yarn is on top in each cell; drawn from a generator seeded by the
batch's first example and the epoch, so a resumed run flips alike). Then the logits' temperature is fitted
on the held-out shards (the scale that minimises their cross-entropy: calibrated probabilities
for the pattern decision, :mod:`weavecap.estimate.decide`), and the held-out accuracy, overall
and per weave kind, is written into the record beside the weights
(:func:`weavecap.training.trainer.write_weights`).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path
import numpy as np

from ..estimate.cell_classifier import CELL_PX, WEIGHTS_FILE, WIDTHS, build_network, count_parameters, network_input
from ..estimate.cell_photos import MARGIN, WEAVE_KINDS, cell_sample, photographed, random_weave, tiled
from ..photo import linear_to_srgb, srgb_to_linear
from . import trainer as skeleton

Progress = skeleton.Progress


@dataclass(frozen=True)
class CellTrainConfig:
    """Every knob of a training run (recorded beside the weights)."""

    seed: int = 0
    images: int = 8000
    shard_images: int = 250
    heldout_shards: int = 2
    cells: int = 12
    forward_share: float = 0.2
    per_geometry: int = 4
    epochs: int = 8
    batch: int = 16
    lr: float = 3e-3
    weight_decay: float = 1e-4
    widths: tuple = WIDTHS

    def __post_init__(self):
        if self.shards <= self.heldout_shards:
            raise ValueError(f"{self.images} images make {self.shards} shards of {self.shard_images}: too few to hold "
                             f"{self.heldout_shards} out; make more images")

    @property
    def shards(self) -> int:
        return -(-self.images // self.shard_images)

    def train_settings(self) -> dict:
        """The settings a checkpoint depends on (:class:`weavecap.training.trainer.Trainer`)."""
        return {k: getattr(self, k) for k in ("seed", "epochs", "batch", "lr", "weight_decay")} | {
            "widths": list(self.widths)}


def _to_srgb8(linear: np.ndarray) -> np.ndarray:
    """A linear canvas in [0, 1] as a photo holds it: 8-bit sRGB."""
    return (linear_to_srgb(np.clip(linear, 0, 1)) * 255 + 0.5).astype(np.uint8)


def forward_samples(rng: np.random.Generator, count: int, kind: str, *, cells: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """``count`` examples of one random geometry of the forward model (:mod:`weavecap.model`):
    a weave of ``kind`` (at most 12 yarns a side) and a fabric over Table 1
    (:func:`weavecap.estimate.sampling.random_fabric`) under a random light rig, rendered
    orthographically at 10–27 px a yarn; each further example another appearance of the same
    geometry (the colours and the specular and shadowing terms redrawn: one shading pass, the
    rays cast once). Each render goes through :func:`~weavecap.estimate.cell_photos.photographed`
    like the procedural images. Returns [(canvas, labels)] as
    :func:`~weavecap.estimate.cell_photos.cell_sample`."""
    from ..estimate.initializer import CONTINUOUS_KEYS
    from ..estimate.sampling import random_fabric
    from ..model.render import render_numpy
    from ..model.scene import GEOMETRY_KEYS, RIGS, View, build_scene

    weave = random_weave(rng, kind, max_size=12)
    span = (cells + 2 * MARGIN, cells + 2 * MARGIN)
    tiles = (-(-span[0] // weave.shape[0]), -(-span[1] // weave.shape[1]))
    rows, cols = tiles[0] * weave.shape[0], tiles[1] * weave.shape[1]
    render_px = int(rng.integers(10, 28))
    fabric = random_fabric(rng, weave)
    fs = build_scene(fabric, View(tiles=tiles, size=render_px * max(rows, cols), spp=4), light=str(rng.choice(RIGS)))
    out = []
    for k in range(count):
        if k:
            other = random_fabric(rng, weave)
            for key in CONTINUOUS_KEYS:
                if key not in GEOMETRY_KEYS:
                    fs.set(key, other.get(key))
        image = render_numpy(fs, seed=k)[: span[0] * render_px, : span[1] * render_px]
        out.append(photographed(rng, image, tiled(weave, span), float(render_px), cells=(cells, cells),
                                cell_px=CELL_PX))
    return out


def make_shard(config: CellTrainConfig, index: int) -> dict:
    """Shard ``index``: ``shard_images`` examples (fewer in the last), from a generator seeded
    with (seed, index): a share ``forward_share`` of them rendered by the forward model
    (:func:`forward_samples`, ``per_geometry`` appearances a geometry), the rest by
    :func:`~weavecap.estimate.cell_photos.cell_sample`. Arrays: ``image`` (N, H, W, 3) uint8
    sRGB, ``labels`` (N, cells, cells) float16, ``kind`` (N,) str (``forward:`` before the
    forward model's)."""
    rng = np.random.default_rng([config.seed, index])
    count = min(config.shard_images, config.images - index * config.shard_images)
    forward = int(round(config.forward_share * count))
    images, labels, kinds = [], [], []
    while len(images) < forward:
        kind = str(rng.choice(WEAVE_KINDS))
        for canvas, lab in forward_samples(rng, min(config.per_geometry, forward - len(images)), kind,
                                           cells=config.cells):
            images.append(_to_srgb8(canvas))
            labels.append(lab.astype(np.float16))
            kinds.append(f"forward:{kind}")
    while len(images) < count:
        kind = str(rng.choice(WEAVE_KINDS))
        canvas, lab = cell_sample(rng, cells=(config.cells, config.cells), cell_px=CELL_PX,
                                  weave=random_weave(rng, kind))
        images.append(_to_srgb8(canvas))
        labels.append(lab.astype(np.float16))
        kinds.append(kind)
    return {"image": np.stack(images), "labels": np.stack(labels), "kind": np.array(kinds)}


def shard_paths(work: Path, config: CellTrainConfig) -> list[Path]:
    """Where the data shards live: ``work/data/shard_k.npz``."""
    return [skeleton.shard_path(Path(work) / "data", k) for k in range(config.shards)]


def generate_data(work: Path, config: CellTrainConfig, *, progress: Progress = lambda s: None) -> float:
    """Make the missing shards; return the seconds all shards took to make."""
    (Path(work) / "data").mkdir(parents=True, exist_ok=True)
    return skeleton.make_shards(shard_paths(work, config), lambda index: make_shard(config, index), progress=progress,
                                describe=lambda arrays: f"{len(arrays['labels'])} images")


def load_data(work: Path, config: CellTrainConfig, indices) -> dict:
    """Concatenated shards ``indices``: ``x`` (N, 3, H, W) float16 network inputs, ``labels``,
    ``kind``."""
    paths = shard_paths(work, config)
    data = skeleton.concatenate_shards([paths[i] for i in indices], ("image", "labels", "kind"))
    x = np.stack([network_input(srgb_to_linear(im / np.float32(255))).astype(np.float16) for im in data["image"]])
    return {"x": x, "labels": data["labels"], "kind": data["kind"]}


def predict_logits(net, x: np.ndarray) -> np.ndarray:
    """The network's raw logits for inputs ``x`` (N, 3, H, W): (N, cells, cells)."""
    import torch

    net.eval()
    with torch.no_grad():
        return np.concatenate([net(torch.from_numpy(x[i:i + 32].astype(np.float32)))[:, 0].numpy()
                               for i in range(0, len(x), 32)])


def fit_temperature(logits: np.ndarray, labels: np.ndarray) -> float:
    """The scale T minimising the cross-entropy of ``sigmoid(logits / T)`` against ``labels``
    (a golden-section search over log T in [−2, 3])."""
    z, y = logits.ravel().astype(np.float64), labels.ravel().astype(np.float64)

    def nll(log_t: float) -> float:
        s = z / np.exp(log_t)
        return float(np.mean(np.logaddexp(0, s) - y * s))

    lo, hi = -2.0, 3.0
    g = (np.sqrt(5) - 1) / 2
    a, b = hi - g * (hi - lo), lo + g * (hi - lo)
    for _ in range(60):
        if nll(a) < nll(b):
            hi, b = b, a
            a = hi - g * (hi - lo)
        else:
            lo, a = a, b
            b = lo + g * (hi - lo)
    return float(np.exp(0.5 * (lo + hi)))


def heldout_scores(logits: np.ndarray, held: dict, temperature: float = 1.0) -> dict:
    """On the held-out shards: the accuracy on the cells whose label is sure (0 or 1), overall
    and per weave kind; the share of images on the crossings (no cell half off) every cell of
    which is right; and the mean confidence (|P − ½| × 2) on those and on the images half a cell
    off, which the decision tells a lattice's phase by."""
    labels = held["labels"].astype(np.float32)
    sure = (labels == 0) | (labels == 1)
    right = (logits > 0) == (labels == 1)
    on_phase = sure.all(axis=(1, 2))
    kinds = sorted(set(held["kind"].tolist()))
    per_kind = {k: round(float(right[sure & (held["kind"] == k)[:, None, None]].mean()), 4)
                for k in kinds if np.any(sure & (held["kind"] == k)[:, None, None])}
    confidence = np.abs(2.0 / (1.0 + np.exp(-logits / temperature)) - 1.0).mean(axis=(1, 2))
    return {"cell_accuracy": round(float(right[sure].mean()), 4),
            "images_all_right": round(float(right[on_phase].all(axis=(1, 2)).mean()), 4),
            "per_kind": per_kind, "cells": int(sure.sum()), "images": int(len(right)),
            "confidence_on_crossings": round(float(confidence[on_phase].mean()), 3),
            "confidence_half_off": round(float(confidence[~on_phase].mean()), 3) if np.any(~on_phase) else None}


def train(work: Path, config: CellTrainConfig, *, progress: Progress = lambda s: None) -> tuple[object, float]:
    """Train (resuming from ``work/checkpoint.pt``); return the network and the seconds spent."""
    import torch

    torch.manual_seed(config.seed)
    net = build_network(tuple(config.widths))
    opt = torch.optim.AdamW(net.parameters(), lr=config.lr, weight_decay=config.weight_decay)
    data = load_data(work, config, range(config.shards - config.heldout_shards))
    steps = -(-len(data["labels"]) // config.batch)
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, max_lr=config.lr, total_steps=config.epochs * steps, pct_start=0.1)
    trainer = skeleton.Trainer(work, config.train_settings(), net, opt, sched, progress=progress)
    x_all = torch.from_numpy(data["x"])
    y_all = torch.from_numpy(data["labels"].astype(np.float32))
    loss_fn = torch.nn.BCEWithLogitsLoss()

    def loss(idx):
        x, y = x_all[idx].float(), y_all[idx]
        flips = torch.rand(2, generator=torch.Generator().manual_seed(int(idx[0]) * 7919 + trainer.done))
        if flips[0] < 0.5:
            x, y = x.flip(2), y.flip(1)
        if flips[1] < 0.5:
            x, y = x.flip(3), y.flip(2)
        return loss_fn(net(x)[:, 0], y)

    trainer.epochs(config.epochs, len(y_all), config.batch, config.seed, loss,
                   after=lambda done, mean: progress(f"train: epoch {done}/{config.epochs} loss {mean:.4f} "
                                                     f"({trainer.seconds:.0f} s)"))
    return net, trainer.seconds


def run(work: Path, out: Path, config: CellTrainConfig, *, progress: Progress = lambda s: None) -> dict:
    """Data, training, temperature and held-out scores; the weights and their record written to
    ``out`` (created if missing). Returns the record."""
    import torch

    torch.set_num_threads(1)
    Path(out).mkdir(parents=True, exist_ok=True)
    data_seconds = generate_data(work, config, progress=progress)
    net, train_seconds = train(work, config, progress=progress)
    held = load_data(work, config, range(config.shards - config.heldout_shards, config.shards))
    logits = predict_logits(net, held["x"])
    temperature = fit_temperature(logits, held["labels"].astype(np.float32))
    record = {
        "format": "weavecap.cell_classifier/1",
        "what": "P(weft on top) per cell of a cell canvas (weavecap/estimate/cell_classifier.py)",
        "cell_px": CELL_PX, "widths": list(config.widths), "parameters": count_parameters(net),
        "input": "sqrt(linear RGB) as luminance and two opponent channels, local mean removed, over the local "
                 "luminance spread (sigma 2 cells)",
        "config": asdict(config) | {"widths": list(config.widths)},
        "data": {"generator": "weavecap/estimate/cell_photos.py", "kinds": list(WEAVE_KINDS),
                 "train_images": int((config.shards - config.heldout_shards) * config.shard_images),
                 "heldout_images": int(len(held["labels"]))},
        "temperature": round(temperature, 4),
        "heldout": heldout_scores(logits, held, temperature),
        "seconds": {"data": round(data_seconds, 1), "train": round(train_seconds, 1)},
        "command": f"python scripts/train_cell_classifier.py --seed {config.seed} --images {config.images} "
                   f"--epochs {config.epochs}",
    }
    skeleton.write_weights(Path(out) / WEIGHTS_FILE, net, record)
    progress(f"held-out: {record['heldout']['cell_accuracy']:.4f} of cells right; temperature {temperature:.3f}")
    return record
