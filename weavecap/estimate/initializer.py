"""Parameter pre-estimation (Wu et al. 2025 §5.3): a VGG-style network, or Table 1 defaults.

The network sees a window of ``INPUT_CELLS`` × ``INPUT_CELLS`` cells of the repeat (tiled
cyclically), each cell resampled to ``CELL_PX`` pixels — so yarns have the same size in its
input whatever the photo's resolution or the repeat's size — as four channels: the square
root of linear RGB, and the pre-estimated pattern (+0.5 where the weft is on top, -0.5 where
the warp is). VGG-style blocks (two 3×3 convolutions with batch norm and ReLU, then 2×2 max
pooling) turn it into features; two fully connected LeakyReLU layers and a linear layer give
one value per output, and a sigmoid scaled to each parameter's Table 1 range
(:data:`weavecap.params.FIT_RANGES`) maps it into that range (§5.3). No pretrained VGG can be
downloaded here, so the whole network is trained from scratch on the forward model's renders
(:mod:`weavecap.training.initializer`; ``weavecap train-initializer``).

Without weights, or for inputs it never saw, :func:`default_values` gives the middle of every
range (§5.3, §7.3: the pre-estimation can be bypassed, at the price of a longer fit).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from ..params import CONTINUOUS_KEYS, FIT_RANGES
from .cells import wrap_window

INPUT_CELLS = 4  # cells per side of the network's input window
CELL_PX = 16  # pixels per cell in that window
INPUT_PX = INPUT_CELLS * CELL_PX
COLOUR_KEYS = frozenset(k for k in CONTINUOUS_KEYS
                        if k.endswith(("reflection", "transmission", "transmission_exit", "subsurface")))
#: what the network predicts, in order: every continuous parameter, then plies and fibres
OUTPUT_KEYS: tuple[str, ...] = CONTINUOUS_KEYS + ("plies", "fibers")
INTEGER_KEYS = frozenset({"plies", "fibers"})
WEIGHTS_FILE = "initializer.pt"
RECORD_FILE = "initializer.json"


def key_width(key: str) -> int:
    """Number of outputs of a dotted key: 3 for a colour, 1 otherwise."""
    return 3 if key in COLOUR_KEYS else 1


def output_slices() -> dict[str, slice]:
    """Where each key of :data:`OUTPUT_KEYS` sits in the network's output vector."""
    out, start = {}, 0
    for key in OUTPUT_KEYS:
        out[key] = slice(start, start + key_width(key))
        start += key_width(key)
    return out


N_OUTPUTS = sum(key_width(k) for k in OUTPUT_KEYS)


def range_arrays() -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi), each (N_OUTPUTS,) float32: Table 1's range of every output."""
    lo = np.concatenate([[FIT_RANGES[k][0]] * key_width(k) for k in OUTPUT_KEYS]).astype(np.float32)
    hi = np.concatenate([[FIT_RANGES[k][1]] * key_width(k) for k in OUTPUT_KEYS]).astype(np.float32)
    return lo, hi


def to_vector(values: dict) -> np.ndarray:
    """A dict of dotted key → value (float or RGB) as the (N_OUTPUTS,) float32 output layout."""
    return np.concatenate([np.atleast_1d(np.asarray(values[k], dtype=np.float32)) for k in OUTPUT_KEYS])


def from_vector(vector: np.ndarray) -> dict:
    """The output layout back to dotted key → float / RGB tuple / int (plies, fibres rounded)."""
    out = {}
    for key, sl in output_slices().items():
        v = np.asarray(vector[sl], dtype=np.float64)
        if key in INTEGER_KEYS:
            lo, hi = FIT_RANGES[key]
            out[key] = int(np.clip(np.rint(v[0]), lo, hi))
        elif v.size == 3:
            out[key] = tuple(float(x) for x in v)
        else:
            out[key] = float(v[0])
    return out


def default_values() -> dict:
    """The middle of every Table 1 range (§7.3's default initialization), as :func:`from_vector`."""
    lo, hi = range_arrays()
    return from_vector(0.5 * (lo + hi))


def network_input(window: np.ndarray, pattern_window: np.ndarray) -> np.ndarray:
    """The network's (4, INPUT_PX, INPUT_PX) float32 input.

    Parameters
    ----------
    window : (INPUT_PX, INPUT_PX, 3) linear RGB, ``INPUT_CELLS``² cells of ``CELL_PX``.
    pattern_window : (INPUT_CELLS, INPUT_CELLS) 0/1, the pattern under those cells.
    """
    rgb = np.sqrt(np.clip(np.asarray(window, dtype=np.float32), 0.0, 4.0)).transpose(2, 0, 1)
    pat = np.kron(np.asarray(pattern_window, dtype=np.float32), np.ones((CELL_PX, CELL_PX), np.float32)) - 0.5
    return np.concatenate([rgb, pat[None]], axis=0)


def input_windows(canvas: np.ndarray, pattern: np.ndarray, *, max_windows: int = 4) -> np.ndarray:
    """Network inputs for up to ``max_windows`` cyclic offsets of a repeat (test-time averaging).

    Parameters
    ----------
    canvas : (n_e * CELL_PX, n_a * CELL_PX, 3) the repeat's cell canvas (:func:`cells.cell_canvas`).
    pattern : (n_e, n_a) 0/1.

    Returns
    -------
    (K, 4, INPUT_PX, INPUT_PX) float32.
    """
    pattern = np.asarray(pattern, dtype=np.uint8)
    n_e, n_a = pattern.shape
    offsets = [(i, j) for i in range(n_e) for j in range(n_a)]
    step = max(1, len(offsets) // max_windows)
    out = []
    for i, j in offsets[::step][:max_windows]:
        rolled = np.roll(canvas, (-i * CELL_PX, -j * CELL_PX), axis=(0, 1))
        pat = np.roll(pattern, (-i, -j), axis=(0, 1))
        out.append(network_input(wrap_window(rolled, pattern.shape, INPUT_CELLS),
                                 wrap_window(pat, pattern.shape, INPUT_CELLS)))
    return np.stack(out)


@dataclass(frozen=True)
class NetConfig:
    """Architecture: channels of each VGG block, width of the two FC layers."""

    widths: tuple[int, ...] = (16, 32, 64, 96)
    hidden: int = 256

    def to_json(self) -> dict:
        return {"widths": list(self.widths), "hidden": self.hidden}


def build_network(config: NetConfig = NetConfig()):
    """The VGG-style initializer network (a ``torch.nn.Module``): (B, 4, 64, 64) → (B, N_OUTPUTS)
    values, each inside its Table 1 range."""
    import torch
    from torch import nn

    class Initializer(nn.Module):
        def __init__(self):
            super().__init__()
            layers, ch = [], 4
            for w in config.widths:
                layers += [nn.Conv2d(ch, w, 3, padding=1), nn.BatchNorm2d(w), nn.ReLU(inplace=True),
                           nn.Conv2d(w, w, 3, padding=1), nn.BatchNorm2d(w), nn.ReLU(inplace=True),
                           nn.MaxPool2d(2)]
                ch = w
            self.features = nn.Sequential(*layers)
            side = INPUT_PX >> len(config.widths)
            self.head = nn.Sequential(
                nn.Flatten(), nn.Linear(ch * side * side, config.hidden), nn.LeakyReLU(0.1),
                nn.Linear(config.hidden, config.hidden), nn.LeakyReLU(0.1), nn.Linear(config.hidden, N_OUTPUTS))
            lo, hi = range_arrays()
            self.register_buffer("lo", torch.from_numpy(lo))
            self.register_buffer("span", torch.from_numpy(hi - lo))

        def unit(self, x):
            """Outputs as fractions of their ranges, in (0, 1) (the training target's units)."""
            return torch.sigmoid(self.head(self.features(x)))

        def forward(self, x):
            return self.lo + self.span * self.unit(x)

    return Initializer()


def weights_dir() -> Path:
    """The folder of the shipped weights (``weavecap/estimate/weights``)."""
    return Path(str(resources.files("weavecap.estimate").joinpath("weights")))


@dataclass
class Predictor:
    """A loaded initializer: ``predict`` maps a repeat's canvas and pattern to parameter values."""

    net: object
    record: dict

    def predict(self, canvas: np.ndarray, pattern: np.ndarray) -> dict:
        """Parameter values (dotted key → float, RGB tuple or int) for one repeat, averaged over
        cyclic offsets. ``canvas``: (n_e * CELL_PX, n_a * CELL_PX, 3) linear RGB.

        Runs on one thread: the work is a few ms, and on a busy 2-core machine a second
        OpenMP thread made one window take 290 ms instead of 2.4 ms (measured)."""
        import torch

        x = torch.from_numpy(input_windows(canvas, pattern))
        threads = torch.get_num_threads()
        torch.set_num_threads(1)
        try:
            with torch.inference_mode():
                y = self.net(x).mean(dim=0).numpy()
        finally:
            torch.set_num_threads(threads)
        return from_vector(y)


def load_predictor(folder: str | Path | None = None) -> Predictor | None:
    """Load the weights (``torch.load(weights_only=True)``: no pickle) and their record from
    ``folder`` (default: the shipped ones); None when there are none or they do not fit."""
    import torch

    folder = Path(folder) if folder is not None else weights_dir()
    wpath, rpath = folder / WEIGHTS_FILE, folder / RECORD_FILE
    if not (wpath.is_file() and rpath.is_file()):
        return None
    record = json.loads(rpath.read_text())
    if list(record.get("outputs", [])) != list(OUTPUT_KEYS):
        return None
    cfg = record["network"]
    net = build_network(NetConfig(widths=tuple(cfg["widths"]), hidden=int(cfg["hidden"])))
    net.load_state_dict(torch.load(wpath, map_location="cpu", weights_only=True))
    net.eval()
    return Predictor(net=net, record=record)
