"""The capture of ``weavecap fit`` for one photo: the runner that orders its stages
(Wu et al. 2025 §4–6; the stages and their typed results: :mod:`weavecap.stages`).

load → prepare (§4) → cells, once per photo; then pre-estimate (§5) → plan → fit (§6.1–6.2) →
finish (§6.3 and the figures) under each light rig the rig search asks for
(:func:`weavecap.fit.rigs.search`: one capture, or several from the same preparation, one
kept); report.json assembled once from the results (:mod:`weavecap.report`). Each stage is
timed. A photo that is not a resolvable woven fabric ends as a :class:`Capture` with status
``rejected`` and a reason, not as an exception. :func:`write_capture` writes the outputs
atomically, ``report.json`` last (its presence marks a finished photo).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from . import params as wparams
from . import report as reports
from . import stages
from .stages import CaptureOptions

#: the capture's stage messages (``photo: preparing …``), one a stage: ``weavecap fit`` shows
#: them as progress (:meth:`cli.report.Reporter.stages`); a ``--jobs`` or Dask worker's go nowhere
PROGRESS = logging.getLogger("weavecap.progress")
OUTPUT_FILES = ("params.json", "report.json", "compare.png", "rectified.png", "grid.png", "loss.png", "diagnosis.png")


@dataclass
class Capture:
    """The result of :func:`capture` for one photo: the report, and what to write."""

    report: dict
    fabric: wparams.Fabric | None = None
    images: dict = field(default_factory=dict)  # output name → (H, W, 3) linear RGB
    history: list = field(default_factory=list)

    @property
    def status(self) -> str:
        return self.report["status"]


@dataclass(frozen=True)
class FitJob:
    """``weavecap fit``'s work on one photo, as a :class:`weavecap.batch.Job`: capture it and
    write its outputs (:func:`write_capture`)."""

    options: CaptureOptions = CaptureOptions()
    key = "photo"
    outputs = OUTPUT_FILES
    record = "report.json"

    def run(self, source: str, folder: str) -> dict:
        cap = capture(source, self.options, progress=lambda message: PROGRESS.info("%s: %s", source, message))
        write_capture(cap, Path(folder))
        return cap.report

    def failure_record(self, source: str, status: str, reason: str, seconds: float) -> dict:
        from .photo import file_sha256

        try:  # identify the photo, so that a resumed batch knows this failure is its own
            sha256 = file_sha256(source)
        except OSError:
            sha256 = ""
        return reports.failed(source, self.options, status=status, reason=reason, seconds=seconds, sha256=sha256)

    def summary(self, record: dict) -> dict:
        fit = record.get("fit", {})
        fidelity = fit.get("fidelity", {})
        return {"weave": record.get("weave"), "psnr_db": fit.get("psnr_db"),
                "pattern_confidence": fit.get("pattern_confidence"), "yarns": record["grid"]["yarns"],
                "light": fit.get("light", {}).get("rig"), "sharpness": fidelity.get("sharpness"),
                "delta_e": fidelity.get("delta_e"), "clipped": fidelity.get("clipped"),
                "photo_scale": fidelity.get("photo_scale"), "neutral_delta_e": fidelity.get("neutral_delta_e")}


class _Clock:
    """Seconds per stage: ``clock(name, fn, *args)`` runs a stage and adds its time to ``name``."""

    def __init__(self):
        self.seconds: dict[str, float] = {}
        self.t0 = time.perf_counter()

    def __call__(self, name: str, fn, *args):
        t = time.perf_counter()
        out = fn(*args)
        self.seconds[name] = self.seconds.get(name, 0.0) + time.perf_counter() - t
        return out

    def total(self) -> float:
        return time.perf_counter() - self.t0


def capture(photo_path: str | Path, options: CaptureOptions = CaptureOptions(), *,
            progress: Callable[[str], None] | None = None) -> Capture:
    """Run the whole pipeline on one photo. Bad photos give status ``rejected``, not errors.

    The photo is loaded, prepared and divided into its repeat's cells once; the captures under
    the light rigs ``options.light`` asks for (:func:`weavecap.fit.rigs.search`) all start from
    that preparation."""
    say = progress or (lambda _msg: None)
    clock = _Clock()
    say("loading")
    loaded = clock("load", stages.load, photo_path)
    if isinstance(loaded, stages.Rejection):
        return Capture(report=reports.rejected(photo_path, options, loaded, {**clock.seconds, "total": clock.total()}))
    say("preparing (rectify, regularize, repeat, grid)")
    prepared = clock("prepare", stages.prepare, loaded, options)
    if isinstance(prepared, stages.Rejection):
        return Capture(report=reports.rejected(photo_path, options, prepared, {**clock.seconds, "total": clock.total()},
                                               loaded=loaded), images={"diagnosis.png": prepared.diagnosis})
    grid = clock("cells", stages.cells, prepared)
    if options.pattern is None and options.start_from is None:
        say("deciding the pattern from the photo's cells")
    decided = clock("decide", stages.decide, loaded, prepared, grid, options)
    prepared, grid = decided.prepared, decided.grid

    def under(light: str) -> stages.Captured:
        """One capture under ``light`` from the one preparation."""
        rig = _Clock()
        say(f"pre-estimating a {grid.shape[0]}x{grid.shape[1]} repeat (pattern, colours, parameters)")
        start = rig("pre_estimate", stages.pre_estimate, decided, options, light)
        planned = rig("plan", stages.plan, start, decided, options)
        say(f"fitting ({options.quality}: up to {options.config.iterations} steps"
            + (f", {options.budget_s:g} s budget" if options.budget_s else "") + ")")
        fitted = rig("fit", stages.fit, start, decided, planned, options)
        say("measuring how well the photo determines each parameter")
        done = rig("finish", stages.finish, start, planned, fitted, options)
        return stages.Captured(start=start, plan=planned, fitted=fitted, finished=done, seconds=rig.seconds)

    from .fit.rigs import search

    searched = search(options.request, under, stages.Captured.weighed, say=say)
    released = stages.decision_holds(decided, searched.kept)
    if released:  # ``under`` reads ``decided`` when called: the captures start from the decision
        say(f"the decided pattern {released}")
        decided = decided.release(released)
        searched = search(options.request, under, stages.Captured.weighed, say=say)
    kept: stages.Captured = searched.kept
    timings = {**clock.seconds, **kept.seconds}
    if len(searched.captures) > 1:
        timings["captures"] = {light: sum(cap.seconds.values()) for light, cap in searched.captures.items()}
    timings["total"] = clock.total()
    report = reports.finished(photo_path, options, loaded=loaded, decided=decided, searched=searched,
                              timings=timings)
    return Capture(report=report, fabric=kept.finished.fabric, images=_images(prepared, kept),
                   history=kept.fitted.result.history)


def _images(prepared, kept: stages.Captured) -> dict:
    """The pictures of a capture (linear RGB): compare.png (the photo and the fit at the photo's
    scale, and their repeats, :meth:`weavecap.fit.compare.PhotoScale.compare`), as shot; the
    rectified photo; its yarn grid."""
    done = kept.finished
    compare = done.at_scale.compare(kept.fitted.target, done.rendered, [done.fidelity.caption()],
                                    exposure=kept.start.exposure or 1.0)
    return {"compare.png": compare,
            "rectified.png": prepared.rectification.image, "grid.png": prepared.grid_overlay()}


def loss_plot(history: list[float], *, size: tuple[int, int] = (240, 400)) -> np.ndarray:
    """A plot of log10(MSE) per step (for loss.png), linear RGB, drawn with OpenCV."""
    import cv2

    h, w = size
    img = np.full((h, w, 3), 255, np.uint8)
    m = 30
    cv2.rectangle(img, (m, 10), (w - 10, h - m), (0, 0, 0), 1)
    if len(history) >= 2:
        y = np.log10(np.maximum(np.asarray(history, dtype=np.float64), 1e-12))
        lo, hi = float(y.min()), float(y.max())
        span = hi - lo if hi > lo else 1.0
        xs = m + (np.arange(y.size) / (y.size - 1)) * (w - 10 - m)
        ys = (h - m) - (y - lo) / span * (h - m - 10)
        cv2.polylines(img, [np.stack([xs, ys], 1).astype(np.int32)], False, (200, 60, 20), 2, cv2.LINE_AA)
        cv2.putText(img, f"{10 ** hi:.2e}", (m + 4, 24), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (0, 0, 0), 1, cv2.LINE_AA)
        cv2.putText(img, f"{10 ** lo:.2e}", (m + 4, h - m - 6), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (0, 0, 0), 1, cv2.LINE_AA)
    cv2.putText(img, "MSE per step (log)", (m, h - 8), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 0), 1, cv2.LINE_AA)
    from .photo import srgb_to_linear

    return srgb_to_linear(img.astype(np.float32) / 255.0)


def _enlarged(image: np.ndarray, min_height: int = 256) -> np.ndarray:
    k = max(1, int(np.ceil(min_height / max(1, image.shape[0]))))
    return np.repeat(np.repeat(image, k, axis=0), k, axis=1) if k > 1 else image


def write_capture(cap: Capture, out_dir: Path) -> None:
    """Write a capture's outputs into ``out_dir`` as one result set, report.json last
    (:func:`weavecap.io.write_result_set`). A rejected photo gets report.json and, where
    preparation refused it, diagnosis.png; an earlier run's other outputs are removed."""
    from .io import atomic_write_text, dumps_json, write_result_set
    from .photo import save_png

    files = {}
    if cap.fabric is None and cap.images.get("diagnosis.png") is not None:  # what the grid search saw
        files["diagnosis.png"] = lambda path: save_png(path, cap.images["diagnosis.png"])
    if cap.fabric is not None:  # texture paths relative to where params.json ends up, not the staging
        files["params.json"] = lambda path: atomic_write_text(path, wparams.dumps(cap.fabric, base=out_dir.resolve()))
        for name, image in cap.images.items():
            if name == "compare.png":
                image = _enlarged(image)
            files[name] = lambda path, image=image: save_png(path, image)
        files["loss.png"] = lambda path: save_png(path, loss_plot(cap.history))
    write_result_set(out_dir, files, record=("report.json", dumps_json(cap.report, indent=1) + "\n"),
                     outputs=OUTPUT_FILES)
