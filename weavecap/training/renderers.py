"""Training the output renderers' networks (``weavecap train-renderer``): each one's data, its
training and its held-out errors, then the weights with their record.

- the woven neural renderer (Chen et al. 2024): footprint-filtered BSDF data of random fabrics
  and its network (:mod:`.woven`);
- the fold renderer (Son et al.): LocalPT on the procedural fold suite and the BLIDF
  (:mod:`.fold`).

Each keeps its data and checkpoints in its own folder of the work folder (``WORK/woven``,
``WORK/fold``), claimed for its settings (:func:`weavecap.training.work.claim_work_folder`),
so an interrupted run resumes from what is there.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from ..io import refuse_overwrite
from .work import claim_work_folder

Progress = Callable[[str], None]


@dataclass(frozen=True)
class WovenPlan:
    """The woven renderer's data and training: random ``fabrics`` (both sides each, every 16th
    held out) and training ``steps`` (4 materials x 1024 queries each)."""

    fabrics: int = 320
    steps: int = 8000


@dataclass(frozen=True)
class FoldPlan:
    """The fold renderer's data and training: directional ``lights`` per mesh of the fold suite
    (the last block of 8 held out), vertices (both sides) ``per_light``, training ``epochs``."""

    lights: int = 48
    per_light: int = 300
    epochs: int = 160


def _woven_targets(out_dir: Path | None) -> list[Path]:
    """The woven renderer's weights and their record."""
    from ..render.woven.infer import WEIGHTS, weights_path

    out = (out_dir / WEIGHTS) if out_dir is not None else weights_path()
    return [out, out.with_suffix(".json")]


def _woven(work: Path, out: Path, fabrics: int, steps: int, seed: int, say: Progress, progress: Progress) -> None:
    """The woven neural renderer's part (Chen et al. 2024): data, training, held-out errors."""
    from dataclasses import asdict

    from . import woven as woven_train

    data_config = woven_train.DataConfig(fabrics=fabrics, seed=seed)
    train_config = woven_train.TrainConfig(steps=steps, seed=seed)
    folder = work / "woven"
    claim_work_folder(folder, {"data": asdict(data_config), "train": asdict(train_config)}, name="plan.json")
    say(f"woven: data for {fabrics} fabrics ({data_config.shards} shards) in {folder / 'data'}")
    # the time spent making the data, over every run that made some of it (each shard keeps its own)
    data_seconds = woven_train.generate(folder / "data", data_config, progress=lambda m: progress(f"woven: {m}"))
    dataset = woven_train.Dataset(folder / "data", data_config)
    say(f"woven: training {steps} steps on {len(dataset.inputs)} queries of {len(dataset.train_materials)} "
        f"materials ({len(dataset.held_materials)} held out)")
    model, train_summary = woven_train.train(dataset, folder / "train", train_config,
                                             log=lambda m: progress(f"woven: {m}"))
    held = woven_train.evaluate(model, dataset, dataset.held_materials)
    seen = woven_train.evaluate(model, dataset, dataset.train_materials[:len(dataset.held_materials)])
    baseline = woven_train.evaluate(None, dataset, dataset.held_materials, baseline_only=True)
    record = woven_train.record(data_config, train_config, data_seconds=data_seconds, train_summary=train_summary,
                                held_out=held, seen=seen, dataset=dataset)
    record["held_out_errors_prefilter_only"] = baseline
    woven_train.export(model, out, record)
    say(f"woven: wrote {out} ({out.stat().st_size / 1e6:.2f} MB) and its record; held-out RGB error: relative MSE "
        f"{held['all']['rel_mse']:.4f}, relative MAE {held['all']['rel_mae']:.3f} "
        f"(data {data_seconds:.0f} s, training {train_summary['seconds']:.0f} s)")


def _fold_targets(out_dir: Path | None) -> list[Path]:
    """The fold renderer's weights (their record inside)."""
    from ..render.fold import blidf

    return [(out_dir / blidf.WEIGHTS_FILE) if out_dir is not None else blidf.weights_path()]


def _fold(work: Path, out: Path, lights: int, per_light: int, epochs: int, seed: int, say: Progress,
          progress: Progress) -> None:
    """The fold renderer's part (Son et al.): LocalPT data on the fold suite, the BLIDF, held-out errors."""
    from . import fold as training

    # blocks of 8 lights (at most half of them, so that one block is held out and one trained on)
    config = training.TrainConfig(seed=seed, lights=lights, per_light=per_light, epochs=epochs,
                                  block=min(8, lights // 2))
    folder = work / "fold"
    claim_work_folder(folder, config.data_settings())
    meshes = training.fold_suite()
    say(f"fold: LocalPT data of {len(meshes)} meshes x {lights} lights x {per_light} vertices in {folder / 'data'}")
    data_seconds = training.generate_data(folder, meshes, config, progress=lambda m: progress(f"fold: {m}"))
    net, train_seconds, errors = training.train(folder, meshes, config, progress=lambda m: progress(f"fold: {m}"))
    training.write_weights(out, net, meshes, config, data_seconds=data_seconds, train_seconds=train_seconds,
                           errors=errors, radii=training.mesh_radii(folder, meshes, config))
    say(f"fold: wrote {out}; held-out RMSE {errors['heldout']['rmse']:.6f}, without the fold term "
        f"{errors['heldout']['rmse_without']:.6f} (data {data_seconds:.0f} s, training {train_seconds:.0f} s)")


def train_renderers(work: Path, out_dir: Path | None, *, woven: WovenPlan | None = None, fold: FoldPlan | None = None,
                    seed: int = 0, force: bool = False, say: Progress = lambda m: None,
                    progress: Progress = lambda m: None) -> list[Path]:
    """Make the data of the renderers planned (``woven``, ``fold``: None leaves one out), train
    their networks and write the weights and records into ``out_dir`` (None: the package's
    weights folders); the same ``seed`` gives the same data and weights. ``say`` is told what
    each part did, ``progress`` how its steps go. Returns the files written.

    Raises
    ------
    InputError
        A weights file exists and ``force`` is not given (checked before any work), or a work
        folder holds data made with other settings.
    """
    woven_out = _woven_targets(out_dir) if woven else []
    fold_out = _fold_targets(out_dir) if fold else []
    for path in woven_out + fold_out:  # before any work: nothing is overwritten without --force
        refuse_overwrite(path, force=force)
    if woven:
        _woven(Path(work), woven_out[0], woven.fabrics, woven.steps, seed, say, progress)
    if fold:
        _fold(Path(work), fold_out[0], fold.lights, fold.per_light, fold.epochs, seed, say, progress)
    return woven_out + fold_out
