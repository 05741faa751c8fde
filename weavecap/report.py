"""report.json of a capture (``weavecap.report/1``, ``schemas/report.schema.json``), assembled
in one place from the results of the stages (:mod:`weavecap.stages`).

Every report holds every part the contract requires: a photo that stops early (rejected at
load or preparation, or failed in a batch) gets the parts it reached and neutral values for
the rest (:func:`neutral`).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from .fit.rigs import Searched
    from .stages import Captured, CaptureOptions, Decided, Loaded, Rejection

FORMAT = "weavecap.report/1"


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    """PSNR in dB of two linear images clipped to [0, 1] (peak 1)."""
    mse = float(np.mean((np.clip(a, 0, 1).astype(np.float64) - np.clip(b, 0, 1)) ** 2))
    return float(10 * np.log10(1.0 / max(mse, 1e-12)))


def neutral(photo_path: str | Path, options: CaptureOptions) -> dict:
    """A report holding every part the contract requires, with neutral values, and the options."""
    return {"format": FORMAT, "input": {"path": str(photo_path), "sha256": "", "width": 0, "height": 0},
            "status": "failed", "rectification": {"rotation_deg": 0.0, "homography": np.eye(3).tolist()},
            "grid": {"repeat_px": [0, 0], "pitch_px": [0, 0], "yarns": [0, 0]},
            "fit": {"psnr_db": 0.0, "iterations": 0}, "timings_s": {"total": 0.0},
            "options": {"quality": options.quality, "light": options.light, "seed": options.seed,
                        "budget_s": options.budget_s, "network": options.use_network,
                        "exposure": options.exposure}}


def _seconds(timings: dict) -> dict:
    return {k: round(v, 3) if isinstance(v, float) else {n: round(s, 3) for n, s in v.items()}
            for k, v in timings.items()}


def failed(photo_path: str | Path, options: CaptureOptions, *, status: str, reason: str, seconds: float,
           sha256: str = "") -> dict:
    """The report of a photo a batch could not capture (``status``: failed, timeout, …)."""
    report = neutral(photo_path, options)
    report["input"]["sha256"] = sha256
    report.update(status=status, reason=reason, timings_s={"total": round(seconds, 3)})
    return report


def rejected(photo_path: str | Path, options: CaptureOptions, rejection: Rejection, timings: dict,
             loaded: Loaded | None = None) -> dict:
    """The report of a rejected photo: what load knew of it, preparation's checks, the reason."""
    report = neutral(photo_path, options)
    report["input"].update(loaded.input if loaded is not None else rejection.input)
    if rejection.checks is not None:
        report["checks"] = rejection.checks
    report.update(status="rejected", reason=rejection.reason, code=rejection.code, timings_s=_seconds(timings))
    return report


def finished(photo_path: str | Path, options: CaptureOptions, *, loaded: Loaded, decided: Decided,
             searched: Searched, timings: dict) -> dict:
    """The report of a capture: the kept capture of ``searched`` (each a
    :class:`weavecap.stages.Captured`), the rig search's note when it made several, and
    ``timings`` (seconds per stage, ``captures``: each capture's when several, ``total``)."""
    from .estimate.weave_name import weave_name
    from .fit import modelled
    from .fit.uncertainty import DETERMINED_SE

    kept: Captured = searched.kept
    start, planned, fitted, done = kept.start, kept.plan, kept.fitted, kept.finished
    result, config = fitted.result, options.config
    report = neutral(photo_path, options)
    report["input"].update(loaded.input)
    report["status"] = "ok"
    prepared = decided.prepared
    prep = prepared.to_json()
    report["rectification"], report["grid"] = prep["rectification"], prep["grid"]
    if decided.repeat_decided:
        report["grid"]["repeat_decided"] = True
    if options.pattern is not None or options.start_from is not None:
        report["grid"].update(repeat_given=True, repeat_in_photo=prep["checks"]["repeat_in_photo"])
    report["fit"] = {
        "psnr_db": round(psnr(done.rendered, fitted.target), 3), "iterations": result.iterations,
        "pattern_confidence": round(done.confidence, 4), "mse": result.loss, "stopped": result.stopped,
        "seconds": round(result.seconds, 3), "cell_px": start.cell_px, "spp": config.spp, "moves": result.moves,
        "pattern_fixed": "pattern" in planned.fixed,
        "fidelity": {**done.fidelity.to_json(), "photo_scale": done.at_scale.figures.to_json()},
        "parameters": {key: {"standard_error": round(se, 4) if np.isfinite(se) else None,
                             "determined": bool(se <= DETERMINED_SE)} for key, se in done.errors.items()},
        "light": modelled.light_json(fitted.rig, result.moves, exposure=start.exposure),
    }
    report["timings_s"] = _seconds(timings)
    report["pre_estimation"] = {**start.notes, **fitted.notes}
    report["weave"] = weave_name(done.fabric.pattern)
    report["modelled"] = modelled.describe(planned, result, done.errors, light=start.light,
                                           light_reason=searched.note or start.light_reason, spp=config.spp,
                                           blur_px=fitted.blur_px, noise=done.noise, pitch_px=prepared.grid.pitch_px,
                                           plies_flat=config.plies_flat)
    report["threads"] = done.at_scale.threads
    return report
