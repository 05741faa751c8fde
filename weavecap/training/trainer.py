"""The skeleton every network of weavecap is trained on: data in shards, a loop that
checkpoints and resumes, and weights written with the record of how they were made.

- **Shards** (:func:`make_shards`): the training data as ``.npz`` files of plain arrays, each
  written atomically with the seconds it took to make (``seconds``). A shard that exists is not
  made again, so an interrupted run resumes where it stopped, and the sum of the shards'
  seconds is what the data cost, earlier runs included. Make shard ``k`` from its own random
  generator (e.g. ``numpy.random.default_rng([seed, k])``) and the same seed gives the same
  data whatever was interrupted.
- **Checkpoints** (:class:`Trainer`): ``torch.save`` of tensors and plain values only — the
  state dicts of the model, optimizer and learning-rate schedule, the epochs or steps done, the
  seconds spent and the training settings as JSON — read back with ``weights_only=True``. A
  checkpoint made with other settings is set aside: training starts over on the same data.
- **The loop**: :meth:`Trainer.epochs` (batches of a permutation drawn from a generator seeded
  with (seed, epoch), a checkpoint after every epoch) or :meth:`Trainer.steps` (the caller draws
  step ``k``'s batch from a generator of its own seeded with (seed, k); a checkpoint every
  ``every`` steps and at the end). Either way a resumed run goes on as if it had not stopped.
- **Weights** (:func:`write_weights`): the network's arrays and, beside them, the record (JSON:
  the settings, the data, the times, the held-out errors), both written atomically.

Used by :mod:`weavecap.training.initializer` (Wu et al. 2025 §5.3).
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from ..io import atomic_path, atomic_write_text

Progress = Callable[[str], None]
CHECKPOINT = "checkpoint.pt"


def shard_path(folder: Path, index: int) -> Path:
    """``folder/shard_{index:04d}.npz``: where shard ``index`` of a numbered set lives."""
    return Path(folder) / f"shard_{index:04d}.npz"


def write_shard(path: Path, arrays: dict) -> None:
    """Write ``arrays`` (name → numpy array) to ``path`` as an ``.npz``, atomically."""
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        np.savez(fh, **arrays)


def shard_seconds(path: Path) -> float:
    """The seconds shard ``path`` took to make (its ``seconds`` array)."""
    with np.load(path) as z:
        return float(z["seconds"])


def make_shards(paths: Sequence[Path], make: Callable[[int], dict], *, progress: Progress = lambda s: None,
                describe: Callable[[dict], str] = lambda arrays: "") -> float:
    """Make every shard of ``paths`` that is missing (``make(k)`` returns shard ``k``'s arrays)
    and return the seconds all of them took to make, those of earlier runs included.

    Each new shard is reported as ``data: shard k/n (describe(arrays), seconds)``.
    """
    spent = 0.0
    for index, path in enumerate(paths):
        if not Path(path).is_file():
            t0 = time.perf_counter()
            arrays = make(index)
            seconds = time.perf_counter() - t0
            write_shard(path, arrays | {"seconds": np.float64(seconds)})
            what = describe(arrays)
            progress(f"data: shard {index + 1}/{len(paths)} ({what + ', ' if what else ''}{seconds:.0f} s)")
        spent += shard_seconds(path)
    return spent


def concatenate_shards(paths: Sequence[Path], keys: Sequence[str]) -> dict:
    """The arrays ``keys`` of the shards ``paths``, concatenated along their first axis."""
    parts = []
    for path in paths:
        with np.load(path) as z:
            parts.append({k: z[k] for k in keys})
    return {k: np.concatenate([p[k] for p in parts]) for k in keys}


class Trainer:
    """A model, its optimizer and (optionally) its learning-rate schedule, trained in ``folder``
    and resumed from ``folder/checkpoint.pt`` when that was made with the same ``settings``.

    ``done`` counts the epochs (:meth:`epochs`) or steps (:meth:`steps`) finished, ``seconds``
    the time spent in them (over every run; evaluation between epochs is not counted).
    """

    def __init__(self, folder: Path, settings: dict, model, optimizer, scheduler=None, *,
                 progress: Progress = lambda s: None):
        self.folder = Path(folder)
        self.folder.mkdir(parents=True, exist_ok=True)
        self.path = self.folder / CHECKPOINT
        self.settings = json.loads(json.dumps(settings))  # as JSON reads it back (tuples become lists)
        self.parts = {"model": model, "optimizer": optimizer}
        if scheduler is not None:
            self.parts["scheduler"] = scheduler
        self.model, self.optimizer, self.scheduler = model, optimizer, scheduler
        self.progress = progress
        self.done, self.seconds = self._resume()

    def _resume(self) -> tuple[int, float]:
        import torch

        if not self.path.is_file():
            return 0, 0.0
        state = torch.load(self.path, map_location="cpu", weights_only=True)
        if not isinstance(state, dict) or "settings" not in state or not set(self.parts) <= set(state) \
                or json.loads(state["settings"]) != self.settings:
            self.progress(f"train: {self.path} is of other training settings; starting over")
            return 0, 0.0
        for name, part in self.parts.items():
            part.load_state_dict(state[name])
        self.progress(f"train: resuming after {int(state['done'])} done ({float(state['seconds']):.0f} s)")
        return int(state["done"]), float(state["seconds"])

    def save(self) -> None:
        """Write the checkpoint (atomically)."""
        import torch

        state = {name: part.state_dict() for name, part in self.parts.items()}
        state |= {"done": self.done, "seconds": self.seconds, "settings": json.dumps(self.settings)}
        with atomic_path(self.path) as tmp:
            torch.save(state, tmp)

    def update(self, loss) -> float:
        """One optimizer step on ``loss`` (a scalar tensor) and one step of the schedule; the
        loss's value."""
        self.optimizer.zero_grad()
        loss.backward()
        self.optimizer.step()
        if self.scheduler is not None:
            self.scheduler.step()
        return float(loss.item())

    def epochs(self, count: int, examples: int, batch: int, seed: int, loss: Callable[[object], object], *,
               after: Callable[[int, float], None] | None = None) -> None:
        """Train until ``count`` epochs are done. An epoch visits the ``examples`` examples once,
        in batches of ``batch`` indices (a LongTensor) of a permutation drawn from a generator
        seeded with ``seed * 1000 + epoch``; ``loss(indices)`` returns the batch's loss (a scalar
        tensor, the mean over the batch). After each epoch: a checkpoint, then
        ``after(epochs done, mean loss over the epoch)``."""
        import torch

        self.model.train()
        for epoch in range(self.done, count):
            t0 = time.perf_counter()
            order = torch.randperm(examples, generator=torch.Generator().manual_seed(seed * 1000 + epoch))
            total = 0.0
            for start in range(0, examples, batch):
                idx = order[start:start + batch]
                total += self.update(loss(idx)) * len(idx)
            self.seconds += time.perf_counter() - t0
            self.done = epoch + 1
            self.save()
            if after is not None:
                after(self.done, total / examples)
                self.model.train()

    def steps(self, count: int, loss: Callable[[int], object], *, every: int,
              after: Callable[[int, float], None] | None = None) -> None:
        """Train until ``count`` steps are done: ``loss(k)`` returns step ``k``'s loss (it draws
        its own batch, from a generator seeded with (seed, k) for a run that resumes exactly);
        ``after(steps done, loss)`` after each step; a checkpoint every ``every`` steps and at
        the end."""
        self.model.train()
        while self.done < count:
            t0 = time.perf_counter()
            value = self.update(loss(self.done))
            self.seconds += time.perf_counter() - t0
            self.done += 1
            if after is not None:
                after(self.done, value)
            if self.done % every == 0 or self.done == count:
                self.save()


def write_weights(path: Path, model, record: dict) -> Path:
    """Write ``model``'s weights to ``path`` and ``record`` (how they were made) beside them as
    ``path`` with ``.json``; return the record's path. ``.pt``: the torch state dict (tensors
    only, for ``torch.load(..., weights_only=True)``); ``.npz``: every tensor as a float32 array
    (no pickle, readable without torch)."""
    import torch

    path = Path(path)
    state = model.state_dict()
    with atomic_path(path) as tmp:
        if path.suffix == ".pt":
            torch.save(state, tmp)
        elif path.suffix == ".npz":
            with open(tmp, "wb") as fh:
                np.savez_compressed(fh, **{k: v.detach().cpu().numpy().astype(np.float32) for k, v in state.items()})
        else:
            raise ValueError(f"{path}: weights are written as .pt or .npz")
    record_path = path.with_suffix(".json")
    atomic_write_text(record_path, json.dumps(record, indent=1) + "\n")
    return record_path
