"""The capture pipeline of ``weavecap fit`` for one photo (DESIGN.md; Wu et al. 2025 §4–6).

load → prepare (§4: rectify, regularize, period, grid) → pre-estimate (§5: pattern, colours,
initializer) → joint fit (§6.1–6.2) → noise (§6.3) → outputs. Each stage is timed; a photo
that is not a resolvable woven fabric ends as a :class:`Capture` with status ``rejected`` and a
reason, not as an exception. :func:`write_capture` writes the outputs of DESIGN.md atomically,
``report.json`` last (its presence marks a finished photo).
"""

from __future__ import annotations

import dataclasses
import json
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from . import params as wparams
from .errors import PhotoError
from .fit.config import PRESETS, FitConfig, cell_px_for
from .fit.fidelity import captioned, faithful_figures, fidelity
from .fit.target import align_cells, repeat_cells, shifted

REPORT_FORMAT = "weavecap.report/1"
OUTPUT_FILES = ("params.json", "report.json", "compare.png", "rectified.png", "grid.png", "loss.png")


@dataclass(frozen=True)
class CaptureOptions:
    """What the user chose for a capture (``weavecap fit``'s options).

    Attributes
    ----------
    quality : preset name of :data:`weavecap.fit.config.PRESETS`
    light : the light rig the photo was taken under (§6.4), ``auto``: the rig that explains
        the photo best before the fit (:func:`weavecap.fit.rounds.choose_rig`: both or front),
        searched further when that capture is not faithful (:func:`capture`), or ``best``: whole
        captures under ``auto`` and the rigs of :data:`BEST_RIGS` it did not take, one kept
        (:func:`rig_search`)
    seed : seeds every random choice; the same seed gives the same result
    budget_s : wall-time limit of the joint fit, seconds (None: the preset's iterations)
    start_from : a fabric to start the fit from instead of the pre-estimate (warm start)
    pattern : a known pattern (fixed during the fit), or None
    use_network : False skips the initializer network (defaults, §7.3)
    exposure : ``rig``: colours against the light rig, the photo's gain solved by the fit from
        unit gain (:func:`weavecap.fit.joint.solve_colours`); ``photo``: the photo divided by
        its own exposure first (:func:`weavecap.estimate.preestimate.photo_exposure`), so the
        same fabric shot a stop darker or brighter gets the same colours, its brightest yarn
        at the rig's reach. Not the default: on the fit bench's own renders (taken at the
        rig's exposure) it cost the twill 2/1 10.7 dB (35.0 → 24.3: a fit started above the
        photo's true gain stays there) and the plain 3 dB
    """

    quality: str = "normal"
    light: str = "auto"
    seed: int = 0
    budget_s: float | None = None
    start_from: wparams.Fabric | None = None
    pattern: np.ndarray | None = None
    use_network: bool = True
    exposure: str = "rig"

    @property
    def config(self) -> FitConfig:
        return PRESETS[self.quality]


@dataclass
class Capture:
    """The result of :func:`capture` for one photo: the report, and what to write."""

    report: dict
    fabric: wparams.Fabric | None = None
    images: dict = field(default_factory=dict)  # output name → (H, W, 3) linear RGB
    history: list = field(default_factory=list)
    captions: dict = field(default_factory=dict)  # output name → a line of text under the picture

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
        cap = capture(source, self.options)
        write_capture(cap, Path(folder))
        return cap.report

    def failure_record(self, source: str, status: str, reason: str, seconds: float) -> dict:
        from .photo import file_sha256

        report = base_report(source, self.options)
        try:  # identify the photo, so that a resumed batch knows this failure is its own
            report["input"]["sha256"] = file_sha256(source)
        except OSError:
            pass
        report.update(status=status, reason=reason, timings_s={"total": round(seconds, 3)})
        return report

    def summary(self, record: dict) -> dict:
        fit = record.get("fit", {})
        fidelity = fit.get("fidelity", {})
        return {"weave": record.get("weave"), "psnr_db": fit.get("psnr_db"),
                "pattern_confidence": fit.get("pattern_confidence"), "yarns": record["grid"]["yarns"],
                "light": fit.get("light", {}).get("rig"), "sharpness": fidelity.get("sharpness"),
                "delta_e": fidelity.get("delta_e"), "clipped": fidelity.get("clipped")}


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    """PSNR in dB of two linear images clipped to [0, 1] (peak 1)."""
    mse = float(np.mean((np.clip(a, 0, 1).astype(np.float64) - np.clip(b, 0, 1)) ** 2))
    return float(10 * np.log10(1.0 / max(mse, 1e-12)))


def base_report(photo_path: str | Path, options: CaptureOptions) -> dict:
    """A report.json holding every part the contract requires, with neutral values: each stage
    overwrites its part as it finishes, so a photo that stops early still has a valid report."""
    return {"format": REPORT_FORMAT, "input": {"path": str(photo_path), "sha256": "", "width": 0, "height": 0},
            "status": "failed", "rectification": {"rotation_deg": 0.0, "homography": np.eye(3).tolist()},
            "grid": {"repeat_px": [0, 0], "pitch_px": [0, 0], "yarns": [0, 0]},
            "fit": {"psnr_db": 0.0, "iterations": 0}, "timings_s": {"total": 0.0},
            "options": {"quality": options.quality, "light": options.light, "seed": options.seed,
                        "budget_s": options.budget_s, "network": options.use_network,
                        "exposure": options.exposure}}


def _rejected(report: dict, reason: str, code: str, timings: dict, t0: float) -> Capture:
    timings["total"] = time.perf_counter() - t0
    report.update(status="rejected", reason=reason, code=code,
                  timings_s={k: round(v, 3) for k, v in timings.items()})
    return Capture(report=report)


#: the rigs a rig search (``--light best``, or ``auto``'s retry) captures the photo under
#: besides ``auto``'s (one whole capture each)
BEST_RIGS = ("both", "front", "lamp")


def capture(photo_path: str | Path, options: CaptureOptions = CaptureOptions(), *,
            progress: Callable[[str], None] | None = None) -> Capture:
    """Run the whole pipeline on one photo. Bad photos give status ``rejected``, not errors.

    ``--light best`` searches the rigs (:func:`rig_search`); ``--light auto`` does when its
    capture is not faithful to the photo and the preset retries (``FitConfig.rig_retry``)."""
    if options.light == "best":
        return rig_search(photo_path, options, progress=progress)
    cap = capture_under_rig(photo_path, options, progress=progress)
    retry = options.light == "auto" and options.config.rig_retry
    if retry and cap.status == "ok" and not faithful(cap.report, options.config):
        return rig_search(photo_path, options, first=cap, progress=progress)
    return cap


def faithful(report: dict, config: FitConfig) -> bool:
    """Whether a capture's render looks like its photo: at least ``config.faithful_sharpness``
    of its gradient energy and each family's colour within ``config.faithful_delta_e``
    (``report["fit"]["fidelity"]``; a family the pattern never shows is not judged)."""
    f = report["fit"]["fidelity"]
    return faithful_figures(f["sharpness"], f["delta_e"], min_sharpness=config.faithful_sharpness,
                            max_delta_e=config.faithful_delta_e)


def capture_under_rig(photo_path: str | Path, options: CaptureOptions, *,
                      progress: Callable[[str], None] | None = None) -> Capture:
    """One capture under one rig: ``options.light``, or under ``auto`` the rig chosen before the
    fit (:func:`weavecap.fit.rounds.choose_rig`)."""
    from .estimate.cells import cell_canvas
    from .estimate.decide import decide_on_photo
    from .estimate.preestimate import photo_exposure, pre_estimate
    from .estimate.weave_name import weave_name
    from .fit.confidence import pattern_confidence
    from .fit import modelled
    from .fit.rounds import choose_rig, fit_registered
    from .fit.uncertainty import DETERMINED_SE, standard_errors
    from .model.render import as_photographed, render_numpy, white_level
    from .model.scene import View, build_scene, light_rig
    from .noise import fit_noise
    from .photo import file_sha256, load_photo
    from .prepare import Rejected, prepare_photo

    say = progress or (lambda _msg: None)
    t0 = time.perf_counter()
    timings: dict[str, float] = {}
    report = base_report(photo_path, options)

    say("loading")
    t = time.perf_counter()
    try:
        photo = load_photo(photo_path)
    except PhotoError as exc:
        try:  # identify even an unreadable photo, so that a resumed batch knows it was done
            report["input"].update(sha256=file_sha256(photo_path), width=0, height=0)
        except OSError:
            pass
        return _rejected(report, str(exc), "unreadable", timings, t0)
    clipped = photo.clipped
    report["input"].update(sha256=photo.sha256, width=photo.width, height=photo.height, format=photo.source_format,
                           clipped=None if clipped is None else [round(v, 4) for v in clipped])
    timings["load"] = time.perf_counter() - t

    say("preparing (rectify, regularize, repeat, grid)")
    t = time.perf_counter()
    # a given pattern (or warm start) is the fabric's repeat: a photo shows the repeat's look,
    # which can be shorter (a grey 2/2 twill's complement looks alike) or, held once, hidden
    given = options.pattern if options.pattern is not None else options.start_from
    prepared = prepare_photo(photo.rgb, repeat=None if given is None else given.shape)
    timings["prepare"] = time.perf_counter() - t
    if isinstance(prepared, Rejected):
        report["checks"] = prepared.to_json()["checks"]
        return _rejected(report, prepared.reason, prepared.code, timings, t0)
    prep = prepared.to_json()
    report["rectification"], report["grid"] = prep["rectification"], prep["grid"]
    if given is not None:
        report["grid"].update(repeat_given=True, repeat_in_photo=prep["checks"]["repeat_in_photo"])
    cells = repeat_cells(prepared, prepared.regularized.box)
    cells = align_cells(prepared.regularized.image, cells)
    decision = None
    if given is None:  # the pattern from what the photo's cells show (docs/capture.md, the pattern decision)
        say("deciding the pattern from the photo's cells")
        t = time.perf_counter()
        again, cells, decision = decide_on_photo(photo.rgb, prepared, cells)
        if again is not prepared:  # prepared again at the decided repeat
            prepared, report["grid"] = again, again.to_json()["grid"] | {"repeat_decided": True}
        timings["decide"] = time.perf_counter() - t
    decided = (decision.pattern_at(shifted(cells, prepared.regularized.box))
               if decision is not None and decision.pattern.shape == cells.shape else None)
    known = options.pattern if options.pattern is not None else decided if decision and decision.decided else None
    shape = cells.shape

    config = options.config
    c = cell_px_for(config, shape)
    light, light_reason = ("both", "auto") if options.light == "auto" else (options.light, "given")
    # --exposure photo: the photo is read relative to its own exposure, so that the same fabric
    # shot a stop darker or brighter is fitted alike; the outputs show it as shot
    as_shot, exposure = prepared, None
    if options.exposure == "photo":
        exposure = photo_exposure(prepared.regularized.image, cells, light=light)
        prepared = prepared.exposed(exposure)

    say(f"pre-estimating a {shape[0]}x{shape[1]} repeat (pattern, colours, parameters)")
    t = time.perf_counter()
    if options.start_from is not None:
        start = options.start_from
        report["pre_estimation"] = {"parameters_from": "start_from"}
    else:
        pre = pre_estimate(prepared.regularized.image, cells, light=light, use_network=options.use_network,
                           pattern=None if options.pattern is not None else known, start=decided)
        start = pre.fabric
        report["pre_estimation"] = pre.to_json()
    if decision is not None:
        report["pre_estimation"]["decision"] = decision.to_json()
    if options.pattern is not None:
        start = start.replace({"pattern": options.pattern})
    timings["pre_estimate"] = time.perf_counter() - t

    if options.light == "auto":
        light, losses = choose_rig(prepared, cells, start, c=c, spp=config.spp)
        light_reason = "the rig whose render, colours and gain solved, explains the photo best: " + ", ".join(
            f"{k} {v:.4g}" for k, v in losses.items())
    # the fit starts at unit gain and solves its own (:func:`weavecap.fit.joint.solve_colours`):
    # started at the pre-estimate's exposure, found with its guessed specular terms, an own-render
    # twill stayed at 2.1 times the truth's gain (27.6 dB; 34.8 from unit gain)
    rig = light_rig(light)
    t = time.perf_counter()
    # what this photo can show: values no render of its repeat sees are held, not fitted
    plan = modelled.plan(start, cell_px=c, fixed=frozenset({"pattern"}) if known is not None else frozenset())
    unseen = {k: se for k, se in standard_errors(plan.start, render_numpy(build_scene(
        plan.start, View(tiles=(1, 1), size=c * max(shape), spp=config.spp), light=rig)), blur_px=0.0, light=rig,
        spp=config.spp, fixed=plan.fixed).items() if not np.isfinite(se)}
    plan = modelled.plan(plan.start, cell_px=c, fixed=plan.fixed, unseen=unseen, reasons=plan.reasons)
    timings["plan"] = time.perf_counter() - t
    say(f"fitting ({options.quality}: up to {config.iterations} steps"
        + (f", {options.budget_s:g} s budget" if options.budget_s else "") + ")")
    t = time.perf_counter()
    fitted = fit_registered(prepared, cells, plan.start, options, c=c, fixed=plan.fixed, rig=rig,
                            explore_patterns=known is None and options.start_from is None)
    result, blur_px, target, photo_cells = fitted.result, fitted.blur_px, fitted.target, fitted.cells
    report["pre_estimation"].update(fitted.notes)
    timings["fit"] = time.perf_counter() - t

    t = time.perf_counter()
    fs = build_scene(result.fabric, View(tiles=(1, 1), size=max(target.shape[:2]), spp=config.spp), light=fitted.rig)
    rendered = as_photographed(render_numpy(fs), blur_px, white_level(target))
    confidence = pattern_confidence(fs, rendered, target, config.spp, blur_px)
    photo_canvas = cell_canvas(prepared.rectification.image, photo_cells, c)
    noise = fit_noise(photo_canvas - rendered, pitch_px=float(c), seed=options.seed)
    fabric = dataclasses.replace(result.fabric, noise=noise) if noise["gaussians"] else result.fabric
    pitch = prepared.grid.pitch_px
    timings["noise"] = time.perf_counter() - t

    say("measuring how well the photo determines each parameter")
    t = time.perf_counter()
    errors = standard_errors(result.fabric, target, blur_px=blur_px, light=fitted.rig, spp=config.spp,
                             fixed=plan.fixed)
    timings["uncertainty"] = time.perf_counter() - t
    timings["total"] = time.perf_counter() - t0

    faithful = fidelity(target, rendered, result.fabric.pattern, shot=(exposure or 1.0) * photo_canvas)
    report.update(status="ok", weave=weave_name(fabric.pattern))
    report["fit"] = {
        "psnr_db": round(psnr(rendered, target), 3), "iterations": result.iterations,
        "pattern_confidence": round(confidence, 4), "mse": result.loss, "stopped": result.stopped,
        "seconds": round(result.seconds, 3), "cell_px": c, "spp": config.spp, "moves": result.moves,
        "pattern_fixed": known is not None, "fidelity": faithful.to_json(),
        "parameters": {key: {"standard_error": round(se, 4) if np.isfinite(se) else None,
                             "determined": bool(se <= DETERMINED_SE)} for key, se in errors.items()},
    }
    report["fit"]["light"] = modelled.light_json(fitted.rig, result.moves, exposure=exposure)
    report["modelled"] = modelled.describe(plan, result, errors, light=light, light_reason=light_reason,
                                           spp=config.spp,
                                           blur_px=blur_px, noise=noise, pitch_px=pitch, plies_flat=config.plies_flat)
    report["timings_s"] = {k: round(v, 3) for k, v in timings.items()}
    error = np.abs(rendered - target) * 4.0
    images = {"compare.png": (exposure or 1.0) * np.concatenate([target, rendered, error], axis=1),
              "rectified.png": as_shot.rectification.image, "grid.png": as_shot.grid_overlay()}
    return Capture(report=report, fabric=fabric, images=images, history=result.history,
                   captions={"compare.png": faithful.caption()})


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


def rig_search(photo_path: str | Path, options: CaptureOptions, *, first: Capture | None = None,
               progress: Callable[[str], None] | None = None) -> Capture:
    """The capture under ``auto`` (``first``, when already made), then under each rig of
    :data:`BEST_RIGS` it did not fit under (pre-estimate, fit and end stages under that rig):
    three captures, three times ``auto``'s time; one kept (:func:`kept_capture`).

    ``auto`` picks its rig before any fit, on the pre-estimate, where the loss prefers the
    flatter rig whatever lit the photo: it is physically wrong on 6 of the 18 independent
    photos. After the whole fit the loss mostly ranks the rigs as their looks do, but it
    rewards a blur: on 5 of the 18 the lowest loss was a render under 0.75 of the photo's
    sharpness. Measured on the independent photos (normal): sharpness median / worst
    0.91 / 0.31 under ``auto`` without a retry, 0.94 / 0.82 with it, 0.98 / 0.82 searching
    every photo; ΔE2000 median / worst 0.9 / 13.3, 0.7 / 8.3 and 0.7 / 6.9 (docs/capture.md,
    Sessions 16–17). A photo rejected by ``auto`` is returned at once (preparation does not
    depend on the rig)."""
    say = progress or (lambda _msg: None)
    config = options.config
    caps = {}
    if first is not None:
        caps["auto"] = first
        say("the render is not faithful to the photo: capturing again under the other rigs")
    for light in ("auto", *BEST_RIGS):
        if light in caps or ("auto" in caps and light == caps["auto"].report["fit"]["light"]["rig"]):
            continue  # made, or auto fitted under it
        say(f"capturing with --light {light} ({len(caps) + 1} of {len(BEST_RIGS)})")
        cap = capture_under_rig(photo_path, dataclasses.replace(options, light=light), progress=progress)
        if cap.status != "ok":
            return cap
        caps[light] = cap
    chosen, reason = kept_capture({light: cap.report for light, cap in caps.items()}, config)
    out = caps[chosen]
    why = ("every rig searched (--light best)" if first is None else
           f"auto's capture was not faithful to the photo (sharpness under {config.faithful_sharpness} "
           f"or a family's colour beyond ΔE {config.faithful_delta_e}), the other rigs searched")
    out.report["options"]["light"] = options.light
    fits = {light: cap.report["fit"] for light, cap in caps.items()}
    each = [f"{light} loss {f['mse']:.4g}, sharpness {f['fidelity']['sharpness']}, ΔE {f['fidelity']['delta_e']}"
            for light, f in fits.items()]
    out.report["modelled"]["light_rig_from"] = (f"{why}: {chosen} ({out.report['fit']['light']['rig']}) kept, "
                                                f"{reason}: " + ", ".join(each))
    out.report["timings_s"]["captures"] = {light: cap.report["timings_s"]["total"] for light, cap in caps.items()}
    out.report["timings_s"]["total"] = round(sum(out.report["timings_s"]["captures"].values()), 3)
    return out


def kept_capture(reports: dict[str, dict], config: FitConfig) -> tuple[str, str]:
    """Which of a rig search's captures to keep (``reports``: ``auto``'s and each other rig's
    report), and why. Weighed: ``auto``'s, and those whose loss (``fit.mse``, against the
    photo's repeat registered on its own render) is within ``config.rig_loss_slack`` of the
    lowest; of them the lowest loss among the :func:`faithful`, else among those at least
    ``config.faithful_sharpness`` as sharp as the photo, else the sharpest.

    The loss alone rewards a blur (above); sharpness alone took sharp renders that explain the
    photo far worse: the independent satin 5 a stop darker (``--exposure photo``), ``lamp``
    at 5.9 times auto's loss, its warp ΔE 21. The captures kept on both photo sets were within
    1.35 times the lowest loss (docs/capture.md, Session 17)."""
    losses = {light: float(r["fit"]["mse"]) for light, r in reports.items()}
    sharpness = {light: r["fit"]["fidelity"]["sharpness"] or 0.0 for light, r in reports.items()}
    lowest = min(losses.values())
    weighed = [light for light in reports if light == "auto" or losses[light] <= config.rig_loss_slack * lowest]
    faithful_ones = [light for light in weighed if faithful(reports[light], config)]
    if faithful_ones:
        return min(faithful_ones, key=losses.get), "the lowest loss of the faithful captures"
    sharp = [light for light in weighed if sharpness[light] >= config.faithful_sharpness]
    if sharp:
        return min(sharp, key=losses.get), (f"none faithful; the lowest loss of those {config.faithful_sharpness} "
                                            "as sharp as the photo")
    return max(weighed, key=sharpness.get), f"none {config.faithful_sharpness} as sharp as the photo; the sharpest"


def write_capture(cap: Capture, out_dir: Path) -> None:
    """Write a capture's outputs into ``out_dir`` as one result set, report.json last
    (:func:`weavecap.io.write_result_set`). A rejected photo gets only report.json; an
    earlier run's other outputs are removed."""
    from .io import atomic_write_text, write_result_set
    from .photo import save_png

    files = {}
    if cap.fabric is not None:  # texture paths relative to where params.json ends up, not the staging
        files["params.json"] = lambda path: atomic_write_text(path, wparams.dumps(cap.fabric, base=out_dir.resolve()))
        for name, image in cap.images.items():
            if name == "compare.png":
                image = _enlarged(image)
            if name in cap.captions:
                image = captioned(image, cap.captions[name])
            files[name] = lambda path, image=image: save_png(path, image)
        files["loss.png"] = lambda path: save_png(path, loss_plot(cap.history))
    write_result_set(out_dir, files, record=("report.json", json.dumps(cap.report, indent=1) + "\n"),
                     outputs=OUTPUT_FILES)
