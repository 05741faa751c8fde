"""Which yarn is on top in each cell, read off the photo by a small network (Wu et al. 2025
§5.1's question, answered without the forward model).

§5.1 anneals every cell's state against the forward model's render, and the model cannot
render real yarns — hairy, plied, twisted, striped — so on real cloth that comparison is a
coin toss. The cues that survive a real photo are the yarn's own: the direction of its fine
texture (fibres and plies run along the yarn on top), where a float ends (the yarn dips and
darkens), and which yarn runs on unbroken across the cell's borders. A small fully
convolutional network reads them: the input is a cell canvas
(:func:`weavecap.estimate.cells.cell_canvas`, :data:`CELL_PX` per cell) of any number of cells,
the output one logit per cell (> 0: the weft is on top), each cell seeing about two cells of
its neighbours (the receptive field of four stride-2 stages and the context layers).

The input is contrast-normalised locally (:func:`network_input`): the square root of the
linear values (closer to what the eye sees), as luminance and two opponent colour channels,
each minus its mean over about two cells and divided by the luminance's local spread — so the
network sees structure and colour differences, not the exposure, the light's gradient or a
colour block's hue.

The weights are trained on :mod:`.cell_photos`' varied procedural images
(:mod:`weavecap.training.cell_classifier`, ``scripts/train_cell_classifier.py``) and shipped as
``.npz`` (read with ``allow_pickle=False``) beside a JSON record of how they were trained and
what they scored on held-out images (:func:`load_classifier`).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

CELL_PX = 16  # canvas pixels per cell
WEIGHTS_FILE = "cell_classifier.npz"
RECORD_FILE = "cell_classifier.json"
#: channel widths of the stages: full resolution, then after each of the four stride-2 steps
WIDTHS = (12, 16, 24, 32, 32)


def weights_dir() -> Path:
    """The folder of the shipped weights."""
    return Path(__file__).resolve().parent / "weights"


def network_input(canvas: np.ndarray) -> np.ndarray:
    """The network's input for a cell canvas: (3, H, W) float32.

    ``canvas`` (H, W, 3) linear RGB (any exposure). Its square root is split into luminance
    and two opponent colour channels (red − green, blue − yellow); each has its local mean
    (:func:`local_mean`) taken away, and all are divided by the luminance's local standard
    deviation (same window; at least 2% of the local mean luminance, so that a flat patch stays
    flat rather than amplifying noise).
    """
    img = np.sqrt(np.clip(np.asarray(canvas, np.float32), 0.0, None))
    if img.ndim == 2:
        img = np.repeat(img[..., None], 3, axis=2)
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    chans = [(r + g + b) / 3.0, r - g, b - 0.5 * (r + g)]
    means = [local_mean(c) for c in chans]
    lum_var = local_mean((chans[0] - means[0]) ** 2)
    spread = np.sqrt(np.maximum(lum_var, (0.02 * np.maximum(means[0], 1e-3)) ** 2)) + 1e-4
    return np.stack([(c - m) / spread for c, m in zip(chans, means)]).astype(np.float32)


def local_mean(channel: np.ndarray) -> np.ndarray:
    """A channel's mean over about two cells: a Gaussian of σ = 2 cells, borders reflected."""
    return cv2.GaussianBlur(channel, (0, 0), 2.0 * CELL_PX, borderType=cv2.BORDER_REFLECT)


def build_network(widths: tuple[int, ...] = WIDTHS):
    """The classifier (a ``torch.nn.Sequential``): a 3×3 convolution at full resolution, four
    stride-2 stages (16 px a cell down to 1), two 3×3 context layers at one pixel a cell and a
    1×1 read-out: (B, 3, 16 n_e, 16 n_a) → (B, 1, n_e, n_a) logits. Batch normalisation after
    each convolution (folded into it at inference by ``eval()``)."""
    import torch.nn as nn

    layers: list = []

    def conv(cin: int, cout: int, stride: int = 1) -> None:
        layers.extend([nn.Conv2d(cin, cout, 3, stride=stride, padding=1, bias=False), nn.BatchNorm2d(cout),
                       nn.ReLU(inplace=True)])

    conv(3, widths[0])
    for cin, cout in zip(widths[:-1], widths[1:]):
        conv(cin, cout, stride=2)
    conv(widths[-1], widths[-1])
    conv(widths[-1], widths[-1])
    layers.append(nn.Conv2d(widths[-1], 1, 1))
    return nn.Sequential(*layers)


def count_parameters(net) -> int:
    """Trainable parameters of ``net``."""
    return int(sum(p.numel() for p in net.parameters() if p.requires_grad))


@dataclass
class CellClassifier:
    """A loaded classifier: the network (eval mode), its temperature and its record."""

    net: object
    record: dict

    @property
    def temperature(self) -> float:
        """The logits' scale that makes their probabilities calibrated on held-out procedural
        cells (fitted after training; 1 when not recorded)."""
        return float(self.record.get("temperature", 1.0))

    def logits(self, canvas: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
        """(n_e, n_a) calibrated logits of a cell canvas ((n_e * CELL_PX, n_a * CELL_PX, 3)
        linear RGB): > 0 where the weft is on top, the log-odds of it."""
        import torch

        n_e, n_a = shape
        if canvas.shape[:2] != (n_e * CELL_PX, n_a * CELL_PX):
            raise ValueError(f"canvas {canvas.shape[:2]} does not hold {shape} cells of {CELL_PX} px")
        x = torch.from_numpy(network_input(canvas))[None]
        threads = torch.get_num_threads()
        torch.set_num_threads(1)
        try:
            with torch.inference_mode():
                y = self.net(x)[0, 0].numpy().astype(np.float64)
        finally:
            torch.set_num_threads(threads)
        return y[:n_e, :n_a] / self.temperature

    def probabilities(self, canvas: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
        """(n_e, n_a) the probability that the weft is on top in each cell."""
        return 1.0 / (1.0 + np.exp(-self.logits(canvas, shape)))


def load_classifier(folder: str | Path | None = None) -> CellClassifier | None:
    """The classifier in ``folder`` (default: the shipped weights), read without pickle; None
    when there are none."""
    import torch

    folder = Path(folder) if folder is not None else weights_dir()
    wpath, rpath = folder / WEIGHTS_FILE, folder / RECORD_FILE
    if not (wpath.is_file() and rpath.is_file()):
        return None
    record = json.loads(rpath.read_text())
    net = build_network(tuple(record.get("widths", WIDTHS)))
    with np.load(wpath, allow_pickle=False) as data:
        net.load_state_dict({k: torch.from_numpy(np.array(data[k])) for k in data.files})
    net.eval()
    return CellClassifier(net=net, record=record)
