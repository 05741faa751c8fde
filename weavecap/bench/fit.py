"""The speed–accuracy bench of ``weavecap fit``: photos with known truth,
fitted at each quality preset, from two sources.

The bench set is fixed by a seed: fabrics over Table 1 (:mod:`weavecap.estimate.sampling`)
with plain, twill, satin 5 and 8, basket and random patterns up to 8×8, rendered by the
forward model at about one megapixel with the yarn pitch between 24 and 40 px, turned by up to
±15°, seen by a perspective camera (mild), with sensor noise and saved as JPEG (quality 90).
Each photo is captured end to end (:func:`weavecap.pipeline.capture`) and compared with its
truth: the pattern up to a cyclic shift, the re-render's PSNR against the regularized photo,
the error of every continuous parameter relative to its Table 1 range, plies and fibres — and
which continuous parameters the photo determines (standard error ≤ 5% of the range at the fit,
:mod:`weavecap.fit.uncertainty`), the ones the accuracy figures are about.

That set cannot show model mismatch: its photos come from the model that fits them. The
*independent* set (:func:`make_independent_photos`) comes from
:mod:`weavecap.bench.heightfield_photos`, which shares no code with the forward model: height-field
yarns with their own shading, exposure and white balance off. Its truth is the pattern (face
and direction included); every photo of both sets is also scored by the fidelity figures of
:mod:`weavecap.fit.fidelity` (sharpness, each family's ΔE2000, structure correlation) between
the photo's repeat and the fit's render.
"""

from __future__ import annotations

import statistics
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..params import CONTINUOUS_KEYS, FIT_RANGES, Fabric

PHOTO_SIDE_PX = 1024
FAMILIES = ("plain", "twill", "satin5", "satin8", "basket", "random", "twill", "random")
QUICK_FAMILIES = ("plain", "twill", "random")


SETS = ("own", "independent")


@dataclass(frozen=True)
class BenchPhoto:
    """A bench photo and its truth: the whole fabric (own renders) or only its pattern
    (independent photos, ``truth`` None)."""

    path: Path
    truth: Fabric | None
    family: str
    rotate_deg: float
    pattern: np.ndarray | None = None
    set: str = "own"

    @property
    def true_pattern(self) -> np.ndarray:
        return self.truth.pattern if self.truth is not None else self.pattern


def make_photos(folder: Path, *, quick: bool, seed: int = 2026) -> list[BenchPhoto]:
    """Render the bench set into ``folder`` (JPEG files)."""
    import cv2

    from ..estimate.sampling import random_fabric, random_pattern, satin
    from ..model.render import render_numpy
    from ..model.scene import View, build_scene
    from ..photo import linear_to_srgb

    rng = np.random.default_rng(seed)
    photos = []
    for k, family in enumerate(QUICK_FAMILIES if quick else FAMILIES):
        if family.startswith("satin"):
            n = int(family[-1])
            pattern, family = satin(n, 2 if n == 5 else 3), f"satin {n}"
        else:
            _, pattern = random_pattern(rng, family=family, max_size=8)
        truth = random_fabric(rng, pattern)
        pitch = rng.uniform(24, 40)
        n_e, n_a = pattern.shape
        tiles = (max(2, round(PHOTO_SIDE_PX / (pitch * n_e))), max(2, round(PHOTO_SIDE_PX / (pitch * n_a))))
        rotate = float(rng.uniform(-15, 15))
        view = View(tiles=tiles, size=PHOTO_SIDE_PX, spp=4, rotate_deg=rotate, camera="perspective", fov_deg=12.0)
        image = render_numpy(build_scene(truth, view), seed=k)
        image = image + rng.normal(0.0, 0.01, image.shape).astype(np.float32)
        srgb = (np.clip(linear_to_srgb(np.clip(image, 0, 1)), 0, 1) * 255 + 0.5).astype(np.uint8)
        path = folder / f"{k:02d}_{family.replace(' ', '')}.jpg"
        cv2.imwrite(str(path), cv2.cvtColor(srgb, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, 90])
        photos.append(BenchPhoto(path=path, truth=truth, family=family, rotate_deg=rotate))
    return photos


def make_independent_photos(folder: Path, *, quick: bool, seed: int = 11) -> list[BenchPhoto]:
    """Render the independent set (:func:`weavecap.bench.heightfield_photos.bench_specs`) into
    ``folder`` (JPEG at each photo's own quality)."""
    from ..estimate.weave_name import weave_name
    from .heightfield_photos import bench_specs, write_photo

    photos = []
    for k, spec in enumerate(bench_specs(seed=seed, quick=quick)):
        path = write_photo(folder / f"{spec.name}.jpg", spec, seed=seed + k)
        photos.append(BenchPhoto(path=path, truth=None, family=weave_name(spec.pattern),
                                 rotate_deg=spec.rotate_deg, pattern=np.asarray(spec.pattern), set="independent"))
    return photos


def score_pattern(fit: Fabric | None, truth: np.ndarray) -> dict:
    """The independent set's scoring: the pattern up to a cyclic shift (face and direction
    included: a mirrored twill or the other face of a satin is a different pattern)."""
    from ..estimate.weave_name import equal_up_to_shift

    if fit is None:
        return {"fitted": False, "pattern_exact": False}
    return {"fitted": True, "pattern_exact": equal_up_to_shift(fit.pattern, truth)}


def compare(fit: Fabric | None, truth: Fabric, determined: dict | None = None) -> dict:
    """Errors of a fitted fabric against the truth (None: the photo was not fitted).
    ``determined``: the report's ``fit.parameters`` (which values the photo determines);
    ``within_2se`` is the share of values with a finite standard error whose error is within
    two of it."""
    from ..estimate.weave_name import equal_up_to_shift

    if fit is None:
        return {"fitted": False, "pattern_exact": False}
    out = {"fitted": True, "pattern_exact": equal_up_to_shift(fit.pattern, truth.pattern),
           "plies_ok": abs(fit.plies - truth.plies) <= 1, "fibers_ok": abs(fit.fibers - truth.fibers) <= 1,
           "relative_error": {},
           "determined": sorted(k for k, v in (determined or {}).items() if v["determined"])}
    within = []
    for key in CONTINUOUS_KEYS:
        lo, hi = FIT_RANGES[key]
        diff = np.abs(np.subtract(np.asarray(fit.get(key), float), np.asarray(truth.get(key), float)))
        out["relative_error"][key] = float(np.mean(diff) / (hi - lo))
        se = (determined or {}).get(key, {}).get("standard_error")
        if se is not None:
            within.append(float(np.max(diff) / (hi - lo)) <= 2.0 * se)
    out["within_2se"] = float(np.mean(within)) if within else float("nan")
    return out


def run(presets: tuple[str, ...], *, quick: bool, folder: Path | None = None, sets: tuple[str, ...] = SETS,
        light: str = "auto", progress=print) -> list[dict]:
    """Fit every photo of each of ``sets`` at every preset, with ``weavecap fit --light``
    ``light``; one result dict per (photo, preset). ``folder`` keeps the photos (``own/``,
    ``independent/``) and each fit's outputs (``fits/<preset>/<photo>/``, compare.png included)."""
    from ..estimate.weave_name import weave_name
    from ..pipeline import CaptureOptions, capture, write_capture

    with tempfile.TemporaryDirectory() as tmp:
        where = folder or Path(tmp)
        photos = []
        for name in sets:
            (where / name).mkdir(parents=True, exist_ok=True)
            make = make_photos if name == "own" else make_independent_photos
            photos += make(where / name, quick=quick)
        results = []
        for preset in presets:
            for photo in photos:
                cap = capture(photo.path, CaptureOptions(quality=preset, seed=0, light=light))
                if folder is not None:
                    write_capture(cap, where / "fits" / preset / photo.set / photo.path.stem)
                fit = cap.report.get("fit", {})
                scores = (compare(cap.fabric, photo.truth, fit.get("parameters")) if photo.truth is not None
                          else score_pattern(cap.fabric, photo.pattern))
                row = {"set": photo.set, "preset": preset, "light": light, "photo": photo.path.name,
                       "family": photo.family,
                       "status": cap.status, "seconds": cap.report["timings_s"]["total"],
                       "psnr_db": fit["psnr_db"] if cap.status == "ok" else None,
                       "fidelity": fit.get("fidelity") if cap.status == "ok" else None,
                       "fitted_weave": weave_name(cap.fabric.pattern) if cap.fabric is not None else None,
                       "timings_s": cap.report["timings_s"], **scores}
                results.append(row)
                fid = row["fidelity"] or {}
                progress(f"{preset:6s} {photo.path.name:22s} {row['status']:8s} {row['seconds']:6.1f} s  "
                         f"pattern {'exact' if row['pattern_exact'] else 'wrong'} ({row['fitted_weave']})  "
                         f"PSNR {row['psnr_db']}  sharpness {fid.get('sharpness')}  dE {fid.get('delta_e')}")
    return results


#: the exposure-invariance check: one fabric, photographed as the camera saw it and
#: 1 stop darker, 1 stop brighter and with a 15% colour cast (gain per channel)
EXPOSURE_VARIANTS = {"as shot": (0.0, (1.0, 1.0, 1.0)), "1 stop darker": (-1.0, (1.0, 1.0, 1.0)),
                     "1 stop brighter": (1.0, (1.0, 1.0, 1.0)), "15% colour cast": (0.0, (1.15, 1.0, 0.87))}
EXPOSURE_FABRICS = ("07_satin5_weft", "00_plain")  # one back-lit (gaps show the light), one front-lit


def exposure_invariance(preset: str, folder: Path, *, seed: int = 11, exposure: str = "rig",
                        progress=print) -> list[dict]:
    """Fit each of :data:`EXPOSURE_FABRICS` (from :func:`weavecap.bench.heightfield_photos.bench_specs`)
    under every :data:`EXPOSURE_VARIANTS` camera (exposure and white balance relative to a
    neutral one), with ``weavecap fit --exposure`` ``exposure``, and measure how far the fitted
    fabric colours move: per fabric and family, the largest CIEDE2000 between any two variants
    of ``params.json``'s body reflection (``delta_e_max``) and of the colour the fabric renders
    under a fixed light (:func:`weavecap.fit.fidelity.rendered_family_lab`; ``rendered``, and
    ``rendered_stops`` over the three exposures alone, without the cast), and each variant's
    fitted gain."""
    from ..estimate.colour import linear_to_lab
    from ..fit.fidelity import rendered_family_lab
    from .heightfield_photos import bench_specs, with_camera, write_photo
    from ..pipeline import CaptureOptions, capture

    folder.mkdir(parents=True, exist_ok=True)
    specs = {s.name: s for s in bench_specs(seed=seed)}
    rows = []
    for name in EXPOSURE_FABRICS:
        spec, colours, rendered, gains = specs[name], {}, {}, {}
        for label, (stops, cast) in EXPOSURE_VARIANTS.items():  # around a neutral camera
            variant = with_camera(spec, exposure_stops=stops, white_balance=cast)
            path = write_photo(folder / f"{name}_{label.replace(' ', '_').replace('%', '')}.jpg", variant, seed=seed)
            cap = capture(path, CaptureOptions(quality=preset, seed=0, exposure=exposure))
            if cap.fabric is None:
                continue
            colours[label] = {f: linear_to_lab(cap.fabric.get(f"{f}.body_reflection")) for f in ("warp", "weft")}
            rendered[label] = rendered_family_lab(cap.fabric)
            gains[label] = cap.report["fit"]["light"]["gain"]
            progress(f"{preset:6s} --exposure {exposure} {name} {label:16s} gain {gains[label]}  "
                     f"warp {np.round(colours[label]['warp'], 1)} weft {np.round(colours[label]['weft'], 1)}  "
                     f"rendered warp {np.round(rendered[label]['warp'], 1)} weft {np.round(rendered[label]['weft'], 1)}")
        stops = {k: v for k, v in rendered.items() if EXPOSURE_VARIANTS[k][1] == (1.0, 1.0, 1.0)}
        rows.append({"fabric": name, "preset": preset, "exposure": exposure, "fitted": len(colours),
                     "delta_e_max": _largest_difference(colours), "rendered": _largest_difference(rendered),
                     "rendered_stops": _largest_difference(stops), "gain": gains})
    return rows


def _largest_difference(colours: dict[str, dict[str, np.ndarray]]) -> dict[str, float]:
    """Per family, the largest CIEDE2000 between any two of ``colours`` ({variant: {family:
    CIELAB}}); NaN with fewer than two."""
    from skimage.color import deltaE_ciede2000

    out = {}
    for family in ("warp", "weft"):
        labs = [c[family] for c in colours.values()]
        out[family] = max((float(deltaE_ciede2000(a, b)) for i, a in enumerate(labs) for b in labs[i + 1:]),
                          default=float("nan"))
    return out


def exposure_table(rows: list[dict]) -> str:
    """The exposure-invariance table (markdown): largest ΔE2000 between the variants' colours,
    warp / weft: the body reflection, the rendered colour, the rendered colour over the stops."""
    out = ["| fabric | preset | --exposure | variants fitted | body reflection ΔE2000 (max pair) | "
           "rendered ΔE2000 (max pair) | rendered, the stops alone | fitted gains |", "|" + "---|" * 8]
    nan = {"warp": float("nan"), "weft": float("nan")}
    for r in rows:
        gains = "; ".join(f"{k}: {', '.join(f'{v:.2f}' for v in g)}" for k, g in r["gain"].items())
        pairs = " | ".join(f"{d['warp']:.1f} / {d['weft']:.1f}" for d in
                           (r["delta_e_max"], r.get("rendered", nan), r.get("rendered_stops", nan)))
        out.append(f"| {r['fabric']} | {r['preset']} | {r.get('exposure', 'rig')} | "
                   f"{r['fitted']}/{len(EXPOSURE_VARIANTS)} | {pairs} | {gains} |")
    return "\n".join(out)


def _fidelity_summary(fitted: list[dict]) -> dict:
    """Median and worst of the fidelity figures over fitted photos: sharpness (worst = lowest),
    ΔE over both families of every photo (worst = highest), structure (median)."""
    sharp = [r["fidelity"]["sharpness"] for r in fitted if r.get("fidelity") and r["fidelity"]["sharpness"] is not None]
    de = [v for r in fitted if r.get("fidelity") for v in r["fidelity"]["delta_e"].values() if v is not None]
    struct = [r["fidelity"]["structure"] for r in fitted if r.get("fidelity") and r["fidelity"]["structure"] is not None]
    nan = float("nan")
    return {"sharpness_median": statistics.median(sharp) if sharp else nan, "sharpness_worst": min(sharp, default=nan),
            "delta_e_median": statistics.median(de) if de else nan, "delta_e_worst": max(de, default=nan),
            "structure_median": statistics.median(struct) if struct else nan}


def summary(results: list[dict]) -> list[dict]:
    """Per preset: median and max seconds, pattern-exact rate, median PSNR, plies/fibres rates,
    the median relative error of each continuous parameter and the share of photos that
    determine it, and the median relative error over every (photo, parameter it determines)."""
    rows = []
    for set_, preset in dict.fromkeys((r.get("set", "own"), r["preset"]) for r in results):
        rs = [r for r in results if r.get("set", "own") == set_ and r["preset"] == preset]
        fitted = [r for r in rs if r["fitted"]]
        if set_ != "own":
            rows.append({"set": set_, "preset": preset, "photos": len(rs), "fitted": len(fitted),
                         "median_s": statistics.median(r["seconds"] for r in rs), "max_s": max(r["seconds"] for r in rs),
                         "pattern_exact": sum(r["pattern_exact"] for r in rs) / len(rs),
                         "median_psnr_db": statistics.median(r["psnr_db"] for r in fitted) if fitted else float("nan"),
                         "rigs_searched": sum("captures" in (r.get("timings_s") or {}) for r in rs),
                         **_fidelity_summary(fitted)})
            continue
        row = {"set": set_, "preset": preset, "photos": len(rs), "fitted": len(fitted),
               "median_s": statistics.median(r["seconds"] for r in rs), "max_s": max(r["seconds"] for r in rs),
               "pattern_exact": sum(r["pattern_exact"] for r in rs) / len(rs),
               "median_psnr_db": statistics.median(r["psnr_db"] for r in fitted) if fitted else float("nan"),
               "plies_ok": sum(r.get("plies_ok", False) for r in rs) / len(rs),
               "fibers_ok": sum(r.get("fibers_ok", False) for r in rs) / len(rs),
               "relative_error": {k: statistics.median(r["relative_error"][k] for r in fitted) if fitted else float("nan")
                                  for k in CONTINUOUS_KEYS},
               "determined_share": {k: sum(k in r["determined"] for r in fitted) / max(1, len(fitted))
                                    for k in CONTINUOUS_KEYS}}
        pooled = [r["relative_error"][k] for r in fitted for k in r["determined"]]
        row["median_error_determined"] = statistics.median(pooled) if pooled else float("nan")
        row["determined_per_photo"] = statistics.median(len(r["determined"]) for r in fitted) if fitted else 0
        row["within_2se"] = statistics.median(r["within_2se"] for r in fitted) if fitted else float("nan")
        row.update(_fidelity_summary(fitted))
        rows.append(row)
    return rows


def independent_table(rows: list[dict]) -> str:
    """The independent set's table (markdown): pattern, fidelity and time per preset, and how
    many photos were captured under more than one rig (:func:`weavecap.pipeline.rig_search`)."""
    out = ["| preset | photos fitted | median s | max s | pattern exact | median PSNR | sharpness median | "
           "sharpness worst | ΔE2000 median | ΔE2000 worst | structure median | rigs searched |", "|" + "---|" * 12]
    for r in rows:
        if r.get("set") != "independent":
            continue
        out.append(f"| {r['preset']} | {r['fitted']}/{r['photos']} | {r['median_s']:.1f} | {r['max_s']:.1f} | "
                   f"{r['pattern_exact']:.0%} | {r['median_psnr_db']:.1f} dB | {r['sharpness_median']:.2f} | "
                   f"{r['sharpness_worst']:.2f} | {r['delta_e_median']:.1f} | {r['delta_e_worst']:.1f} | "
                   f"{r['structure_median']:.2f} | {r.get('rigs_searched', 0)} |")
    return "\n".join(out)


def table(rows: list[dict]) -> str:
    """docs/capture.md's fit bench tables for the own-render set (markdown)."""
    rows = [r for r in rows if r.get("set", "own") == "own"]
    if not rows:
        return ""
    out = ["| preset | photos fitted | median s | max s | pattern exact | median PSNR | sharpness median / worst |"
           " ΔE2000 median / worst | plies ±1 | fibres ±1 |"
           " median rel. error (determined) | determined per photo | errors within 2 SE |"
           " median rel. error (all continuous) |", "|" + "---|" * 14]
    for r in rows:
        med = statistics.median(r["relative_error"].values())
        out.append(f"| {r['preset']} | {r['fitted']}/{r['photos']} | {r['median_s']:.1f} | {r['max_s']:.1f} | "
                   f"{r['pattern_exact']:.0%} | {r['median_psnr_db']:.1f} dB | "
                   f"{r.get('sharpness_median', float('nan')):.2f} / {r.get('sharpness_worst', float('nan')):.2f} | "
                   f"{r.get('delta_e_median', float('nan')):.1f} / {r.get('delta_e_worst', float('nan')):.1f} | "
                   f"{r['plies_ok']:.0%} | "
                   f"{r['fibers_ok']:.0%} | {r['median_error_determined']:.1%} | {r['determined_per_photo']:g} | "
                   f"{r['within_2se']:.0%} | {med:.1%} |")
    out += ["", "| parameter (median rel. error, share of photos that determine it) | "
            + " | ".join(r["preset"] for r in rows) + " |", "|---|" + "---|" * len(rows)]
    for key in CONTINUOUS_KEYS:
        out.append(f"| {key} | " + " | ".join(f"{r['relative_error'][key]:.1%} ({r['determined_share'][key]:.0%})"
                                              for r in rows) + " |")
    return "\n".join(out)


def plot(rows: list[dict], path: Path) -> None:
    """Speed against error on the own-render set (median seconds vs median relative error and
    PSNR) as a PNG; nothing without that set."""
    import cv2

    from ..photo import save_png, srgb_to_linear

    rows = [r for r in rows if "relative_error" in r]  # the own-render set: errors against the truth
    if not rows:
        return
    h, w, m = 320, 480, 50
    img = np.full((h, w, 3), 255, np.uint8)
    cv2.rectangle(img, (m, 20), (w - 20, h - m), (0, 0, 0), 1)
    xs = [r["median_s"] for r in rows]
    ys = [100 * statistics.median(r["relative_error"].values()) for r in rows]
    x_hi, y_hi = max(xs) * 1.15 or 1.0, max(ys) * 1.15 or 1.0

    def at(x, y):
        return int(m + x / x_hi * (w - 20 - m)), int((h - m) - y / y_hi * (h - m - 20))

    pts = [at(x, y) for x, y in zip(xs, ys)]
    cv2.polylines(img, [np.array(pts, np.int32)], False, (180, 180, 180), 1, cv2.LINE_AA)
    for (px, py), r in zip(pts, rows):
        cv2.circle(img, (px, py), 5, (200, 60, 20), -1, cv2.LINE_AA)
        cv2.putText(img, f"{r['preset']} ({r['median_psnr_db']:.1f} dB)", (px + 8, py - 6), cv2.FONT_HERSHEY_SIMPLEX,
                    0.42, (0, 0, 0), 1, cv2.LINE_AA)
    cv2.putText(img, f"median seconds per photo (0..{x_hi:.0f})", (m, h - 18), cv2.FONT_HERSHEY_SIMPLEX, 0.45,
                (0, 0, 0), 1, cv2.LINE_AA)
    cv2.putText(img, f"median rel. error % (0..{y_hi:.0f})", (8, 14), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 0), 1,
                cv2.LINE_AA)
    save_png(path, srgb_to_linear(img.astype(np.float32) / 255.0))
