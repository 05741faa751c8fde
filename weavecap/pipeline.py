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
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from . import params as wparams
from .errors import PhotoError
from .fit.config import PRESETS, FitConfig, cell_px_for
from .fit.target import align_cells, dual, mean_repeat, photo_blur, register_cells, repeat_cells, shifted
from .io import atomic_write_text

REPORT_FORMAT = "weavecap.report/1"
OUTPUT_FILES = ("params.json", "report.json", "compare.png", "rectified.png", "grid.png", "loss.png")


@dataclass(frozen=True)
class CaptureOptions:
    """What the user chose for a capture (``weavecap fit``'s options).

    Attributes
    ----------
    quality : preset name of :data:`weavecap.fit.config.PRESETS`
    light : the light rig the photo was taken under (§6.4)
    seed : seeds every random choice; the same seed gives the same result
    budget_s : wall-time limit of the joint fit, seconds (None: the preset's iterations)
    start_from : a fabric to start the fit from instead of the pre-estimate (warm start)
    pattern : a known pattern (fixed during the fit), or None
    use_network : False skips the initializer network (defaults, §7.3)
    """

    quality: str = "normal"
    light: str = "both"
    seed: int = 0
    budget_s: float | None = None
    start_from: wparams.Fabric | None = None
    pattern: np.ndarray | None = None
    use_network: bool = True

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

    @property
    def status(self) -> str:
        return self.report["status"]


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    """PSNR in dB of two linear images clipped to [0, 1] (peak 1)."""
    mse = float(np.mean((np.clip(a, 0, 1).astype(np.float64) - np.clip(b, 0, 1)) ** 2))
    return float(10 * np.log10(1.0 / max(mse, 1e-12)))


def _pattern_confidence(fs, rendered: np.ndarray, target: np.ndarray, spp: int, blur_px: float) -> float:
    """Fraction of cells whose fitted state (``rendered``, blurred) explains the photo better
    than its opposite (one more render, of the complement pattern)."""
    from .estimate.cells import cell_errors
    from .model.render import as_photographed, render_numpy, white_level

    pattern = fs.fabric.pattern.copy()
    now = cell_errors(rendered, target, pattern.shape)
    fs.set("pattern", 1 - pattern)
    flipped = cell_errors(as_photographed(render_numpy(fs, spp=spp), blur_px, white_level(target)), target,
                          pattern.shape)
    fs.set("pattern", pattern)
    return float(np.mean(flipped > now))


def base_report(photo_path: str | Path, options: CaptureOptions) -> dict:
    """A report.json holding every part the contract requires, with neutral values: each stage
    overwrites its part as it finishes, so a photo that stops early still has a valid report."""
    return {"format": REPORT_FORMAT, "input": {"path": str(photo_path), "sha256": "", "width": 0, "height": 0},
            "status": "failed", "rectification": {"rotation_deg": 0.0, "homography": np.eye(3).tolist()},
            "grid": {"repeat_px": [0, 0], "pitch_px": [0, 0], "yarns": [0, 0]},
            "fit": {"psnr_db": 0.0, "iterations": 0}, "timings_s": {"total": 0.0},
            "options": {"quality": options.quality, "light": options.light, "seed": options.seed,
                        "budget_s": options.budget_s, "network": options.use_network}}


def _rejected(report: dict, reason: str, code: str, timings: dict, t0: float) -> Capture:
    timings["total"] = time.perf_counter() - t0
    report.update(status="rejected", reason=reason, code=code,
                  timings_s={k: round(v, 3) for k, v in timings.items()})
    return Capture(report=report)


def capture(photo_path: str | Path, options: CaptureOptions = CaptureOptions(), *,
            progress: Callable[[str], None] | None = None) -> Capture:
    """Run the whole pipeline on one photo. Bad photos give status ``rejected``, not errors."""
    from .estimate.cells import cell_canvas
    from .estimate.preestimate import pre_estimate
    from .estimate.weave_name import weave_name
    from .fit.uncertainty import DETERMINED_SE, standard_errors
    from .model.render import as_photographed, render_numpy, white_level
    from .model.scene import View, build_scene
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
    report["input"].update(sha256=photo.sha256, width=photo.width, height=photo.height,
                           format=photo.source_format)
    timings["load"] = time.perf_counter() - t

    say("preparing (rectify, regularize, repeat, grid)")
    t = time.perf_counter()
    prepared = prepare_photo(photo.rgb)
    timings["prepare"] = time.perf_counter() - t
    if isinstance(prepared, Rejected):
        report["checks"] = prepared.to_json()["checks"]
        return _rejected(report, prepared.reason, prepared.code, timings, t0)
    prep = prepared.to_json()
    report["rectification"], report["grid"] = prep["rectification"], prep["grid"]
    cells = repeat_cells(prepared, prepared.regularized.box)
    cells = align_cells(prepared.regularized.image, cells)
    shape = cells.shape
    if options.pattern is not None and options.pattern.shape != shape:
        raise wparams.ParamsError(f"the given pattern is {options.pattern.shape[0]}x{options.pattern.shape[1]} but "
                                  f"the photo's repeat is {shape[0]} wefts x {shape[1]} warps", field="pattern")

    say(f"pre-estimating a {shape[0]}x{shape[1]} repeat (pattern, colours, parameters)")
    t = time.perf_counter()
    if options.start_from is not None:
        start = options.start_from
        if start.shape != shape:
            raise wparams.ParamsError(f"--start-from has a {start.shape[0]}x{start.shape[1]} pattern but the photo's "
                                      f"repeat is {shape[0]}x{shape[1]}", field="pattern")
        report["pre_estimation"] = {"parameters_from": "start_from"}
    else:
        pre = pre_estimate(prepared.regularized.image, cells, light=options.light, use_network=options.use_network)
        start = pre.fabric
        report["pre_estimation"] = pre.to_json()
    if options.pattern is not None:
        start = start.replace({"pattern": options.pattern})
    timings["pre_estimate"] = time.perf_counter() - t

    config = options.config
    c = cell_px_for(config, shape)
    fixed = frozenset({"pattern"}) if options.pattern is not None else frozenset()
    say(f"fitting ({options.quality}: up to {config.iterations} steps"
        + (f", {options.budget_s:g} s budget" if options.budget_s else "") + ")")
    t = time.perf_counter()
    fitted = fit_registered(prepared, cells, start, options, c=c, fixed=fixed,
                            explore_patterns=options.pattern is None and options.start_from is None)
    result, blur_px, target, photo_cells = fitted.result, fitted.blur_px, fitted.target, fitted.cells
    report["pre_estimation"].update(fitted.notes)
    timings["fit"] = time.perf_counter() - t

    t = time.perf_counter()
    fs = build_scene(result.fabric, View(tiles=(1, 1), size=max(target.shape[:2]), spp=config.spp), light=options.light)
    rendered = as_photographed(render_numpy(fs), blur_px, white_level(target))
    confidence = _pattern_confidence(fs, rendered, target, config.spp, blur_px)
    photo_canvas = cell_canvas(prepared.rectification.image, photo_cells, c)
    noise = fit_noise(photo_canvas - rendered, pitch_px=float(c), seed=options.seed)
    fabric = dataclasses.replace(result.fabric, noise=noise) if noise["gaussians"] else result.fabric
    pitch = prepared.grid.pitch_px
    timings["noise"] = time.perf_counter() - t

    say("measuring how well the photo determines each parameter")
    t = time.perf_counter()
    errors = standard_errors(result.fabric, target, blur_px=blur_px, light=options.light, spp=config.spp)
    timings["uncertainty"] = time.perf_counter() - t
    timings["total"] = time.perf_counter() - t0

    report.update(status="ok", weave=weave_name(fabric.pattern))
    report["fit"] = {
        "psnr_db": round(psnr(rendered, target), 3), "iterations": result.iterations,
        "pattern_confidence": round(confidence, 4), "mse": result.loss, "stopped": result.stopped,
        "seconds": round(result.seconds, 3), "cell_px": c, "spp": config.spp, "moves": result.moves,
        "pattern_fixed": options.pattern is not None,
        "parameters": {key: {"standard_error": round(se, 4) if np.isfinite(se) else None,
                             "determined": bool(se <= DETERMINED_SE)} for key, se in errors.items()},
    }
    report["modelled"] = {
        "light_rig": options.light,
        "transmission": "exit-point rays for the back light" if options.light in ("both", "back")
        else "none: nothing lights the back",
        "samples_per_pixel": f"{config.spp}: directional lights are exact at pixel centres",
        "radii": "greedy pattern search (finite-difference gradients: same PSNR, 19x slower; Metropolis moves: 5 dB worse)",
        "photo_blur_px": round(blur_px, 3),
        "noise": f"{len(noise['gaussians'])} Gaussians over the residual spectrum",
        "yarn_pitch_px": [round(float(v), 3) for v in pitch],
    }
    report["timings_s"] = {k: round(v, 3) for k, v in timings.items()}
    error = np.abs(rendered - target) * 4.0
    images = {"compare.png": np.concatenate([target, rendered, error], axis=1),
              "rectified.png": prepared.rectification.image, "grid.png": prepared.grid_overlay()}
    return Capture(report=report, fabric=fabric, images=images, history=result.history)


@dataclass
class RegisteredFit:
    """One round of :func:`fit_registered`: a fit, and the registration it was fitted on.

    Attributes
    ----------
    result : the round's :class:`weavecap.fit.joint.FitResult` (after :func:`fit_registered`,
        its history holds every round's steps)
    target : (n_e*c, n_a*c, 3) the photo's median repeat on the registration
    cells : that registration, a CellGrid in the regularized box's pixels
    blur_px : the blur the renders were compared with
    notes : what the report records (cell shifts per round, the dual choice)
    """

    result: object
    target: np.ndarray
    cells: object
    blur_px: float
    notes: dict = field(default_factory=dict)


def _registered_target(prepared, cells, model: np.ndarray, c: int):
    """The cells registered on ``model`` (a render of one repeat as photographed, ``c`` px per
    cell) and the photo's median repeat there: (cells in the regularized box's pixels, shift in
    cells, target (n_e*c, n_a*c, 3))."""
    cells, shift = register_cells(prepared.regularized.image, cells, model, c)
    target = mean_repeat(prepared.rectification.image, shifted(cells, prepared.regularized.box), c, model=model)
    return cells, shift, target


def _fit_round(prepared, cells, fabric: wparams.Fabric, options: CaptureOptions, config: FitConfig, *, c: int,
               fixed: frozenset[str], seed: int, budget_s: float | None) -> RegisteredFit:
    """Register ``cells`` on a render of ``fabric``, extract the photo's median repeat there,
    measure the blur, and fit ``fabric`` to it. One render serves all three."""
    from .estimate.forward import BLUR_CELLS, RepeatRenderer
    from .fit.joint import fit
    from .model.render import as_photographed, white_level

    image = RepeatRenderer(fabric, cell_px=c, light=options.light, spp=config.spp, blur_cells=0.0).render()
    model = as_photographed(image, BLUR_CELLS * c, white_level(prepared.rectification.image))
    cells, shift, target = _registered_target(prepared, cells, model, c)
    blur_px, _ = photo_blur(image, target, c)
    result = fit(target, fabric, config=config, light=options.light, seed=seed, budget_s=budget_s, fixed=fixed,
                 blur_px=blur_px)
    return RegisteredFit(result=result, target=target, cells=cells, blur_px=blur_px,
                         notes={"cell_shift": [round(v, 3) for v in shift]})


def is_named_weave(pattern: np.ndarray) -> bool:
    """The pattern has a name other than custom (:func:`weavecap.estimate.weave_name.weave_name`:
    at any phase, tiled, or an extended satin) — the same rule the report names it by."""
    from .estimate.weave_name import weave_name

    return not weave_name(pattern).startswith("custom")


def best_named_weave(prepared, cells, start: wparams.Fabric, options: CaptureOptions, *, c: int,
                     tolerance: float = 0.0) -> np.ndarray | None:
    """The named weave (:func:`weavecap.estimate.sampling.regular_weaves`) of ``start``'s repeat
    shape that explains the photo best with ``start``'s other parameters, if it explains it
    better than ``start``'s own pattern does (or at most ``tolerance`` worse, as a fraction of
    the MSE; ``math.inf``: the best named weave however it scores); else None.

    §5.1's annealing flips one cell at a time, and on a large repeat (a satin of 8) it can
    settle in a pattern no single flip improves. Each named weave is scored as the fit would
    see it: the cells registered on its render, the photo's median repeat there, and the
    MSE between the two (one render each). The pattern's phase does not matter: the
    registration moves the cells to it.
    """
    from .estimate.forward import RepeatRenderer
    from .estimate.sampling import regular_weaves
    from .estimate.weave_name import equal_up_to_shift
    from .model.render import white_level

    weaves = [p for p in regular_weaves(start.shape) if not equal_up_to_shift(p, start.pattern)]
    if not weaves:
        return None
    rr = RepeatRenderer(start, cell_px=c, light=options.light, white=white_level(prepared.rectification.image))

    def score(pattern: np.ndarray) -> float:
        rr.set_pattern(pattern)
        model = rr.render()
        _, _, target = _registered_target(prepared, cells, model, c)
        return float(np.mean(np.square(model - target)))

    own = score(start.pattern)
    scores = [score(p) for p in weaves]
    k = int(np.argmin(scores))
    return weaves[k] if scores[k] < own * (1.0 + tolerance) else None


def fit_registered(prepared, cells, start: wparams.Fabric, options: CaptureOptions, *, c: int,
                   fixed: frozenset[str], explore_patterns: bool) -> RegisteredFit:
    """The joint fit (§6), alternating with the registration of the photo's cells.

    The target is the photo's median repeat on cells registered against a render of the
    current fabric (:func:`register_cells`); a render of the pre-estimate can be far enough off
    (wrong radii, colours) to put the cells a fifth of a yarn astray, and then even the true
    parameters score poorly (a synthetic random 2×3 turned 12°: 15.4 dB registered on the
    pre-estimate, 33.7 dB on the truth). So the fit runs in ``config.registration_rounds``
    rounds, the iterations and any budget split evenly; before each, the cells are registered
    on the fabric fitted so far, the target re-extracted and the blur re-measured. Each round
    warm-starts from the best fabric so far, and the round with the lowest loss is kept.

    With ``explore_patterns`` (the pattern is free and the start is the pre-estimate) the first
    round is run from the pre-estimate and from its
    :func:`dual` (every cell flipped, warp and weft exchanged), and the lower loss goes on: the
    two differ only in which way the yarns run in each cell, which a pre-estimate judged on
    cell colours gets wrong when the colours hardly show (a pale, back-lit twill: its
    complement). A third start is the named weave of the same repeat that explains the photo
    best, when it explains it better than the pre-estimate (:func:`best_named_weave`). At the
    end, a fitted pattern that is no named weave is tried against the best named weave of its
    shape, fitted with that pattern fixed; within ``config.named_weave_tolerance`` of the loss,
    the named weave is kept. The candidate is always fitted: scored with the custom fit's
    values, the real satin W108's named weave looked worse than its custom 5×5 and was not
    tried; fitted, its loss was 0.0056 against 0.0133 (18.7 → 22.5 dB). Returns the best
    round, with ``cells`` in the rectified photo's
    pixels.
    """
    config = options.config
    rounds = max(1, config.registration_rounds)
    per_round = config.with_(iterations=max(1, config.iterations // rounds))
    t0 = time.perf_counter()
    starts = {"pre_estimate": start, "dual": dual(start)} if explore_patterns else {"pre_estimate": start}
    if explore_patterns:
        named = best_named_weave(prepared, cells, start, options, c=c)
        if named is not None:
            starts["named_weave"] = start.replace({"pattern": named})
    runs = rounds + len(starts)  # and one more round for a named weave

    def budget(done: int) -> float | None:
        if options.budget_s is None:
            return None
        return max(0.0, options.budget_s - (time.perf_counter() - t0)) / max(1, runs - done)

    def spent() -> bool:  # with --budget, no further start or round begins once it is used up
        return options.budget_s is not None and time.perf_counter() - t0 >= options.budget_s

    firsts: dict[str, RegisteredFit] = {}
    for k, (name, fabric) in enumerate(starts.items()):
        if firsts and spent():
            break
        firsts[name] = _fit_round(prepared, cells, fabric, options, per_round, c=c, fixed=fixed, seed=options.seed,
                                  budget_s=budget(k))
    chosen = min(firsts, key=lambda name: firsts[name].result.loss)
    best = firsts[chosen]
    notes = {"cell_shift": [best.notes["cell_shift"]]}
    if explore_patterns:
        notes["start"] = {"chosen": chosen, **{name: round(r.result.loss, 6) for name, r in firsts.items()}}
    history = list(best.result.history)
    k, gain = 1, math.inf
    while k < rounds or (k < rounds + config.extra_rounds and gain > config.extra_round_gain):
        if spent():
            break
        last = _fit_round(prepared, best.cells, best.result.fabric, options, per_round, c=c, fixed=fixed,
                          seed=options.seed + k, budget_s=budget(len(starts) + k - 1))
        notes["cell_shift"].append(last.notes["cell_shift"])
        history += last.result.history
        gain = (best.result.loss - last.result.loss) / max(best.result.loss, 1e-12)
        if last.result.loss < best.result.loss:  # every round scores against the same photo
            best = last
        k += 1
    if explore_patterns and not spent() and not is_named_weave(best.result.fabric.pattern):
        named = best_named_weave(prepared, best.cells, best.result.fabric, options, c=c, tolerance=math.inf)
        if named is not None:
            last = _fit_round(prepared, best.cells, best.result.fabric.replace({"pattern": named}), options, per_round,
                              c=c, fixed=fixed | {"pattern"}, seed=options.seed + k, budget_s=budget(runs - 1))
            history += last.result.history
            taken = last.result.loss <= best.result.loss * (1.0 + config.named_weave_tolerance)
            notes["named_weave"] = {"pattern": named.astype(int).tolist(), "loss": round(last.result.loss, 6),
                                    "fitted_loss": round(best.result.loss, 6), "taken": taken}
            if taken:
                best = last
    result = dataclasses.replace(best.result, history=history, iterations=len(history),
                                 seconds=time.perf_counter() - t0)
    return RegisteredFit(result=result, target=best.target, cells=shifted(best.cells, prepared.regularized.box),
                         blur_px=best.blur_px, notes=notes)


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
    """Write a capture's outputs into ``out_dir`` (created), each atomically, report.json last.
    A rejected photo gets only report.json."""
    from .photo import save_png

    out_dir.mkdir(parents=True, exist_ok=True)
    if cap.fabric is not None:
        wparams.save(cap.fabric, out_dir / "params.json")
        for name, image in cap.images.items():
            save_png(out_dir / name, _enlarged(image) if name == "compare.png" else image)
        save_png(out_dir / "loss.png", loss_plot(cap.history))
    atomic_write_text(out_dir / "report.json", json.dumps(cap.report, indent=1) + "\n")
