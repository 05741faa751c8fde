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


def _repeat_cells(prepared, image_box: tuple[float, float, float, float]):
    """The cells of one repeat inside the regularized box, in the box's pixels."""
    from .estimate.cells import CellGrid

    grid = prepared.grid
    rows, cols = grid.cells()
    y0, x0 = image_box[0], image_box[1]
    rh, rw = rows[-1] - rows[0], cols[-1] - cols[0]
    # move the repeat by whole repeats so that it starts inside the box
    dy = y0 + np.mod(rows[0] - y0, rh) - rows[0]
    dx = x0 + np.mod(cols[0] - x0, rw) - cols[0]
    return CellGrid(rows=rows + dy - y0, cols=cols + dx - x0)


def align_cells(image: np.ndarray, cells):
    """Put the cell corners on the gaps between yarns: of the four half-pitch shifts of
    ``cells``, the one whose corners vary most and whose centres vary least (§5's cells are
    centred on yarn crossings).

    The yarn boundaries of §4.4 are valleys of the integral projection — right under front
    light, where gaps are dark, but half a pitch off under back light, where they glow. A
    corner window holds a gap and four yarn edges whatever the light; a centre window sits on a
    smooth crossing. (Finer shifts, and the orientation coherence of each cell, were tried and
    chose worse phases on the bench photos.) ``image`` (H, W, 3) linear RGB, ``cells`` a
    CellGrid in its pixels.
    """
    from .estimate.cells import CellGrid, cell_canvas

    c = 12
    win = max(1, c // 4)
    best, best_score = cells, -np.inf
    for dy in (0.0, 0.5):
        for dx in (0.0, 0.5):
            shifted = CellGrid(rows=cells.rows + dy * np.diff(cells.rows).mean(),
                               cols=cells.cols + dx * np.diff(cells.cols).mean())
            grey = cell_canvas(image, shifted, c).mean(axis=2)
            tiles = grey.reshape(shifted.shape[0], c, shifted.shape[1], c).transpose(0, 2, 1, 3)
            centre = tiles[:, :, c // 2 - win: c // 2 + win, c // 2 - win: c // 2 + win]
            corner = np.roll(np.roll(grey, win, axis=0), win, axis=1)
            corner = corner.reshape(shifted.shape[0], c, shifted.shape[1], c).transpose(0, 2, 1, 3)[:, :, :2 * win, :2 * win]
            score = float(corner.var(axis=(2, 3)).mean() - centre.var(axis=(2, 3)).mean())
            if score > best_score:
                best, best_score = shifted, score
    return best


def register_cells(image: np.ndarray, cells, fabric: wparams.Fabric, *, light: str, c: int = 16):
    """Move ``cells`` so that the photo's repeat lines up with a render of ``fabric``.

    The cells found from §4.4's boundaries can sit a fraction of a yarn off (uneven lighting,
    bright gaps, residual perspective), and then no parameter values fit. The photo's cell
    canvas and the render are both one period of the fabric, so their circular
    cross-correlation (one FFT) peaks at the shift between them; the cells move by that shift
    (sub-pixel, by a parabola through the peak), whole cells included, so the fabric's pattern
    stays right for the moved cells. Returns the moved CellGrid and the shift in cells (dy, dx).
    """
    from .estimate.cells import CellGrid, cell_canvas
    from .estimate.forward import RepeatRenderer

    photo = cell_canvas(image, cells, c).mean(axis=2)
    model = RepeatRenderer(fabric, cell_px=c, light=light).render().mean(axis=2)
    a, b = photo - photo.mean(), model - model.mean()
    corr = np.real(np.fft.ifft2(np.fft.fft2(a) * np.conj(np.fft.fft2(b))))
    iy, ix = np.unravel_index(int(np.argmax(corr)), corr.shape)

    def peak(values: np.ndarray, i: int) -> float:
        n = values.size
        lo, mid, hi = values[(i - 1) % n], values[i], values[(i + 1) % n]
        den = lo - 2 * mid + hi
        k = i + (0.5 * (lo - hi) / den if den < 0 else 0.0)
        return k - n if k > n / 2 else k

    dy, dx = peak(corr[:, ix], iy) / c, peak(corr[iy, :], ix) / c
    moved = CellGrid(rows=cells.rows + dy * np.diff(cells.rows).mean(), cols=cells.cols + dx * np.diff(cells.cols).mean())
    return moved, (float(dy), float(dx))


def mean_repeat(image: np.ndarray, cells, c: int):
    """The photo's average repeat as a cell canvas: the median over every whole repeat of
    ``image`` (H, W, 3) on the lattice of ``cells`` (a CellGrid in its pixels), one pitch clear
    of the border. Irregularities average out (§4.2's aim) without kernel PCA's variable
    smoothing: on a synthetic twill the true parameters score 33.9 and 35.5 dB against this at
    0° and 12° turns, against the regularized photo's repeat 26.4 and 40.4 dB. Returns
    (n_e*c, n_a*c, 3).
    """
    from .estimate.cells import CellGrid, cell_canvas

    n_e, n_a = cells.shape
    h, w = image.shape[:2]
    axes = []
    for bounds, n, size in ((cells.rows, n_e, h), (cells.cols, n_a, w)):
        pitch = float(np.diff(bounds).mean())
        period = n * pitch
        start = bounds[0] - np.floor((bounds[0] - pitch) / period) * period  # first repeat clear of the edge
        count = max(1, int(np.floor((size - pitch - start) / period)))
        if start + period > size:  # the photo holds less than one clear repeat: use the one given
            start, count = bounds[0], 1
        axes.append((start + pitch * np.arange(count * n + 1), count))
    (rows, ky), (cols, kx) = axes
    canvas = cell_canvas(image, CellGrid(rows=rows, cols=cols), c)
    return np.median(canvas.reshape(ky, n_e * c, kx, n_a * c, 3), axis=(0, 2)).astype(np.float32)


def dual(fabric: wparams.Fabric) -> wparams.Fabric:
    """The fabric with every cell's state flipped and the warp's and weft's colours and radii
    exchanged: in each cell the other yarn family is on top, in the colour that was there. A
    cell-colour match cannot tell the two apart (a plain weave's two phases look alike cell by
    cell); only the yarns' shapes (running across or down) can."""
    swap = {}
    for key in ("body_reflection", "body_subsurface", "radius"):
        swap[f"warp.{key}"], swap[f"weft.{key}"] = fabric.get(f"weft.{key}"), fabric.get(f"warp.{key}")
    return fabric.replace({**swap, "pattern": 1 - fabric.pattern})


def photo_blur(fabric: wparams.Fabric, target: np.ndarray, *, light: str, spp: int) -> float:
    """σ (canvas px) of the Gaussian that makes a render of ``fabric`` most like ``target``,
    and the MSE it leaves.

    The regularized photo is smoothed by §4.2's Gaussian (σ = pitch / 16), by resampling to
    the canvas and by the camera itself; how much in all varies from photo to photo, and the
    MSE is very sensitive to it (on a 16-px canvas: 0.0033 at σ = 1 px, 0.0025 at 1.5, 0.0053
    at 2). It is measured once, on the pre-estimate, by a bounded 1-D search.
    """
    from scipy.optimize import minimize_scalar

    from .model.render import blurred_mse, render_numpy
    from .model.scene import View, build_scene

    c = target.shape[0] / fabric.shape[0]
    image = render_numpy(build_scene(fabric, View(tiles=(1, 1), size=max(target.shape[:2]), spp=spp), light=light))
    best = minimize_scalar(lambda s: blurred_mse(image, target, s), bounds=(0.0, c / 4), method="bounded",
                           options={"xatol": 0.02})
    return float(best.x), float(best.fun)


def _better_of_dual(start: wparams.Fabric, target: np.ndarray, light: str, spp: int):
    """The pre-estimate or its :func:`dual`, whichever renders closer to the photo (each at its
    own best blur); returns (fabric, blur_px, what was compared)."""
    options = {"pre_estimate": start, "dual": dual(start)}
    scores = {name: photo_blur(f, target, light=light, spp=spp) for name, f in options.items()}
    name = min(scores, key=lambda k: scores[k][1])
    return options[name], scores[name][0], {"chosen": name, **{k: round(v[1], 6) for k, v in scores.items()}}


def _pattern_confidence(fs, rendered: np.ndarray, target: np.ndarray, spp: int, blur_px: float) -> float:
    """Fraction of cells whose fitted state (``rendered``, blurred) explains the photo better
    than its opposite (one more render, of the complement pattern)."""
    from .estimate.cells import cell_errors
    from .model.render import blur, render_numpy

    pattern = fs.fabric.pattern.copy()
    now = cell_errors(rendered, target, pattern.shape)
    fs.set("pattern", 1 - pattern)
    flipped = cell_errors(blur(render_numpy(fs, spp=spp), blur_px), target, pattern.shape)
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
    from .fit.joint import fit
    from .model.render import blur, render_numpy
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
    cells = _repeat_cells(prepared, prepared.regularized.box)
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
    cells, shift = register_cells(prepared.regularized.image, cells, start, light=options.light, c=c)
    report.setdefault("pre_estimation", {})["cell_shift"] = [round(v, 3) for v in shift]
    photo_cells = _shifted(cells, prepared.regularized.box)  # in the rectified photo's pixels
    target = mean_repeat(prepared.rectification.image, photo_cells, c)
    fixed = frozenset({"pattern"}) if options.pattern is not None else frozenset()
    say(f"fitting ({options.quality}: up to {config.iterations} steps"
        + (f", {options.budget_s:g} s budget" if options.budget_s else "") + ")")
    t = time.perf_counter()
    if options.pattern is None and options.start_from is None:
        start, blur_px, report["pre_estimation"]["dual"] = _better_of_dual(start, target, options.light, config.spp)
    else:
        blur_px, _ = photo_blur(start, target, light=options.light, spp=config.spp)
    result = fit(target, start, config=config, light=options.light, seed=options.seed, budget_s=options.budget_s,
                 fixed=fixed, blur_px=blur_px)
    timings["fit"] = time.perf_counter() - t

    t = time.perf_counter()
    fs = build_scene(result.fabric, View(tiles=(1, 1), size=max(target.shape[:2]), spp=config.spp), light=options.light)
    rendered = blur(render_numpy(fs), blur_px)
    confidence = _pattern_confidence(fs, rendered, target, config.spp, blur_px)
    photo_canvas = cell_canvas(prepared.rectification.image, photo_cells, c)
    noise = fit_noise(photo_canvas - rendered, pitch_px=float(c), seed=options.seed)
    fabric = dataclasses.replace(result.fabric, noise=noise) if noise["gaussians"] else result.fabric
    pitch = prepared.grid.pitch_px
    timings["noise"] = time.perf_counter() - t
    timings["total"] = time.perf_counter() - t0

    report.update(status="ok", weave=weave_name(fabric.pattern))
    report["fit"] = {
        "psnr_db": round(psnr(rendered, target), 3), "iterations": result.iterations,
        "pattern_confidence": round(confidence, 4), "mse": result.loss, "stopped": result.stopped,
        "seconds": round(result.seconds, 3), "cell_px": c, "spp": config.spp, "moves": result.moves,
        "pattern_fixed": options.pattern is not None,
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


def _shifted(cells, box):
    """``cells`` (box pixels) in the rectified image's pixels."""
    from .estimate.cells import CellGrid

    return CellGrid(rows=cells.rows + box[0], cols=cells.cols + box[1])


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
