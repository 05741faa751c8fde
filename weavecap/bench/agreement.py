"""Agreement where users render: garments and lights no renderer here was trained on.

The ``agreement`` section of ``weavecap bench --render``. For every garment of
:data:`weavecap.render.garments.GARMENTS` (and the towel of ``../shared/meshes`` when present),
every shipped light (:data:`weavecap.render.scene.LIGHTS`) and one environment map
(:func:`environment_map`, written here), at SIZE pixels and two views (a repeat covering
VIEWS px at the nearest point of the garment: the weave's floats seen, and many repeats a
pixel):

- **neural against direct**: ``--mode neural`` at its default spp against ``--mode direct``
  at TRUTH_SPP (the one-bounce truth), both ``--fold off``: the garment's mean linear RGB
  (their ratio, and its worst channel) and the median CIE ΔE2000 over the garment's pixels
  (the images as an sRGB display shows them). Goal: within 2 % and ΔE ≤ 2 on every pair.
- **speed at equal error**: direct's time to reach the neural image's error against the truth
  (its MSE at CHECK_SPP, MSE ∝ 1/spp) over the neural image's time (renders only, both
  compiled first), and the default (adaptive) direct render's spp, time (the command's, bake
  and all) and error.
- **the fold term against path tracing** (the far view): ``--mode reference --max-depth 16``
  at PT_SPP against direct with ``--fold off`` and ``--fold on``; RMSE over the garment with
  each image's Monte-Carlo noise taken out (each rendered as two halves of different seeds:
  ``MSE − noise``, the noise from the halves' difference). Goal: fold on never farther than
  off, and ≥ 1.5× closer on the deep-fold garments.

The garment's pixels are those whose centre and four neighbours' centres see the mesh
(silhouettes left out: the neural renderer samples pixel centres, direct the pixel's area).
Each garment gets one fabric of :data:`FABRICS` in turn. ``python -m weavecap.bench.agreement
-o DIR`` also writes, per garment and light, direct | neural | |difference| × 4 side by side,
and keeps the reference images under DIR/references (a run with them there renders only what
is measured against them: delete them when the surface model, a garment or a setting changes).
"""

from __future__ import annotations

import math
import tempfile
import time
from pathlib import Path

import numpy as np

from ..fixtures import path as fixture_path

SIZE = (96, 72)
#: pixels a repeat covers at the garment's nearest point (close: up to MAX_PITCH_MM)
VIEWS = {"close": 40.0, "far": 0.5}
TRUTH_SPP = 256  # direct, the one-bounce truth (two halves)
PT_SPP = 256  # path tracing (two halves)
PT_DEPTH = 16
MAX_PITCH_MM = 100.0  # weavecap render's limit
CHECK_SPP = 16  # direct's error at this spp sets its spp to the neural error
FABRICS = ("twill_2_1", "satin_5", "plain", "basket_2_2", "custom_4x6", "twill_3_1")
QUICK = (("pleated_skirt", "sun"),)
MEAN_GOAL, DELTA_E_GOAL, FOLD_GAIN_GOAL = 0.02, 2.0, 1.5


def environment_map(path: Path, width: int = 128) -> Path:
    """An outdoor environment map (equirectangular, +y up, linear RGB ``.exr``): a sky bluer
    and brighter towards the zenith, a warm brown ground, a small bright sun 35° up."""
    from ..backend import mitsuba

    mi = mitsuba()
    height = width // 2
    theta = (np.arange(height) + 0.5) / height * math.pi  # from +y down
    phi = (np.arange(width) + 0.5) / width * 2 * math.pi
    th, ph = np.meshgrid(theta, phi, indexing="ij")
    up = np.cos(th)
    sky = np.where(up[..., None] > 0, np.array([0.35, 0.45, 0.65]) * (0.6 + 0.4 * up[..., None]),
                   np.array([0.16, 0.12, 0.08]))
    d = np.stack([np.sin(th) * np.cos(ph), np.cos(th), np.sin(th) * np.sin(ph)], -1)
    sun = np.array([math.cos(math.radians(35)) * math.cos(2.0), math.sin(math.radians(35)),
                    math.cos(math.radians(35)) * math.sin(2.0)])
    sky = sky + np.array([40.0, 36.0, 30.0]) * (d @ sun > math.cos(math.radians(4)))[..., None]
    mi.util.write_bitmap(str(path), mi.Bitmap(np.ascontiguousarray(sky, dtype=np.float32)), write_async=False)
    return path


def garment_mask(scene) -> np.ndarray:
    """(H, W) bool: pixels whose centre and 4-neighbours' centres see a shape of ``scene``
    (:func:`weavecap.render.run.surface_pixels`, less its edge)."""
    from ..render.run import surface_pixels

    hit = surface_pixels(scene)
    inner = hit.copy()
    inner[1:] &= hit[:-1]
    inner[:-1] &= hit[1:]
    inner[:, 1:] &= hit[:, :-1]
    inner[:, :-1] &= hit[:, 1:]
    inner[[0, -1]] = False
    inner[:, [0, -1]] = False
    return inner


def delta_e(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """CIE ΔE2000 (H, W) between linear RGB images as an sRGB display shows them."""
    from skimage.color import deltaE_ciede2000, rgb2lab

    from ..photo import linear_to_srgb

    def display(x):
        return linear_to_srgb(np.clip(x, 0.0, 1.0)).astype(np.float64)

    return deltaE_ciede2000(rgb2lab(display(a)), rgb2lab(display(b)))


def agreement(image: np.ndarray, truth: np.ndarray, mask: np.ndarray) -> dict:
    """The garment's mean ratio (RGB mean, worst channel) and median ΔE2000 of ``image`` against ``truth``."""
    mi_, mt = image[mask].mean(axis=0), truth[mask].mean(axis=0)
    ratio = mi_ / np.maximum(mt, 1e-12)
    return {"mean": mi_.tolist(), "truth_mean": mt.tolist(), "ratio": float(mi_.sum() / max(mt.sum(), 1e-12)),
            "worst_channel": float(ratio[np.argmax(np.abs(ratio - 1.0))]),
            "delta_e_median": float(np.median(delta_e(image, truth)[mask]))}


def biased_rmse(image_halves: tuple, truth_halves: tuple, mask: np.ndarray) -> float:
    """RMSE over ``mask`` between the means of two pairs of half images, each mean's own
    Monte-Carlo noise taken out: mean((a − t)²) − var(a) − var(t), each variance
    mean((h₁ − h₂)²) / 4 (0 for a deterministic image), floored at 0."""
    a = 0.5 * (image_halves[0] + image_halves[1])
    t = 0.5 * (truth_halves[0] + truth_halves[1])
    mse = float(np.mean(((a - t)[mask]) ** 2))
    noise = sum(float(np.mean(((h[0] - h[1])[mask]) ** 2)) / 4.0 for h in (image_halves, truth_halves))
    return math.sqrt(max(mse - noise, 0.0))


def bench_garments(quick: bool, folder: Path) -> list[tuple[str, Path, tuple, bool]]:
    """(name, OBJ path, view, deep folds?) of every garment (written to ``folder``), the towel
    of ``../shared/meshes`` when present."""
    from .render import SHARED_MESHES
    from ..render.garments import GARMENTS

    names = {g for g, _ in QUICK} if quick else set(GARMENTS)
    out = []
    for name, (make, view, deep) in GARMENTS.items():
        if name in names:
            path = folder / f"{name}.obj"
            path.write_text(make().obj_text(f"weavecap.render.garments.{make.__name__}()"))
            out.append((name, path, view, deep))
    towel = SHARED_MESHES / "towel.obj"
    if towel.is_file() and not quick:
        out.append(("towel", towel.resolve(), (0.0, 50.0), False))
    return out


def _pitch_for(fabric, mesh, options, pixels_per_repeat: float) -> float:
    """The yarn pitch (mm) at which one repeat covers ``pixels_per_repeat`` pixels at the
    mesh's nearest point in this view (at most ``--pitch-mm``'s limit)."""
    from ..render.scene import frame_camera

    camera = frame_camera(mesh.bounds, view=options.view, kind=options.camera, fov_deg=options.fov_deg,
                          margin=options.margin, size=options.size)
    return min(1000.0 * pixels_per_repeat * camera.pixel / max(fabric.shape), MAX_PITCH_MM)


def _halves(scene, spp: int, seed: int, keep: Path | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Two renders of ``spp`` / 2 samples, seeds ``seed`` and ``seed + 1``; read from ``keep``
    (an ``.npz``) when it holds them, else written there (the references cost most of the
    bench and do not change when a renderer under test does)."""
    from ..io import atomic_path
    from ..render.run import render_passes

    if keep is not None and keep.is_file():
        with np.load(keep, allow_pickle=False) as data:
            return data["a"], data["b"]
    out = tuple(render_passes(scene, spp // 2, seed + k).astype(np.float64) for k in (0, 1))
    if keep is not None:
        keep.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(keep) as tmp:
            with open(tmp, "wb") as fh:
                np.savez(fh, a=out[0], b=out[1])
    return out


def measure(fabric, mesh, light: str, view: tuple, *, fold: bool, progress=lambda m: None,
            keep: Path | None = None) -> dict:
    """Every figure of one garment and light (see the module docstring); ``keep``: a folder
    where the references (direct's truth, path tracing) are kept for a later run."""
    from dataclasses import replace

    from ..render import modes
    from ..render.run import RenderContext, RenderOptions, prepare_render, render_fabric, render_passes

    out = {"views": {}}
    images = {}
    base = RenderOptions(mode="direct", spp=TRUTH_SPP, size=SIZE, view=view, light=light, fold="off", seed=1)
    for name, pixels in VIEWS.items():
        options = replace(base, pitch_mm=_pitch_for(fabric, mesh, base, pixels))
        direct = prepare_render(fabric, mesh, options)
        mask = garment_mask(direct.scene)
        progress(f"truth: direct, {TRUTH_SPP} spp")
        truth_h = _halves(direct.scene, TRUTH_SPP, 1, keep and keep / f"{name}_direct_{TRUTH_SPP}.npz")
        truth = 0.5 * (truth_h[0] + truth_h[1])
        render_passes(direct.scene, CHECK_SPP, 7)  # compiled before it is timed
        t = time.perf_counter()
        check = render_passes(direct.scene, CHECK_SPP, 9).astype(np.float64)
        check_s = time.perf_counter() - t
        neural_options = replace(options, mode="neural", spp=modes.mode("neural").spp)
        neural_scene = prepare_render(fabric, mesh, neural_options).scene
        render_passes(neural_scene, neural_options.spp, 7)  # compiled before it is timed
        t = time.perf_counter()
        neural = render_passes(neural_scene, neural_options.spp, 9).astype(np.float64)
        neural_s = time.perf_counter() - t
        auto = render_fabric(fabric, mesh, replace(options, spp=None, seed=3))
        auto_image = auto.image.astype(np.float64)
        mse_neural = float(np.mean(((neural - truth)[mask]) ** 2))
        mse_check = float(np.mean(((check - truth)[mask]) ** 2))
        spp_to_neural = CHECK_SPP * mse_check / max(mse_neural, 1e-30)
        out["views"][name] = {
            "pixels_per_repeat": direct.info["pixels_per_yarn"] * max(fabric.shape), "pitch_mm": options.pitch_mm,
            "garment_pixels": int(mask.sum()),
            "neural": agreement(neural, truth, mask), "neural_seconds": neural_s, "neural_spp": neural_options.spp,
            "direct_check": agreement(check, truth, mask), "direct_check_seconds": check_s,
            "direct_spp_to_neural_error": spp_to_neural,
            "direct_seconds_to_neural_error": check_s * spp_to_neural / CHECK_SPP,
            "speedup_neural": check_s * spp_to_neural / CHECK_SPP / max(neural_s, 1e-9),
            "auto": {**agreement(auto_image, truth, mask), "spp": auto.info["spp"],
                     "seconds": auto.info["timings"]["total"]},
        }
        images[name] = {"direct": truth, "neural": neural, "mask": mask}
        if name == "far" and fold:
            progress(f"path tracing, {PT_SPP} spp")
            reference = prepare_render(fabric, mesh, replace(options, mode="reference", max_depth=PT_DEPTH, spp=16))
            pt_h = _halves(reference.scene, PT_SPP, 11, keep and keep / f"{name}_pt_{PT_DEPTH}_{PT_SPP}.npz")
            term = modes.fold_term("on", modes.mode("direct"), mesh)
            context = RenderContext(direct.scene, mesh, fabric, direct.maps, direct.camera, direct.lighting, options,
                                    np.zeros_like(truth, dtype=np.float32))
            t = time.perf_counter()
            fold_image, detail = term.apply(context)
            fold_s = time.perf_counter() - t
            fold_image = np.asarray(fold_image, np.float64)
            with_fold = tuple(h + fold_image for h in truth_h)
            off, on = biased_rmse(truth_h, pt_h, mask), biased_rmse(with_fold, pt_h, mask)
            pt = 0.5 * (pt_h[0] + pt_h[1])
            # None: both within the noise; "inf": on within it, off not
            gain = off / on if on > 0 else (None if off == 0 else "inf")
            out["fold"] = {"rmse_off": off, "rmse_on": on, "gain": gain, "seconds": fold_s,
                           "pt_mean": pt[mask].mean(axis=0).tolist(), "off_mean": truth[mask].mean(axis=0).tolist(),
                           "on_mean": (truth + fold_image)[mask].mean(axis=0).tolist(),
                           "vertices": detail["vertices"]["computed"] if detail else 0}
            images[name]["pt"] = pt
            images[name]["fold"] = truth + fold_image
    return out, images


def run(quick: bool = False, progress=None, folder: Path | None = None, on_row=None) -> list[dict]:
    """Every garment × light (``quick``: QUICK only); each row one (garment, light); ``on_row``
    is called with the rows so far after each (to keep them should the run be stopped)."""
    from .. import params
    from ..render.mesh import load_mesh
    from ..render.scene import LIGHTS

    say = progress or (lambda m: None)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        env = environment_map(tmp / "outdoor.exr")
        lights = list(LIGHTS) + [str(env)]
        for k, (name, path, view, deep) in enumerate(bench_garments(quick, tmp)):
            fabric_name = FABRICS[k % len(FABRICS)]
            fabric = params.load(fixture_path("params", f"{fabric_name}.json"))
            mesh = load_mesh(path)
            for light in lights:
                light_name = Path(light).name
                if quick and (name, light_name) not in QUICK:
                    continue
                say(f"render bench: agreement, {name} under {light_name} ({fabric_name}) ...")
                keep = Path(folder) / "references" / f"{name}_{light_name.split('.')[0]}" if folder else None
                row, images = measure(fabric, mesh, light, view, fold=True, keep=keep,
                                      progress=lambda m: say(f"render bench: agreement, {name}, {light_name}: {m}"))
                rows.append({"garment": name, "light": light_name, "fabric": fabric_name, "deep_folds": deep,
                             "view": list(view), **row})
                if folder is not None:
                    write_sheet(images, Path(folder) / f"{name}_{light_name.split('.')[0]}.png")
                if on_row is not None:
                    on_row(rows)
    return rows


def write_sheet(images: dict, path: Path) -> None:
    """A labelled contact sheet (:func:`weavecap.render.sheet.contact_sheet`): per view direct |
    neural | |neural − direct| × 4, and for the far view path tracing | direct + fold."""
    from ..render.sheet import contact_sheet

    cells, labels = [], []
    for view, im in images.items():
        cells += [im["direct"], im["neural"], np.abs(im["neural"] - im["direct"]) * 4.0]
        labels += [f"{view}: direct", f"{view}: neural", f"{view}: |diff| x4"]
        if "pt" in im:
            cells += [im["pt"], im["fold"]]
            labels += [f"{view}: path tracing", f"{view}: direct + fold"]
    contact_sheet(cells, labels).save(path)


def table(rows: list[dict]) -> str:
    """The markdown table: one line per garment, light and view."""
    lines = ["| garment | light | fabric | view (px/repeat) | neural / direct mean (worst channel) | ΔE2000 median | "
             "direct time to neural error / neural time | default direct: spp, ΔE2000, s | fold: RMSE vs PT "
             "off → on (gain) |", "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        for view, v in r["views"].items():
            fold = r.get("fold")
            fold_cell = (f"{fold['rmse_off']:.5f} → {fold['rmse_on']:.5f} ({_gain(fold)})" if fold and view == "far"
                         else "")
            n, a = v["neural"], v["auto"]
            lines.append(f"| {r['garment']}{' (deep)' if r['deep_folds'] else ''} | {r['light']} | {r['fabric']} | "
                         f"{view} ({v['pixels_per_repeat']:.2g}) | {n['ratio']:.3f} ({n['worst_channel']:.3f}) | "
                         f"{n['delta_e_median']:.2f} | {v['speedup_neural']:.2f}× | {a['spp']}, "
                         f"{a['delta_e_median']:.2f}, {a['seconds']:.1f} | {fold_cell} |")
    return "\n".join(lines)


def _gain(fold: dict) -> str:
    g = fold["gain"]
    return "both within the noise" if g is None else ("∞" if g == "inf" else f"{g:.2f}×")


def _gain_at_least(fold: dict, least: float) -> bool:
    """Whether the fold term's gain is at least ``least`` (both within the noise: not worse)."""
    g = fold["gain"]
    return (least <= 1.0) if g is None else (g == "inf" or g >= least)


def summary(rows: list[dict]) -> dict:
    """The goals, counted over the rows."""
    views = [(r, v) for r in rows for v in r["views"].values()]
    neural_ok = [abs(v["neural"]["worst_channel"] - 1.0) <= MEAN_GOAL and v["neural"]["delta_e_median"] <= DELTA_E_GOAL
                 for _, v in views]
    folds = [r["fold"] for r in rows if "fold" in r]
    deep = [r["fold"] for r in rows if "fold" in r and r["deep_folds"]]
    return {"neural_within_goal": f"{sum(neural_ok)} of {len(neural_ok)}",
            "fold_never_worse": f"{sum(_gain_at_least(f, 1.0) for f in folds)} of {len(folds)}",
            "fold_deep_gain_1_5": f"{sum(_gain_at_least(f, FOLD_GAIN_GOAL) for f in deep)} of {len(deep)}",
            "speedup_median": float(np.median([v["speedup_neural"] for _, v in views])) if views else None}


def section_table(rows: list[dict]) -> str:
    """:func:`table` and the goals' counts under it."""
    goals = summary(rows)
    return (table(rows) + f"\n\nneural within {MEAN_GOAL:.0%} and ΔE2000 ≤ {DELTA_E_GOAL:g}: "
            f"{goals['neural_within_goal']}; fold term never farther from path tracing: {goals['fold_never_worse']}; "
            f"≥ {FOLD_GAIN_GOAL}× closer on the deep folds: {goals['fold_deep_gain_1_5']}")


def _register() -> None:
    from .render import Section, register_section

    register_section(Section("agreement", "Garments and lights never trained on: neural against direct, the fold "
                                          "term against path tracing", run, section_table))


_register()


def main(argv: list[str] | None = None) -> None:
    """``python -m weavecap.bench.agreement [-o DIR] [--quick]``: the section, its sheets
    and ``agreement.json`` written to DIR, the table printed."""
    import argparse
    import json
    import sys

    from ..io import atomic_write_text

    parser = argparse.ArgumentParser(prog="python -m weavecap.bench.agreement")
    parser.add_argument("-o", "--output", type=Path, default=Path("bench-out/agreement"))
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args(argv)
    args.output.mkdir(parents=True, exist_ok=True)
    def keep(rows):
        atomic_write_text(args.output / "agreement.json", json.dumps({"rows": rows, "summary": summary(rows)}, indent=1)
                          + "\n")

    rows = run(args.quick, lambda m: print(m, file=sys.stderr, flush=True), folder=args.output, on_row=keep)
    print(table(rows))
    print(json.dumps(summary(rows), indent=1))


if __name__ == "__main__":
    main()
