"""The fold renderer's section of ``weavecap bench --render``: error against LocalPT and PT, time.

Every image is ``weavecap render`` of one fabric (:data:`FABRIC`, a light satin, so that folds
return much light) under the ``sun`` light (a directional sun and a uniform sky), seen from a
view that looks into the folds, at :data:`SIZE`:

- *direct*: ``--mode direct --fold off`` at :data:`REF_SPP`;
- *direct + fold*: the same with the fold term (``--fold on``: the image above plus the term);
- *LocalPT*: the direct image plus LocalPT's local inter-reflection alone
  (:mod:`.localpt`, ``direct=False``, same r) at :data:`REF_SPP` — so the direct light is the
  same in both and the errors are the fold term's (LocalPT's bounces treat the fabric as opaque:
  its gaps' null transmission is not followed there);
- *PT*: ``--mode reference --max-depth 16`` at :data:`REF_SPP`, what a user compares with.

RMSE is taken over the garment's pixels (linear radiance). LocalPT's local light is rendered as
two halves of :data:`REF_SPP` / 2 samples with different seeds: their mean is the reference and
half their RMS difference the reference's own noise (an RMSE against it cannot go below that).
*Equal time*: LocalPT (direct + local) at the largest spp that renders within the time of
direct at :data:`SPP` + the fold term, both against the reference — a race the direct light's
noise decides, the same in both. So also *the local light at equal time*: the reference's
direct image plus the fold term, against it plus LocalPT's local light at the spp that renders
in the fold term's time. Both sides are timed by one rule (:func:`race`, :func:`steady_times`),
on the same scene: after an untimed call of each (their kernels compiled), in rounds of one
call of each in turn — our direct render at :data:`SPP`, the fold term, LocalPT's direct and
local renders at :data:`SPP` — until every part's last two timings agree within
:data:`AGREE` (at most :data:`ROUNDS` rounds, else their median); LocalPT's spp are those
seconds per spp into our seconds, and its render at them is timed too (recorded beside ours).
The rows keep every timing. *Seen* meshes are the *Seen* meshes are the
fixture meshes of the shapes trained on (at the fixtures' own, coarser tessellation);
*unseen*: the towel of ``../shared/meshes`` (without the head under it) and
:func:`weavecap.render.garments.crumpled_sheet`, folds in random directions.

The frame (:func:`frame_time`), on the towel and the skirt: one 1280×720 direct render at
:data:`SPP`, without and with the fold term, in one process (as a user runs it, compiles and
all: the frame ratio); and the equal-time comparison again at that size (the same rule) (where the fold term's per-vertex cost is small against the frame's), against
a reference of :data:`FRAME_REF_SPP`.

The default run keeps to minutes: five seen and two unseen meshes at 192×108 (``quick``: one
of each).
"""

from __future__ import annotations

import math
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..fixtures import path as fixture_path
from .render import SHARED_MESHES
from ..render.garments import crumpled_sheet

FABRIC = fixture_path("params", "satin_5.json")
LIGHT = "sun"
SIZE = (192, 108)
REF_SPP = 4096
FRAME_REF_SPP = 512
FRAME_SIZE = (1280, 720)
SPP = 64
PT_DEPTH = 16
SEEN = {"sine_high": (0.0, 35.0), "horseshoe_narrow": (0.0, 30.0), "wave": (20.0, 40.0), "skirt": (30.0, 10.0),
        "drape": (30.0, 30.0)}
UNSEEN = {"towel": (0.0, 50.0), "crumpled": (20.0, 45.0)}
QUICK = ("sine_high", "crumpled")
AGREE = 0.10  # an equal-time race's timings are steady when two in a row agree within this share of their mean
ROUNDS = 5  # timed rounds at most (then the median)


def bench_meshes(quick: bool, folder: Path) -> list[tuple[str, Path, tuple, bool]]:
    """(name, path, view, seen) of every mesh measured."""
    out = []
    for name, view in SEEN.items():
        if not quick or name in QUICK:
            out.append((name, fixture_path("meshes", f"{name}.obj"), view, True))
    towel = SHARED_MESHES / "towel.obj"
    if towel.is_file() and not quick:
        out.append(("towel", towel.resolve(), UNSEEN["towel"], False))
    path = folder / "crumpled.obj"
    path.write_text(crumpled_sheet().obj_text("weavecap.render.garments.crumpled_sheet()"))
    out.append(("crumpled", path, UNSEEN["crumpled"], False))
    return out


def _localpt_mode(radius: float):
    """A render mode of the surface model through LocalPT's local inter-reflection alone."""
    from ..render.modes import MODES, Mode
    from ..render.fold import localpt  # noqa: F401  (registers "localpt")

    return Mode("fold-localpt", "LocalPT, local inter-reflection only", bsdf=MODES["direct"].bsdf,
                integrator=lambda lighting, options: {"type": "localpt", "radius": float(radius), "direct": False,
                                                      "max_depth": PT_DEPTH, "rr_depth": 5})


def _localpt_scene(fabric, mesh, options, radius: float):
    """``weavecap render``'s scene of ``options`` with LocalPT's local inter-reflection as its integrator."""
    from ..render import modes
    from ..render.run import prepare_render

    modes.register_mode(_localpt_mode(radius))
    try:
        return prepare_render(fabric, mesh, replace(options, mode="fold-localpt")).scene
    finally:
        modes.MODES.pop("fold-localpt", None)


def steady_times(parts: dict, *, agree: float = AGREE, rounds: int = ROUNDS, clock=time.perf_counter):
    """Warm, steady timings of the callables ``parts`` ({label: fn()}), the same rule for each.

    One untimed round compiles their kernels; then rounds of one call of each part in turn (so
    every part sees the same load of the shared machine, which moved the same 1280×720 kernel
    between 2.5 and 5 s within minutes), until each part's last two timings agree within
    ``agree`` of their mean, at most ``rounds`` rounds. A part's seconds: the mean of its last
    two timings where they agreed, else the median of all of them. Returns (seconds {label: s},
    timings {label: [s, ...]}, last results {label: fn()})."""
    out = {label: fn() for label, fn in parts.items()}
    timings = {label: [] for label in parts}

    def settled(ts):
        return len(ts) >= 2 and abs(ts[-1] - ts[-2]) <= agree * (ts[-1] + ts[-2]) / 2

    for _ in range(rounds):
        for label, fn in parts.items():
            t = clock()
            out[label] = fn()
            timings[label].append(clock() - t)
        if all(settled(ts) for ts in timings.values()):
            break
    seconds = {label: (ts[-1] + ts[-2]) / 2 if settled(ts) else float(np.median(ts)) for label, ts in timings.items()}
    return seconds, timings, out


def _in_time(budget: float, scenes, seconds_per_spp: float, seed: int, announce=lambda spp: None):
    """The sum of ``scenes``' renders at the largest spp that fits in ``budget`` seconds at
    ``seconds_per_spp`` (their steady rate, :func:`steady_times`; at least 1 spp): (image
    (H, W, 3) float64, spp, seconds taken). A last pass of fewer samples than ``run.PASS_SPP``
    is another kernel: it is compiled before the render is timed (crumpled sheet, 69 spp, 1.3 s
    cold against 0.4 s warm)."""
    from ..render.run import PASS_SPP, render_passes

    spp = max(1, int(budget / seconds_per_spp))
    announce(spp)
    if spp % PASS_SPP:
        for scene in scenes:
            render_passes(scene, spp % PASS_SPP, seed + 2000)
    t = time.perf_counter()
    image = sum(render_passes(scene, spp, seed).astype(np.float64) for scene in scenes)
    return image, spp, time.perf_counter() - t


def race(scene, local_scene, mesh, seed: int, progress=lambda m: None, label: str = "") -> dict:
    """Both equal-time races on one scene, timed by :func:`steady_times` in one set of rounds:
    ours (direct at :data:`SPP` on ``scene``, the fold term) and LocalPT's two renders at
    :data:`SPP` (its direct light on ``scene``, its local light on ``local_scene``), whose
    seconds per spp set the spp LocalPT gets: in the time of direct + fold for the whole image,
    in the fold term's time for the local light alone. Returns the images (ours: direct at SPP
    and the fold term, seeds ``seed`` and 1; LocalPT's: direct + local, local alone, seeds
    ``seed`` + 1, + 2), the spp, and every timing."""
    from ..render.run import render_passes
    from ..render.fold import term

    seconds, timings, out = steady_times({
        "direct": lambda: render_passes(scene, SPP, seed),
        "fold": lambda: term.fold_light(scene, mesh, seed=1)[0],
        "localpt_direct": lambda: render_passes(scene, SPP, seed + 1000),
        "localpt_local": lambda: render_passes(local_scene, SPP, seed + 1000)})
    budget = seconds["direct"] + seconds["fold"]
    eq, k, t_eq = _in_time(budget, (scene, local_scene), (seconds["localpt_direct"] + seconds["localpt_local"]) / SPP,
                           seed + 1, lambda k: progress(f"fold bench: {label}LocalPT at equal time ({k} spp)"))
    local, k_local, t_local = _in_time(
        seconds["fold"], (local_scene,), seconds["localpt_local"] / SPP, seed + 2,
        lambda k: progress(f"fold bench: {label}LocalPT's local light in the fold term's time ({k} spp)"))
    return {"direct": out["direct"].astype(np.float64), "fold": out["fold"].astype(np.float64), "localpt": eq,
            "localpt_local": local, "seconds": seconds, "timings": timings, "budget": budget, "spp": k,
            "seconds_localpt": t_eq, "spp_local": k_local, "seconds_local": t_local}


def _race_cells(r: dict) -> dict:
    """The timings an equal-time row records: the steady seconds and every timing they came from."""
    return {"steady_seconds": r["seconds"], "timings": r["timings"]}


def _render(fabric, mesh, options):
    from ..render.run import render_fabric

    t = time.perf_counter()
    result = render_fabric(fabric, mesh, options)
    return result.image.astype(np.float64), time.perf_counter() - t, result.info


def _timed(fn, *args, **kwargs):
    t = time.perf_counter()
    out = fn(*args, **kwargs)
    return out, time.perf_counter() - t


def garment_mask(*images: np.ndarray) -> np.ndarray:
    """Pixels of the garment: those not equal to the background (the sky a camera ray meets
    unchanged, the same in every image), which is the most common value of the first image."""
    flat = images[0].reshape(-1, 3)
    values, counts = np.unique(np.round(flat, 7), axis=0, return_counts=True)
    background = values[np.argmax(counts)]
    return np.any(np.abs(np.round(images[0], 7) - background) > 0, axis=2)


def rmse(a: np.ndarray, b: np.ndarray, mask: np.ndarray) -> float:
    return float(np.sqrt(np.mean((a[mask] - b[mask]) ** 2)))


def measure_mesh(name: str, path: Path, view, seen: bool, *, folder: Path, progress=None) -> dict:
    """Every image and error of one mesh (see the module docstring)."""
    from .. import params
    from ..render.mesh import load_mesh
    from ..render.run import RenderOptions, prepare_render, render_passes
    from ..render.fold import term
    from ..render.fold.descriptors import cached_descriptors

    say = progress or (lambda m: None)
    fabric = params.load(FABRIC)
    mesh = load_mesh(path)
    desc, radius, _ = cached_descriptors(mesh.positions, mesh.faces, normals=mesh.normals)
    base = RenderOptions(mode="direct", spp=REF_SPP, size=SIZE, view=view, light=LIGHT, fold="off", seed=1)
    scene = prepare_render(fabric, mesh, base).scene
    say(f"fold bench: {name}: direct, fold term")
    direct, t_direct = _timed(render_passes, scene, REF_SPP, 1)
    (fold, info), t_fold = _timed(term.fold_light, scene, mesh, seed=1)
    (fold_k4, _), t_fold_k4 = _timed(term.fold_light, scene, mesh, seed=1, neighbours=4)
    fold_asg = None
    if seen:
        garment = term.garment_of(scene)
        asg, t_asg_fit = _timed(term.mesh_asg, scene, garment, mesh.positions, mesh.faces, desc)
        (fold_asg, _), t_fold_asg = _timed(term.fold_light, scene, mesh, seed=1, asg=asg)
    local_scene = _localpt_scene(fabric, mesh, base, radius.value)
    say(f"fold bench: {name}: LocalPT")
    # two halves of different seeds: their mean is the reference, their difference its own noise
    (half_a, t_a), (half_b, t_b) = (_timed(render_passes, local_scene, REF_SPP // 2, s) for s in (1, 2))
    local, t_local = (half_a + half_b) / 2, t_a + t_b
    say(f"fold bench: {name}: PT")
    pt_scene = prepare_render(fabric, mesh, replace(base, mode="reference", max_depth=PT_DEPTH)).scene
    pt, t_pt = _timed(render_passes, pt_scene, REF_SPP, 1)
    say(f"fold bench: {name}: equal time")
    eq = race(scene, local_scene, mesh, 2, say, f"{name}: ")
    reference = direct + local
    mask = garment_mask(direct, pt)
    errors = {"direct": rmse(direct, reference, mask), "direct_fold": rmse(direct + fold, reference, mask),
              "direct_fold_k4": rmse(direct + fold_k4, reference, mask)}
    if fold_asg is not None:
        errors["direct_fold_asg"] = rmse(direct + fold_asg, reference, mask)
    row = {
        "mesh": name, "seen": seen, "vertices": int(len(mesh.positions)), "view": list(view),
        "radius_m": radius.value, "pixels": int(mask.sum()),
        "folded_share": float(desc.folded.any(axis=1).mean()),
        "local_rms": float(np.sqrt(np.mean(local[mask] ** 2))),
        "reference_noise": rmse(half_a, half_b, mask) / 2,  # RMS noise of the LocalPT reference (mean of halves)
        "rmse_localpt": errors,
        "rmse_pt": {"direct": rmse(direct, pt, mask), "direct_fold": rmse(direct + fold, pt, mask)},
        "equal_time": {"spp_fold": SPP, "seconds_fold": eq["budget"], "spp_localpt": eq["spp"],
                       "seconds_localpt": eq["seconds_localpt"], "rmse_fold": rmse(eq["direct"] + eq["fold"], reference, mask),
                       "rmse_localpt": rmse(eq["localpt"], reference, mask), **_race_cells(eq)},
        "local_equal_time": {"seconds_fold": eq["seconds"]["fold"], "spp_localpt": eq["spp_local"],
                             "seconds_localpt": eq["seconds_local"], "rmse_fold": errors["direct_fold"],
                             "rmse_localpt": rmse(direct + eq["localpt_local"], reference, mask)},
        "seconds": {"direct": t_direct, "fold": t_fold, "fold_warm": eq["seconds"]["fold"],
                    "direct_fast": eq["seconds"]["direct"],
                    "fold_k4": t_fold_k4, "localpt": t_local, "pt": t_pt,
                    **({"asg_fit": t_asg_fit, "fold_asg": t_fold_asg} if seen else {})},
        "fold_detail": info,
    }
    np.savez_compressed(folder / f"{name}.npz", direct=direct.astype(np.float32),
                        fold=(direct + fold).astype(np.float32), localpt=reference.astype(np.float32),
                        pt=pt.astype(np.float32), mask=mask)
    return row


def frame_time(name: str, path: Path, view, *, progress=None) -> dict:
    """One 1280×720 direct frame at :data:`SPP`, without and with the fold term, each
    ``render_fabric`` in this process as a user runs it (compiles and all, after a 16-spp frame
    of each); then, at that size, direct + fold against LocalPT at equal time (:func:`race`, warm
    and steady), both against direct + LocalPT's local light at :data:`FRAME_REF_SPP`."""
    from .. import params
    from ..render.mesh import load_mesh
    from ..render.run import PASS_SPP, RenderOptions, prepare_render, render_passes
    from ..render.fold.descriptors import cached_descriptors

    fabric = params.load(FABRIC)
    mesh = load_mesh(path)
    options = RenderOptions(mode="direct", spp=SPP, size=FRAME_SIZE, view=view, light=LIGHT, fold="off", seed=1)
    say = progress or (lambda m: None)
    say(f"fold bench: {name}: 1280×720 frame")
    for fold in ("off", "on"):  # compile every kernel first: passes of PASS_SPP, with and without the fold attributes
        _render(fabric, mesh, replace(options, spp=PASS_SPP, fold=fold))
    _, _, info_off = _render(fabric, mesh, options)
    _, _, info_on = _render(fabric, mesh, replace(options, fold="on"))
    fold = info_on["timings"]["fold"]
    scene = prepare_render(fabric, mesh, options).scene
    local_scene = _localpt_scene(fabric, mesh, options, cached_descriptors(mesh.positions, mesh.faces,
                                                                           normals=mesh.normals)[1].value)
    say(f"fold bench: {name}: 1280×720 reference ({FRAME_REF_SPP} spp)")
    direct = render_passes(scene, FRAME_REF_SPP, 11).astype(np.float64)
    reference = direct + render_passes(local_scene, FRAME_REF_SPP, 11)
    say(f"fold bench: {name}: 1280×720 equal time")
    eq = race(scene, local_scene, mesh, 12, say, f"{name}: 1280×720 ")
    mask = garment_mask(direct)
    return {"mesh": name, "frame_seconds": info_off["timings"]["total"], "fold_seconds": fold,
            "ratio": fold / info_off["timings"]["total"], "render_seconds": info_off["timings"]["render"],
            "warm_ratio": eq["seconds"]["fold"] / eq["seconds"]["direct"],
            "fold_detail": info_on["fold_detail"],
            "equal_time": {"spp_fold": SPP, "seconds_fold": eq["budget"], "spp_localpt": eq["spp"],
                           "seconds_localpt": eq["seconds_localpt"], "reference_spp": FRAME_REF_SPP,
                           "rmse_fold": rmse(eq["direct"] + eq["fold"], reference, mask),
                           "rmse_localpt": rmse(eq["localpt"], reference, mask), **_race_cells(eq)},
            "local_equal_time": {"seconds_fold": eq["seconds"]["fold"], "spp_localpt": eq["spp_local"],
                                 "seconds_localpt": eq["seconds_local"],
                                 "rmse_fold": rmse(direct + eq["fold"], reference, mask),
                                 "rmse_localpt": rmse(direct + eq["localpt_local"], reference, mask),
                                 "rmse_direct": rmse(direct, reference, mask)}}


def run(quick: bool = False, progress=None, folder: Path | None = None) -> dict:
    """Every mesh's row, and the frame times."""
    folder = Path(folder) if folder is not None else Path(tempfile.mkdtemp(prefix="weavecap-fold-bench-"))
    folder.mkdir(parents=True, exist_ok=True)
    rows = [measure_mesh(name, path, view, seen, folder=folder, progress=progress)
            for name, path, view, seen in bench_meshes(quick, folder)]
    frames = []
    towel = SHARED_MESHES / "towel.obj"
    for name, path, view in ([("towel", towel, UNSEEN["towel"])] if towel.is_file() else []) + \
            ([] if quick else [("skirt", fixture_path("meshes", "skirt.obj"), SEEN["skirt"])]):
        frames.append(frame_time(name, path, view, progress=progress))
    return {"meshes": rows, "frames": frames, "folder": str(folder)}


def summary(result: dict) -> dict:
    """The done-when figures: ratios per mesh, seen and unseen means, the frame time ratio."""
    rows = result["meshes"]

    def mean(key, seen):
        vals = [key(r) for r in rows if r["seen"] == seen]
        return float(np.mean(vals)) if vals else math.nan

    return {
        "gain_over_direct": {r["mesh"]: r["rmse_localpt"]["direct"] / max(r["rmse_localpt"]["direct_fold"], 1e-12)
                             for r in rows},
        "closer_to_pt": {r["mesh"]: r["rmse_pt"]["direct_fold"] < r["rmse_pt"]["direct"] for r in rows},
        "beats_localpt_equal_time": {r["mesh"]: r["equal_time"]["rmse_fold"] < r["equal_time"]["rmse_localpt"]
                                     for r in rows},
        "seen_rmse": mean(lambda r: r["rmse_localpt"]["direct_fold"], True),
        "unseen_rmse": mean(lambda r: r["rmse_localpt"]["direct_fold"], False),
        "seen_relative": mean(lambda r: r["rmse_localpt"]["direct_fold"] / r["local_rms"], True),
        "unseen_relative": mean(lambda r: r["rmse_localpt"]["direct_fold"] / r["local_rms"], False),
        "frame_ratio": {f["mesh"]: f["ratio"] for f in result["frames"]},
        "frame_ratio_warm": {f["mesh"]: f["warm_ratio"] for f in result["frames"]},
        "beats_localpt_equal_time_1280x720": {f["mesh"]: f["equal_time"]["rmse_fold"] < f["equal_time"]["rmse_localpt"]
                                              for f in result["frames"]},
        "beats_localpt_local_light_equal_time": {
            r["mesh"]: r["local_equal_time"]["rmse_fold"] < r["local_equal_time"]["rmse_localpt"]
            for r in rows + [dict(f, mesh=f"{f['mesh']} 1280x720") for f in result["frames"]]},
    }


def table(result: dict) -> str:
    """Markdown: per mesh, then the supplement's Tables 3 and 6 in our terms, then frame time."""
    rows = result["meshes"]
    s = summary(result)
    lines = ["| mesh | seen | r (mm) | local light RMS | its noise | RMSE vs LocalPT: direct | direct + fold | gain | "
             "RMSE vs PT: direct | direct + fold | equal time: fold (spp, s) | LocalPT (spp, s) | local light at equal time: "
             "fold term (s) | LocalPT (spp) |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        e, p, q = r["rmse_localpt"], r["rmse_pt"], r["equal_time"]
        lines.append(f"| {r['mesh']} | {'yes' if r['seen'] else 'no'} | {r['radius_m'] * 1000:.0f} | "
                     f"{r['local_rms']:.5f} | {r['reference_noise']:.5f} | {e['direct']:.5f} | {e['direct_fold']:.5f} | "
                     f"{e['direct'] / max(e['direct_fold'], 1e-12):.2f}× | {p['direct']:.5f} | {p['direct_fold']:.5f} | "
                     + _equal_cells(q) + " | " + _local_cells(r["local_equal_time"]) + " |")
    lines += ["", "Table 3 form (architecture):", "",
              "| Architecture | Representation | Seen RMSE | Unseen RMSE | Time (s) | Params |", "|---|---|---|---|---|---|"]
    times = [r["seconds"]["fold"] for r in rows]
    params = next((r["fold_detail"]["weights_parameters"] for r in rows if r["fold_detail"]), 0)
    lines.append(f"| Factorized | SH (3 bands) | {s['seen_rmse']:.5f} | {s['unseen_rmse']:.5f} | "
                 f"{np.mean(times):.2f} | {params / 1000:.1f}K |")
    seen_direct = np.mean([r["rmse_localpt"]["direct"] for r in rows if r["seen"]])
    unseen_direct = np.mean([r["rmse_localpt"]["direct"] for r in rows if not r["seen"]])
    lines.append(f"| (direct lighting alone) | — | {seen_direct:.5f} | {unseen_direct:.5f} | — | — |")
    lines += ["", f"Unseen / seen RMSE: {s['unseen_rmse'] / s['seen_rmse']:.2f} (absolute), "
                  f"{s['unseen_relative'] / s['seen_relative']:.2f} (relative to each mesh's local light)"]
    lines += ["", "Table 6 form (visibility):", "", "| Method | Configuration | Seen/Unseen | RMSE | Time (s) |",
              "|---|---|---|---|---|"]

    neighbours = next((r["fold_detail"]["neighbours"] for r in rows if r["fold_detail"]), "?")  # what the run used

    def mean_of(key, seen, seconds):
        sel = [r for r in rows if r["seen"] == seen and key in r["rmse_localpt"]]
        if not sel:
            return None
        return (np.mean([r["rmse_localpt"][key] for r in sel]), np.mean([r["seconds"][seconds] for r in sel]))

    for label, config, key, seconds in (("ASG (fitted)", "2 lobes", "direct_fold_asg", "fold_asg"),
                                        ("Sampling", "4 view samples", "direct_fold_k4", "fold_k4"),
                                        ("Sampling", f"{neighbours} view samples", "direct_fold", "fold")):
        for seen in (True, False):
            got = mean_of(key, seen, seconds)
            if got is not None:
                lines.append(f"| {label} | {config} | {'Seen' if seen else 'Unseen'} | {got[0]:.5f} | {got[1]:.2f} |")
    lines += ["", f"| {FRAME_SIZE[0]}×{FRAME_SIZE[1]} frame | direct, {SPP} spp (s) | fold term (s) | ratio | RMSE vs LocalPT ({FRAME_REF_SPP} "
                  "spp): direct | equal time: direct + fold (spp, s) | LocalPT (spp, s) | local light at equal time: "
                  "fold term (s) | LocalPT (spp) |", "|---|---|---|---|---|---|---|---|---|"]
    for f in result["frames"]:
        q, e = f["equal_time"], f["local_equal_time"]
        lines.append(f"| {f['mesh']} | {f['frame_seconds']:.1f} | {f['fold_seconds']:.2f} | {f['ratio'] * 100:.0f} % | "
                     f"{e['rmse_direct']:.5f} | {_equal_cells(q)} | {_local_cells(e)} |")
    return "\n".join(lines)


def _equal_cells(q: dict) -> str:
    """Two table cells: each side's RMSE at equal time (its spp, the seconds it took)."""
    return (f"{q['rmse_fold']:.5f} ({q['spp_fold']}, {q['seconds_fold']:.2f} s) | "
            f"{q['rmse_localpt']:.5f} ({q['spp_localpt']}, {q['seconds_localpt']:.2f} s)")


def _local_cells(q: dict) -> str:
    """Two table cells: the fold term's RMSE (its seconds), LocalPT's in that time (its spp)."""
    return f"{q['rmse_fold']:.5f} ({q['seconds_fold']:.2f} s) | {q['rmse_localpt']:.5f} ({q['spp_localpt']})"


def _register() -> None:
    """Add this section to ``weavecap bench --render`` (which imports this module)."""
    from .render import Section, register_section

    register_section(Section("fold", f"Fold renderer against LocalPT and PT ({SIZE[0]}×{SIZE[1]}, {REF_SPP} spp, "
                                     f"{LIGHT} light)", run, table))



def picture(folder: Path, names: list[str], out: Path) -> Path:
    """A PNG of one row per mesh: direct | direct + fold | LocalPT | PT, each row at one exposure
    (its PT's 99th percentile on the garment to 0.9); then the fold term and LocalPT's local
    light alone, both at one brighter exposure (their row's local light's 99th percentile to
    0.9, the gain written under them): the light the fold term adds is a few percent of the
    direct light, too little to see beside it. Labelled."""
    from PIL import Image, ImageDraw

    from ..io import atomic_path
    from ..photo import linear_to_srgb

    labels = ("direct", "direct + fold", "LocalPT", "PT", "fold term", "LocalPT local")
    rows = [np.load(Path(folder) / f"{name}.npz") for name in names]
    h, w = rows[0]["direct"].shape[:2]
    gap, label = 4, 14
    sheet = Image.new("RGB", (6 * w + 7 * gap, len(rows) * (h + label + gap) + gap), (24, 24, 24))
    draw = ImageDraw.Draw(sheet)
    for r, (name, data) in enumerate(zip(names, rows)):
        mask = data["mask"]
        scale = 0.9 / max(float(np.percentile(data["pt"][mask], 99)), 1e-6)
        local = data["localpt"] - data["direct"]
        gain = 0.9 / max(float(np.percentile(local[mask], 99)), 1e-9)
        images = (data["direct"] * scale, data["fold"] * scale, data["localpt"] * scale, data["pt"] * scale,
                  (data["fold"] - data["direct"]) * gain, local * gain)
        for c, image in enumerate(images):
            x, y = gap + c * (w + gap), gap + r * (h + label + gap)
            srgb = linear_to_srgb(np.clip(image, 0.0, 1.0))
            sheet.paste(Image.fromarray(np.clip(np.round(srgb * 255), 0, 255).astype(np.uint8)), (x, y))
            text = f"{name}: {labels[c]}" if c == 0 else labels[c] + (f" (x{gain / scale:.0f})" if c >= 4 else "")
            draw.text((x + 2, y + h + 1), text, fill=(230, 230, 230))
    with atomic_path(out) as tmp:
        sheet.save(tmp, format="PNG")
    return out


USAGE = """usage: python -m weavecap.bench.fold OUT [--quick]

The fold renderer's section of `weavecap bench --render` alone: every mesh against LocalPT and PT
at 192x108 (4096 spp), equal time, and the 1280x720 frames; writes OUT/fold.json, OUT/fold.md,
OUT/fold.png and the images under OUT/images. --quick: one seen and one unseen mesh.

example: nice -n 5 python -m weavecap.bench.fold /tmp/fold-bench"""


def main(argv: list[str] | None = None) -> None:
    """``python -m weavecap.bench.fold OUT [--quick]``: this section alone, as ``weavecap
    bench --render`` runs it; writes OUT/fold.json, OUT/fold.md and OUT/fold.png."""
    import json
    import sys

    from ..io import atomic_write_text

    args = list(sys.argv[1:] if argv is None else argv)
    quick = "--quick" in args
    folders = [a for a in args if not a.startswith("-")]
    if "-h" in args or "--help" in args or len(folders) != 1 or set(args) - {*folders, "--quick"}:
        print(USAGE, file=sys.stdout if "-h" in args or "--help" in args else sys.stderr)
        raise SystemExit(0 if "-h" in args or "--help" in args else 2)
    out = Path(folders[0])
    out.mkdir(parents=True, exist_ok=True)
    result = run(quick, progress=lambda m: print(m, file=sys.stderr, flush=True), folder=out / "images")
    atomic_write_text(out / "fold.json", json.dumps({**result, "summary": summary(result)}, indent=1) + "\n")
    atomic_write_text(out / "fold.md", table(result) + "\n")
    shown = [r["mesh"] for r in result["meshes"] if r["mesh"] in ("sine_high", "skirt", "towel", "crumpled")]
    picture(out / "images", shown or [result["meshes"][0]["mesh"]], out / "fold.png")
    print(table(result))


_register()

if __name__ == "__main__":
    main()
