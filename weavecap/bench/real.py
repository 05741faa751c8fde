"""The real-photo development bench (``weavecap bench --fit --set real [--stage prepare]``).

Photos of real fabrics that the project never made, read in place from ``../shared/realdata``
(never copied): ``fabricnet/`` (handheld-microscope photos, labelled with the weave family,
warp and weft threads per cm, and which photos are views of one fabric), ``kth_tips2a/`` (six
woven fabrics, each under three poses and four lights; family read by eye), ``plaids/`` (two
yarn-dyed checks), ``images/easy``, ``images/hard`` and ``images/negative`` (knits, felt,
straw, a stain at a magnification where no yarn shows). Each photo is captured end to end
(``stage="fit"``) or only prepared (``stage="prepare"``, Wu et al. 2025 §4: seconds a photo,
for iterating on preparation's rules), and scored per photo:

- status, or the rejection code and reason;
- the weave, and its family against the label (:func:`weave_family`, :func:`label_family`:
  a herringbone or broken twill is a twill; a basket/hopsack or rib a plain-weave derivative);
- the thread-density ratio, denser over sparser family, against the label's
  (:func:`density_ratio_error`: a photo does not say which family is the warp);
- the fidelity figures of the report (PSNR, sharpness, ΔE2000 per family, structure), seconds;

and per fabric whether all its views gave the same weave (:func:`views_agree`: the same
pattern up to a cyclic shift and a quarter turn of the photo).

Rules are decided on the DEV half of the fabrics only (:data:`HELD_OUT`, fixed before any
rule was); the summary (:func:`summary`) is given for DEV, HELD-OUT and all photos. The scoring
functions are pure and tested on known cases (tests/bench/test_real.py).
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import re
import statistics
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterable

import numpy as np

#: the photo folders of ``../shared/realdata`` the bench runs, in this order (short set names)
FOLDERS = (("fabricnet", "fabricnet"), ("kth_tips2a", "kth_tips2a"), ("plaids", "plaids"),
           ("easy", "images/easy"), ("hard", "images/hard"), ("negative", "images/negative"))

#: the fixed hold-out split: rules are decided on the other fabrics only. FabricNET by its
#: ``fabric`` column, KTH-TIPS2-a by the sample (the file name's prefix), plaids by file;
#: ``images/`` (easy, hard, negative) are all DEV (they were seen before the split)
HELD_OUT = {"fabricnet": {"2", "11", "15", "16", "17", "28"},
            "kth_tips2a": {"44c", "46b", "46c"},
            "plaids": {"20190219-120844-771"}}

#: photos of ``images/easy`` whose yarns lie under the sampling limit (a crop a capture must
#: refuse with ``too_fine``): the spectrum's yarn peaks at 2.5–3.7 px (docs/preparation.md)
SUB_NYQUIST = frozenset({"fabricbtdf_twill1_R.png", "fabricbtdf_twill1_T.png",
                         "fabricbtdf_twill4_R.png", "fabricbtdf_twill4_T.png"})

#: the sets counted in "woven, resolvable photos fitted" (hard photos are reported, not counted)
FITTED_TARGET_SETS = ("fabricnet", "kth_tips2a", "plaids", "easy")

FAMILIES = ("plain", "twill", "satin")


def find_realdata(given: Path | None = None) -> Path | None:
    """The real photos' folder: ``given``, else ``$WEAVECAP_SHARED/realdata``, else
    ``shared/realdata`` beside this checkout (``../shared`` from the repository), else beside
    the working folder; None where none holds ``fabricnet/labels.csv``."""
    import os

    here = Path(__file__).resolve().parents[2]
    env = os.environ.get("WEAVECAP_SHARED")
    for cand in ([given] if given is not None else
                 [Path(env) / "realdata" if env else None, here.parent / "shared" / "realdata",
                  Path.cwd().parent / "shared" / "realdata"]):
        if cand is not None and (cand / "fabricnet" / "labels.csv").is_file():
            return cand
    return None


# ----------------------------------------------------------------------------- scoring

def weave_family(name: str | None) -> str | None:
    """The family of a weave name (:func:`weavecap.estimate.weave_name.weave_name`, or a
    named weave with parameters): ``plain`` (plain, basket/hopsack/matt, rib: the plain
    weave's derivatives), ``twill`` (twill, herringbone, broken twill), ``satin`` (satin or
    sateen, extended ones too), ``other`` (custom patterns); None for no weave."""
    if not name:
        return None
    n = name.lower()
    for family, words in (("twill", ("twill", "herringbone")), ("satin", ("satin", "sateen")),
                          ("plain", ("plain", "basket", "hopsack", "matt", "rib"))):
        if any(re.search(rf"\b{w}", n) for w in words):
            return family
    return "other"


def label_family(text: str | None) -> str | None:
    """The weave family a label names (``weave_family``/``weave_visual`` columns of the
    realdata label sheets), or None where the label names none (``unknown``, a knit, felt,
    a non-fabric, an unresolvable cloth): ``"plain (open, slubby)"`` → plain,
    ``"herringbone weave (broken twill)"`` → twill, ``"plain? rotated"`` → plain."""
    if not text:
        return None
    head = text.strip().lower()
    if head.startswith(("unknown", "n/a", "knit", "non-woven", "not a fabric", "woven cloth but")):
        return None
    family = weave_family(re.split(r"[(;]", head, maxsplit=1)[0])
    return family if family in FAMILIES else None


def density_ratio(a: float, b: float) -> float:
    """Denser over sparser of two thread densities (or sparser over denser of two pitches:
    the same number), ≥ 1."""
    lo, hi = sorted((float(a), float(b)))
    return hi / lo


def density_ratio_error(pitch_px: Iterable[float], label_per_cm: Iterable[float]) -> float:
    """Relative error of the photo's thread-density ratio against the label's.

    Parameters
    ----------
    pitch_px : (warp pitch, weft pitch) in rectified px (report.json's ``grid.pitch_px``); a
        family's density is 1/pitch, so the ratio of densities is the inverse ratio of pitches.
    label_per_cm : (warp, weft) threads per cm of the label.

    Returns
    -------
    measured / label − 1, both as denser over sparser (:func:`density_ratio`): a photo does
    not say which family is the warp.
    """
    return density_ratio(*pitch_px) / density_ratio(*label_per_cm) - 1.0


def _quarter_turns(pattern: np.ndarray) -> list[np.ndarray]:
    """The pattern seen after turning the photo by 0, 90, 180 and 270°: a quarter turn makes
    the wefts warps, so the pattern turns and every cell flips (1 = weft over warp)."""
    p = np.asarray(pattern, np.uint8)
    return [np.rot90(p, k) if k % 2 == 0 else 1 - np.rot90(p, k) for k in range(4)]


def same_weave(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether two fitted patterns are the same weave seen in two photos: equal up to a cyclic
    shift (:func:`weavecap.estimate.weave_name.equal_up_to_shift`) after turning one photo by
    a multiple of 90° (the views of one fabric may hold it either way up)."""
    from ..estimate.weave_name import equal_up_to_shift

    return any(equal_up_to_shift(a, t) for t in _quarter_turns(b))


def views_agree(patterns: list[np.ndarray | None]) -> bool:
    """Whether all views of one fabric gave the same weave (:func:`same_weave`); a rejected
    view (None) gave none, so the views then do not agree. False for no views."""
    if not patterns or any(p is None for p in patterns):
        return False
    return all(same_weave(patterns[0], p) for p in patterns[1:])


# ----------------------------------------------------------------------------- the photos

@dataclass(frozen=True)
class RealPhoto:
    """One bench photo and what its labels say.

    Attributes
    ----------
    path : the photo file (in ``../shared/realdata``).
    set : ``fabricnet``, ``kth_tips2a``, ``plaids``, ``easy``, ``hard`` or ``negative``.
    family : the labelled family (``plain``, ``twill``, ``satin``) or None (unlabelled).
    density : (warp, weft) threads per cm of the label, or None.
    fabric : which fabric this is a view of (``fabricnet:5``, ``kth_tips2a:44a``), or None.
    split : ``dev`` or ``held-out`` (:data:`HELD_OUT`).
    expect : ``fit`` (woven and resolvable: counted in the fitted share), ``reject`` (a
        negative, a sub-Nyquist crop), or ``either`` (hard photos: reported, not counted).
    sha256 : of the file; a photo of ``images/`` that is also in ``fabricnet/`` is captured
        once and takes that one's labels.
    """

    path: Path
    set: str
    family: str | None
    density: tuple[float, float] | None
    fabric: str | None
    split: str
    expect: str
    sha256: str

    @property
    def name(self) -> str:
        return self.path.name


def _rows(path: Path) -> list[dict]:
    with path.open(newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def photos(realdata: Path) -> list[RealPhoto]:
    """Every bench photo of ``realdata`` (``../shared/realdata``) with its labels, in
    :data:`FOLDERS` order."""
    out: list[RealPhoto] = []
    fabricnet: dict[str, RealPhoto] = {}
    for r in _rows(realdata / "fabricnet" / "labels.csv"):
        p = realdata / "fabricnet" / r["file"]
        ph = RealPhoto(p, "fabricnet", label_family(r["weave_family"]),
                       (float(r["warp_threads_per_cm"]), float(r["weft_threads_per_cm"])), f"fabricnet:{r['fabric']}",
                       "held-out" if r["fabric"] in HELD_OUT["fabricnet"] else "dev", "fit", _sha256(p))
        fabricnet[ph.sha256] = ph
        out.append(ph)
    for name in ("kth_tips2a", "plaids"):
        for r in _rows(realdata / name / "labels.csv"):
            p = realdata / name / r["file"]
            key = p.stem.split("-scale")[0] if name == "kth_tips2a" else p.stem
            out.append(RealPhoto(p, name, label_family(r["weave_visual"]), None,
                                 f"{name}:{key}" if name == "kth_tips2a" else None,
                                 "held-out" if key in HELD_OUT[name] else "dev", "fit", _sha256(p)))
    labels = {r["file"]: r for r in _rows(realdata / "labels.csv")}
    for set_, folder in FOLDERS[3:]:
        for p in sorted((realdata / folder).iterdir()):
            r = labels.get(f"{folder}/{p.name}")
            if r is None:
                continue
            sha = _sha256(p)
            twin = fabricnet.get(sha)
            expect = ("reject" if set_ == "negative" or p.name in SUB_NYQUIST else "fit" if set_ == "easy"
                      else "either")
            out.append(RealPhoto(p, set_, twin.family if twin else label_family(r["weave_label"]),
                                 twin.density if twin else None, None, "dev", expect, sha))
    return out


# ----------------------------------------------------------------------------- running

def _fit_row(photo: RealPhoto, out_dir: Path, quality: str) -> dict:
    """Capture one photo end to end (``weavecap fit --quality``), write its outputs."""
    from ..pipeline import CaptureOptions, capture, write_capture

    from ..fit.fidelity import with_noise

    cap = capture(photo.path, CaptureOptions(quality=quality))
    write_capture(cap, out_dir)
    rep = cap.report
    fit = rep.get("fit", {}) if cap.status == "ok" else {}
    fid = fit.get("fidelity") or {}
    noise = with_noise(cap.fabric, rig=fit["light"]["rig"]) if cap.status == "ok" else {}
    decision = (rep.get("pre_estimation") or {}).get("decision") or {}
    return {"status": cap.status, "code": rep.get("code"), "reason": rep.get("reason"), "weave": rep.get("weave"),
            "decided": decision.get("decided"),
            "pattern": None if cap.fabric is None else np.asarray(cap.fabric.pattern).tolist(),
            "pitch_px": rep["grid"]["pitch_px"] if cap.status == "ok" else None,
            "yarns": rep["grid"]["yarns"] if cap.status == "ok" else None,
            "psnr_db": fit.get("psnr_db"), "sharpness": fid.get("sharpness"), "delta_e": fid.get("delta_e"),
            "structure": fid.get("structure"), "photo_scale": fid.get("photo_scale"),
            "neutral_delta_e": fid.get("neutral_delta_e"),
            "noise": {k: round(v, 4) for k, v in noise.items()} or None, "seconds": rep["timings_s"]["total"]}


def _prepare_row(photo: RealPhoto, out_dir: Path) -> dict:
    """Only prepare one photo (§4); write grid.png, or diagnosis.png when it is rejected."""
    from ..photo import load_photo, save_png
    from ..prepare import Rejected, prepare_photo

    t = time.perf_counter()
    rgb = load_photo(photo.path).rgb
    res = prepare_photo(rgb)
    seconds = time.perf_counter() - t
    out_dir.mkdir(parents=True, exist_ok=True)
    if isinstance(res, Rejected):
        save_png(out_dir / "diagnosis.png", res.diagnosis(rgb))
        return {"status": "rejected", "code": res.code, "reason": res.reason, "weave": None, "pattern": None,
                "pitch_px": None, "yarns": None, "seconds": round(seconds, 3)}
    save_png(out_dir / "grid.png", res.grid_overlay())
    return {"status": "ok", "code": None, "reason": None, "weave": None, "pattern": None,
            "pitch_px": [round(float(v), 4) for v in res.grid.pitch_px], "yarns": list(res.grid.yarns),
            "colour_repeat": list(res.colour_repeat.yarns), "seconds": round(seconds, 3)}


def score(photo: RealPhoto, raw: dict) -> dict:
    """A bench row: the photo's labels, what the capture gave (``raw``) and its scores."""
    fam = weave_family(raw.get("weave"))
    row = {"set": photo.set, "photo": photo.name, "sha256": photo.sha256, "split": photo.split, "expect": photo.expect,
           "fabric": photo.fabric, "label_family": photo.family, **raw, "family": fam,
           "family_right": None if photo.family is None or fam is None else fam == photo.family,
           "density_label": None if photo.density is None else round(density_ratio(*photo.density), 4),
           "density_ratio": None if not raw.get("pitch_px") else round(density_ratio(*raw["pitch_px"]), 4),
           "density_error": None}
    if photo.density is not None and raw.get("pitch_px"):
        row["density_error"] = round(density_ratio_error(raw["pitch_px"], photo.density), 4)
    return row


def run(realdata: Path, out: Path, *, stage: str = "fit", quality: str = "normal",
        progress: Callable[[str], None] = print) -> list[dict]:
    """Capture (or, ``stage="prepare"``, only prepare) every bench photo, one row each.

    Each photo's outputs go to ``out/fits/<set>/<stem>/`` (report.json, compare.png, grid.png,
    diagnosis.png for a rejected photo; only grid.png or diagnosis.png at ``stage="prepare"``);
    each row is appended to ``out/rows.jsonl`` as it is done, and a photo already there
    (same file, stage and quality) is not captured again, so an interrupted run resumes. A
    photo of ``images/`` that is also in ``fabricnet/`` (the same bytes) is captured once.
    """
    out.mkdir(parents=True, exist_ok=True)
    log = out / "rows.jsonl"
    done: dict[str, dict] = {}
    if log.exists():
        for line in log.read_text(encoding="utf-8").splitlines():
            r = json.loads(line)
            if r.get("stage") == stage and r.get("quality") == quality:
                done[r["sha256"]] = r
    rows = []
    for photo in photos(realdata):
        raw = done.get(photo.sha256)
        if raw is None:
            where = out / "fits" / photo.set / photo.path.stem
            raw = _fit_row(photo, where, quality) if stage == "fit" else _prepare_row(photo, where)
            raw = {"sha256": photo.sha256, "stage": stage, "quality": quality, **raw}
            with log.open("a", encoding="utf-8") as f:
                f.write(json.dumps(raw) + "\n")
            done[photo.sha256] = raw
        row = score(photo, {k: v for k, v in raw.items() if k not in ("sha256", "stage", "quality")})
        rows.append(row)
        progress(f"{photo.set:10s} {photo.name:40s} {row['status']:8s} {row['seconds']:6.1f} s  "
                 f"{row['weave'] or row['code'] or ''}  family {row['family']} / {row['label_family']}  "
                 f"density ratio {row['density_ratio']} / {row['density_label']}")
    return rows


# ----------------------------------------------------------------------------- summary

def _share(hits: list[bool]) -> tuple[int, int]:
    return sum(bool(h) for h in hits), len(hits)


def fabric_agreement(rows: list[dict]) -> dict[str, bool]:
    """Per fabric (fabricnet, KTH), whether all its views gave the same weave (:func:`views_agree`)."""
    by: dict[str, list] = {}
    for r in rows:
        if r["fabric"] and r["set"] in ("fabricnet", "kth_tips2a"):
            by.setdefault(r["fabric"], []).append(None if r["pattern"] is None else np.asarray(r["pattern"]))
    return {f: views_agree(ps) for f, ps in sorted(by.items())}


def summary(rows: list[dict], split: str | None = None) -> dict:
    """The figures of the Done-when list over the rows of one split (None: all photos, each
    file once: a photo of ``images/`` that is also in ``fabricnet/`` counts there).

    Returns counts ``(hits, of)``: ``fitted`` (woven, resolvable photos of
    :data:`FITTED_TARGET_SETS` fitted), ``rejected`` (negatives and sub-Nyquist crops
    rejected), ``family`` (family right of the labelled, fitted photos), ``family_decided`` and
    ``family_undecided`` (the same where the pattern decision was sure, and where it was not:
    what the fit's note on an undecided weave rests on), ``density`` (fabricnet
    photos with the ratio within 15 %, of all of them), ``views`` (fabrics whose views agree),
    the photo-scale figures of the fitted photos (:func:`weavecap.fit.compare.at_photo_scale`):
    ``pixel_p90`` (pixel colour difference p90 ≤ 12), ``pixel_sharpness`` (within 0.8–1.25),
    ``pixel_structure`` (≥ 0.6), ``structure_reachable`` (the photo's structure ceiling ≥ 0.6, of
    the photos whose view holds a repeat twice: :func:`weavecap.fit.fidelity.structure_ceiling`),
    ``not_washed`` (sharpness ≥ 0.5), ``neutral_colour`` (each
    family's colour under a neutral light within ΔE 10 of the photo's at equal lightness:
    :func:`weavecap.fit.fidelity.neutral_light_delta_e`), ``noise_brightness`` (the capture
    rendered with its §6.3 noise within 3 % of its brightness without) and ``noise_weave`` (the
    median correlation of the two: :func:`weavecap.fit.fidelity.with_noise`), and the median
    seconds."""
    if split is None:
        seen, rs = set(), []
        for r in rows:  # fabricnet/ comes first: a copy in images/ counts there
            if r["sha256"] not in seen:
                seen.add(r["sha256"])
                rs.append(r)
    else:
        rs = [r for r in rows if r["split"] == split]
    fit_target = [r for r in rs if r["expect"] == "fit" and r["set"] in FITTED_TARGET_SETS]
    agree = fabric_agreement(rs)
    secs = [r["seconds"] for r in rs if r["seconds"] is not None]
    scale = [r["photo_scale"] for r in rs if r["status"] == "ok" and r.get("photo_scale")]
    neutral = [[v for v in r["neutral_delta_e"].values() if v is not None]
               for r in rs if r["status"] == "ok" and r.get("neutral_delta_e")]
    noises = [r["noise"] for r in rs if r["status"] == "ok" and r.get("noise")]
    return {
        "photos": len(rs),
        "fitted": _share([r["status"] == "ok" for r in fit_target]),
        "rejected": _share([r["status"] == "rejected" and bool(r["reason"]) for r in rs if r["expect"] == "reject"]),
        "family": _share([r["family_right"] for r in rs if r["family_right"] is not None]),
        "family_decided": _share([r["family_right"] for r in rs if r["family_right"] is not None
                                  and r.get("decided") is True]),
        "family_undecided": _share([r["family_right"] for r in rs if r["family_right"] is not None
                                    and r.get("decided") is False]),
        "density": _share([r["density_error"] is not None and abs(r["density_error"]) <= 0.15
                           for r in rs if r["set"] == "fabricnet"]),
        "views": _share(list(agree.values())),
        "pixel_p90": _share([s["colour_p90"] <= 12 for s in scale]),
        "pixel_sharpness": _share([0.8 <= s["sharpness"] <= 1.25 for s in scale]),
        "pixel_structure": _share([s["structure"] >= 0.6 for s in scale]),
        "structure_reachable": _share([s["structure_ceiling"] >= 0.6 for s in scale
                                       if s.get("structure_ceiling") is not None]),
        "not_washed": _share([s["sharpness"] >= 0.5 for s in scale]),
        "neutral_colour": _share([bool(v) and max(v) <= 10 for v in neutral]),
        "noise_brightness": _share([abs(n["brightness"] - 1) <= 0.03 for n in noises]),
        "noise_weave": statistics.median([n["weave"] for n in noises]) if noises else float("nan"),
        "median_s": statistics.median(secs) if secs else float("nan"),
    }


def _frac(pair: tuple[int, int]) -> str:
    hits, of = pair
    return f"{hits}/{of} ({hits / of:.0%})" if of else "–"


def summary_table(rows: list[dict]) -> str:
    """The Done-when figures for DEV, HELD-OUT and all photos (markdown)."""
    parts = [("DEV", summary(rows, "dev")), ("HELD-OUT", summary(rows, "held-out")), ("all", summary(rows))]
    out = ["| split | photos | woven resolvable fitted (≥ 95 %) | negatives + sub-Nyquist rejected (all) | "
           "family right of labelled fitted (≥ 90 %) | "
           "family right where the cells settled the weave / did not | fabricnet density ratio within 15 % (≥ 85 %) | "
           "fabrics whose views agree (≥ 85 %) | median s |", "|" + "---|" * 9]
    for name, s in parts:
        out.append(f"| {name} | {s['photos']} | {_frac(s['fitted'])} | {_frac(s['rejected'])} | {_frac(s['family'])} | "
                   f"{_frac(s['family_decided'])} / {_frac(s['family_undecided'])} | "
                   f"{_frac(s['density'])} | {_frac(s['views'])} | {s['median_s']:.1f} |")
    out += ["", "| split | pixel colour p90 ≤ 12 (≥ 85 %) | sharpness 0.8–1.25 (≥ 85 %) | structure ≥ 0.6 (≥ 85 %) | "
            "photos where a capture can reach structure 0.6 (of those measured) | sharpness ≥ 0.5 (all) | colour under a neutral light within ΔE 10 | with its noise: brightness within "
            "3 % | with its noise: weave correlation, median |", "|" + "---|" * 9]
    for name, s in parts:
        out.append(f"| {name} | {_frac(s['pixel_p90'])} | {_frac(s['pixel_sharpness'])} | "
                   f"{_frac(s['pixel_structure'])} | {_frac(s['structure_reachable'])} | {_frac(s['not_washed'])} | {_frac(s['neutral_colour'])} | "
                   f"{_frac(s['noise_brightness'])} | {s['noise_weave']:.2f} |")
    return "\n".join(out)


def _num(v, fmt: str) -> str:
    return "" if v is None else format(v, fmt)


def photo_table(rows: list[dict]) -> str:
    """One line per photo (markdown), then one per fabric with views."""
    out = ["| set | photo | split | status | weave / reason | family (label) | density ratio (label) | error | "
           "PSNR | sharpness | ΔE warp / weft | structure | s |", "|" + "---|" * 13]
    for r in rows:
        what = r["weave"] if r["status"] == "ok" else f"{r['code']}: {r['reason']}" if r["reason"] else ""
        if r["status"] == "ok" and r["weave"] is None and r["yarns"]:
            what = f"repeat {r['yarns'][0]}×{r['yarns'][1]}"
        mark = {True: " ✓", False: " ✗", None: ""}[r["family_right"]]
        de = r.get("delta_e") or {}
        out.append(f"| {r['set']} | {r['photo']} | {r['split']} | {r['status']} | {what} | "
                   f"{r['family'] or ''} ({r['label_family'] or '?'}){mark} | "
                   f"{_num(r['density_ratio'], '.2f')} ({_num(r['density_label'], '.2f')}) | "
                   f"{_num(r['density_error'], '+.0%')} | {_num(r.get('psnr_db'), '.1f')} | "
                   f"{_num(r.get('sharpness'), '.2f')} | "
                   f"{' / '.join(_num(de.get(k), '.1f') for k in ('warp', 'weft')) if de else ''} | "
                   f"{_num(r.get('structure'), '.2f')} | {r['seconds']:.1f} |")
    out += ["", "| fabric | split | views | weaves | all the same |", "|---|---|---|---|---|"]
    agree = fabric_agreement(rows)
    for fabric, same in agree.items():
        views = [r for r in rows if r["fabric"] == fabric]
        weaves = sorted({r["weave"] or r["code"] or "?" for r in views})
        out.append(f"| {fabric} | {views[0]['split']} | {len(views)} | {'; '.join(weaves)} | {'yes' if same else 'no'} |")
    return "\n".join(out)


def write(rows: list[dict], out: Path) -> None:
    """``out/real.jsonl``, ``out/real.csv`` and ``out/real.md`` (the summary and the photo table)."""
    from ..io import atomic_write_text

    atomic_write_text(out / "real.jsonl", "".join(json.dumps(r) + "\n" for r in rows))
    cols = [k for k in dict.fromkeys(k for r in rows for k in r) if k != "pattern"]
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(cols)
    for r in rows:
        writer.writerow(["" if r.get(k) is None else json.dumps(r[k]) if isinstance(r[k], (dict, list)) else r[k]
                         for k in cols])
    atomic_write_text(out / "real.csv", text.getvalue())
    atomic_write_text(out / "real.md", summary_table(rows) + "\n\n" + photo_table(rows) + "\n")


__all__ = ["RealPhoto", "find_realdata", "photos", "run", "score", "summary", "summary_table", "photo_table", "write",
           "weave_family", "label_family", "density_ratio", "density_ratio_error", "same_weave", "views_agree"]
