#!/usr/bin/env python3
"""Accuracy and speed of ``weavecap.prepare``, on synthetic photos with known truth.

    .venv/bin/python scripts/bench_prepare.py               # 80 accuracy cases + speed
    .venv/bin/python scripts/bench_prepare.py --cases 200 --no-speed
    .venv/bin/python scripts/bench_prepare.py --realdata ../shared/realdata   # + real photos table
    .venv/bin/python scripts/bench_prepare.py --forward 36 --no-accuracy --no-speed  # forward-model renders

Accuracy: turned up to ±40°, camera pitch/yaw up to 10°, noise, blur, JPEG, vignetting, over
plain, twills, satins 5 and 8, basket and a custom 6×4 repeat (tests/prepare/cases.py).
Targets: median turn error ≤ 0.3°, max ≤ 1°; pitch error ≤ 2 %; repeat in yarns exact on
≥ 90 %; residual skew ≤ 1 %. Forward: renders of weavecap's own forward model
(tests/prepare/forward.py: random fabrics over Table 1 — plain, twill, satin, basket, rib and
random patterns up to 8×8 — turned up to ±40°, perspective camera of 12°, noise, JPEG 90;
the truth is the pattern's minimum repeat per axis), same targets but skew. Speed: wall time
of ``prepare_photo`` (photo already decoded) for a 1-megapixel and a 24-megapixel photo;
targets ≤ 2 s and ≤ 6 s.
"""

from __future__ import annotations

import argparse
import glob
import os
import sys
import time
from pathlib import Path

import cv2
import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests" / "prepare"))
sys.path.insert(0, str(HERE.parent))

from cases import draw_cases, measure, render  # noqa: E402

from weavecap.prepare import Prepared, prepare_photo  # noqa: E402

FORWARD_FAMILIES = ("plain", "twill", "satin", "basket", "rib", "random")


def accuracy(n: int, seed: int) -> bool:
    rows, rejected = [], []
    t0 = time.perf_counter()
    for kw in draw_cases(n, seed=seed):
        img, truth = render(**kw)
        r = prepare_photo(img)
        if not isinstance(r, Prepared):
            rejected.append((kw["pattern"], r.reason))
            continue
        m = measure(r, truth, img.shape[:2])
        m["pattern"] = kw["pattern"]
        rows.append(m)
    dt = time.perf_counter() - t0
    turn = np.array([m["turn_err"] for m in rows])
    pitch = np.array([m["pitch_err"] for m in rows])
    skew = np.array([m["skew"] for m in rows])
    persp = np.array([m["perspective"] for m in rows])
    rep = np.array([m["repeat_ok"] for m in rows], float)
    rep_all = rep.sum() / n
    print(f"accuracy: {n} synthetic photos (384×384, seed {seed}), {dt:.1f} s; {len(rejected)} rejected")
    print(f"  turn error      median {np.median(turn):.3f}°  max {turn.max():.3f}°   (target ≤ 0.3 / ≤ 1)")
    print(f"  pitch error     median {100 * np.median(pitch):.2f} %  max {100 * pitch.max():.2f} %   (target ≤ 2 %)")
    print(f"  repeat exact    {100 * rep_all:.1f} % of all photos   (target ≥ 90 %)")
    print(f"  residual skew   median {100 * np.median(skew):.3f} %  max {100 * skew.max():.3f} %   (target ≤ 1 %)")
    print(f"  residual persp. median {100 * np.median(persp):.3f} %  max {100 * persp.max():.3f} %")
    for pat in sorted({m["pattern"] for m in rows}):
        sub = [m for m in rows if m["pattern"] == pat]
        print(f"    {pat:11s} n={len(sub):3d} repeat exact {100 * np.mean([m['repeat_ok'] for m in sub]):5.1f} %  "
              f"max pitch err {100 * max(m['pitch_err'] for m in sub):.2f} %  max turn {max(m['turn_err'] for m in sub):.3f}°")
    for pat, why in rejected:
        print(f"    rejected {pat}: {why}")
    return (np.median(turn) <= 0.3 and turn.max() <= 1 and pitch.max() <= 0.02 and rep_all >= 0.9
            and skew.max() <= 0.01)


def forward(n: int, seed: int, size: int) -> bool:
    """Accuracy on ``n`` renders of the forward model (cycling over the pattern families)."""
    from forward import forward_photo, measure_forward

    rng = np.random.default_rng(seed)
    rows, rejected, t_render, t_prep = [], [], 0.0, 0.0
    for k in range(n):
        t = time.perf_counter()
        img, truth = forward_photo(rng, family=FORWARD_FAMILIES[k % len(FORWARD_FAMILIES)], size=size, seed=k)
        t_render += time.perf_counter() - t
        t = time.perf_counter()
        r = prepare_photo(img)
        t_prep += time.perf_counter() - t
        if not isinstance(r, Prepared):
            rejected.append((k, truth.family, truth.yarns, r.reason))
            continue
        m = measure_forward(r, truth)
        rows.append(m)
        if not m["repeat_ok"]:
            print(f"    #{k} {truth.family} {truth.yarns[0]}×{truth.yarns[1]} "
                  f"found {r.grid.yarns[0]}×{r.grid.yarns[1]} "
                  f"(pitch {truth.pitch_px:.1f} px, turn {truth.rotate_deg:.1f}°)")
    turn = np.array([m["turn_err"] for m in rows])
    pitch = np.array([m["pitch_err"] for m in rows])
    rep_all = sum(m["repeat_ok"] for m in rows) / n
    print(f"forward model: {n} renders ({size} px, seed {seed}), rendering {t_render:.0f} s, prepare {t_prep:.0f} s; "
          f"{len(rejected)} rejected")
    print(f"  turn error      median {np.median(turn):.3f}°  max {turn.max():.3f}°   (target ≤ 0.3 / ≤ 1)")
    print(f"  pitch error     median {100 * np.median(pitch):.2f} %  max {100 * pitch.max():.2f} %   (target ≤ 2 %)")
    print(f"  repeat exact    {100 * rep_all:.1f} % of all renders   (target ≥ 90 %)")
    for k, fam, yarns, why in rejected:
        print(f"    rejected #{k} {fam} {yarns[0]}×{yarns[1]}: {why}")
    return np.median(turn) <= 0.3 and turn.max() <= 1 and pitch.max() <= 0.02 and rep_all >= 0.9


def big_photo(height: int, width: int, pitch: float, seed: int = 0) -> np.ndarray:
    """A synthetic photo of ``height × width`` px: rendered at ≤ 1.5 MP and enlarged (cubic)."""
    f = max(1.0, np.sqrt(height * width / 1.5e6))
    h, w = int(round(height / f)), int(round(width / f))
    img, _ = render("twill_2_1", size=(h, w), pitch_px=pitch / f, angle_deg=17, pitch_deg=6, yaw_deg=-4,
                    noise=0.01, blur=0.5, vignette=0.3, seed=seed, supersample=1)
    if f > 1:
        img = cv2.resize(img, (width, height), interpolation=cv2.INTER_CUBIC)
    return np.clip(img, 0, 1)


def speed(repeats: int) -> bool:
    ok = True
    prepare_photo(big_photo(256, 256, 8))  # warm-up: imports, first calls
    for label, (h, w), pitch, limit in (("1 MP", (1000, 1000), 12, 2.0), ("24 MP", (4000, 6000), 40, 6.0)):
        img = big_photo(h, w, pitch)
        times = []
        for _ in range(repeats):
            t = time.perf_counter()
            r = prepare_photo(img)
            times.append(time.perf_counter() - t)
        stages = ", ".join(f"{k} {v:.2f}" for k, v in r.timings_s.items()) if isinstance(r, Prepared) else r.reason
        best = min(times)
        ok &= best <= limit
        print(f"speed {label:5s} ({w}×{h}): best {best:.2f} s, median {np.median(times):.2f} s of {repeats} "
              f"(target ≤ {limit:.0f} s) [{stages}]")
    return ok


def realdata(root: str) -> None:
    from weavecap.errors import PhotoError
    from weavecap.photo import load_photo

    print(f"real photos under {root}:")
    print(f"  {'photo':58s} {'status':9s} {'angle°':>7s} {'pitch px (warp, weft)':>22s} {'repeat':>7s}  reason")
    files = sorted(glob.glob(os.path.join(root, "images", "*", "*"))) + sorted(glob.glob(os.path.join(root, "raw", "*")))
    for f in files:
        name = os.path.relpath(f, root)
        try:
            ph = load_photo(f)
        except PhotoError as exc:
            print(f"  {name:58s} {'unreadable':9s} {'':>7s} {'':>22s} {'':>7s}  {str(exc)[:90]}")
            continue
        r = prepare_photo(ph.rgb)
        if isinstance(r, Prepared):
            g = r.grid
            pin = tuple(p / r.rectification.scale for p in g.pitch_px)
            print(f"  {name:58s} {'ok':9s} {r.rectification.rotation_deg:7.2f} "
                  f"{pin[0]:10.1f} {pin[1]:10.1f}  {g.yarns[0]:>3d}×{g.yarns[1]:<3d}")
        else:
            print(f"  {name:58s} {'rejected':9s} {'':>7s} {'':>22s} {'':>7s}  {r.code}: {r.reason[:80]}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", type=int, default=80)
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--no-speed", action="store_true")
    ap.add_argument("--no-accuracy", action="store_true")
    ap.add_argument("--forward", type=int, default=0, metavar="N", help="also N renders of the forward model")
    ap.add_argument("--forward-size", type=int, default=512, help="side of those renders (px)")
    ap.add_argument("--realdata", metavar="DIR", help="also tabulate the real photos of DIR (shared/realdata)")
    a = ap.parse_args()
    ok = True
    if not a.no_accuracy:
        ok &= accuracy(a.cases, a.seed)
    if a.forward:
        ok &= forward(a.forward, a.seed, a.forward_size)
    if not a.no_speed:
        ok &= speed(a.repeats)
    if a.realdata:
        realdata(a.realdata)
    print("all targets met" if ok else "SOME TARGETS MISSED")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
