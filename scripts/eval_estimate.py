"""Measure the pre-estimation (Wu et al. 2025 §5) on held-out synthetic photos.

Each photo: a random pattern (plain, twill, satin, basket, rib, random; up to 16 × 16) and
parameters over Table 1 (:mod:`weavecap.estimate.sampling`, a seed the training never used),
rendered by the forward model as 2 × 2 repeats under the default light rig at ``--cell-px``
pixels per yarn, then blurred (σ = 1 px) and given pixel noise (σ = 0.005) like a regularized
photo. The grid is known from the render (one repeat from a random yarn, so the answer is
defined up to a cyclic shift). Reported:

- pattern: exact up to a cyclic shift (share of photos), right cells (share of all cells);
- colours: CIE76 ΔE of the warp and weft body colours against the truth, end to end (other
  parameters as pre-estimated) and with the true other parameters (the colour stage alone),
  the latter also over the yarns whose body colour shows (sensitivity ≥ ``VISIBLE``);
- initializer: per parameter, the mean absolute error of the network's prediction and of
  always predicting the middle of the Table 1 range, beside how much the parameter shows in a
  photo at all: the RMS change of the 6 × 6-cell render (clipped to [0, 1], blurred) when it moves from the bottom to the
  top of its range, everything else held (mean over ``--visibility`` random fabrics);
- times.

Usage:  python scripts/eval_estimate.py --photos 60 --out eval.json
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import cv2
import numpy as np

from weavecap.estimate.cells import CellGrid, cell_canvas
from weavecap.estimate.colour import delta_e, estimate_colours
from weavecap.estimate.initializer import CELL_PX, OUTPUT_KEYS, default_values, load_predictor
from weavecap.estimate.preestimate import PATTERN_CELL_PX, pre_estimate
from weavecap.estimate.sampling import random_fabric, random_pattern
from weavecap.estimate.weave_name import shift_agreement, weave_name
from weavecap.model.render import render_numpy
from weavecap.model.scene import View, build_scene


VISIBLE = 0.1  # a yarn's body colour "shows" when its cell average moves ≥ 0.1 per unit albedo


def synthetic_photo(rng: np.random.Generator, *, cell_px: int, max_size: int):
    """(photo (H, W, 3), CellGrid of one repeat, true Fabric, family)."""
    big = rng.random() < 0.15
    family, pattern = random_pattern(rng, family="random" if big else None, max_size=16 if big else max_size)
    if big:  # a large random repeat, at least 10 yarns on one side
        from weavecap.estimate.sampling import random_binary
        pattern = random_binary(rng, (int(rng.integers(10, 17)), int(rng.integers(6, 17))))
    fabric = random_fabric(rng, pattern)
    n_e, n_a = fabric.shape
    fs = build_scene(fabric, View(tiles=(2, 2), size=2 * cell_px * max(n_e, n_a), spp=4), light="both")
    photo = render_numpy(fs)
    photo = cv2.GaussianBlur(photo, (0, 0), 1.0)
    photo = photo + rng.normal(0.0, 0.005, photo.shape).astype(np.float32)
    origin = (cell_px * int(rng.integers(n_e)), cell_px * int(rng.integers(n_a)))
    return photo, CellGrid.regular((n_e, n_a), cell_px, origin), fabric, family


def visibility(rng: np.random.Generator, fabrics: int) -> dict:
    """Per output key: RMS change of the image (clipped, blurred by σ = pitch / 16 as the test
    photos are), linear RGB, from the bottom to the top of its range."""
    from weavecap.training.initializer import render_window
    from weavecap.params import FIT_RANGES

    out = {k: [] for k in OUTPUT_KEYS}
    for _ in range(fabrics):
        fabric = random_fabric(rng, random_pattern(rng)[1])
        fs = render_window(fabric, spp=4)
        for key in OUTPUT_KEYS:
            lo_v, hi_v = FIT_RANGES[key]
            images = []
            for v in (lo_v, hi_v):
                value = (v,) * 3 if isinstance(fabric.get(key), tuple) else v
                fs.set(key, value)
                # as the photos: clipped, blurred like a regularized photo (σ = pitch / 16)
                images.append(cv2.GaussianBlur(np.clip(render_numpy(fs), 0.0, 1.0), (0, 0), CELL_PX / 16))
            fs.set(key, fabric.get(key))
            if key in ("warp.radius", "weft.radius"):
                fs = render_window(fabric, spp=4)
            out[key].append(float(np.sqrt(np.mean(np.square(images[1] - images[0])))))
    return {k: round(float(np.mean(v)), 4) for k, v in out.items()}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--photos", type=int, default=60)
    ap.add_argument("--seed", type=int, default=20261126, help="held-out seed (training uses its own)")
    ap.add_argument("--cell-px", type=int, default=16, help="photo pixels per yarn")
    ap.add_argument("--max-size", type=int, default=8, help="largest repeat of the named families")
    ap.add_argument("--visibility", type=int, default=6, help="fabrics for the per-parameter visibility")
    ap.add_argument("--out", default=None, help="write the figures as JSON here")
    args = ap.parse_args(argv)

    predictor = load_predictor()
    rng = np.random.default_rng(args.seed)
    lo = {k: np.atleast_1d(np.asarray(v, dtype=float)) for k, v in default_values().items()}
    rows, net_err, mid_err = [], {k: [] for k in OUTPUT_KEYS}, {k: [] for k in OUTPUT_KEYS}
    for n in range(args.photos):
        photo, grid, truth, family = synthetic_photo(rng, cell_px=args.cell_px, max_size=args.max_size)
        t0 = time.perf_counter()
        est = pre_estimate(photo, grid)
        seconds = time.perf_counter() - t0
        agree, _ = shift_agreement(est.fabric.pattern, truth.pattern)
        # the colour stage alone: the true pattern and other parameters
        canvas = cell_canvas(photo, grid, PATTERN_CELL_PX)
        shift = (-int(round(grid.rows[0] / args.cell_px)), -int(round(grid.cols[0] / args.cell_px)))
        aligned = truth.replace({"pattern": np.roll(truth.pattern, shift, axis=(0, 1))})  # the grid's first cell
        alone = estimate_colours(canvas, aligned, cell_px=PATTERN_CELL_PX)
        row = {"family": family, "shape": list(truth.shape), "weave": weave_name(truth.pattern),
               "estimated_weave": est.weave, "exact": agree == 1.0, "cells_right": agree,
               "cells": int(truth.pattern.size),
               "de_warp": float(delta_e(est.colours.warp, truth.warp.body_reflection)),
               "de_weft": float(delta_e(est.colours.weft, truth.weft.body_reflection)),
               "de_specular": float(delta_e(est.colours.specular, truth.specular.reflection)),
               "de_warp_alone": float(delta_e(alone.warp, truth.warp.body_reflection)),
               "de_weft_alone": float(delta_e(alone.weft, truth.weft.body_reflection)),
               "sensitivity": list(alone.sensitivity),
               "source": est.source, "seconds": seconds, "renders": est.pattern.renders}
        if predictor is not None:
            t1 = time.perf_counter()
            pred = predictor.predict(cell_canvas(photo, grid, CELL_PX), est.fabric.pattern)
            row["inference_s"] = time.perf_counter() - t1
            for key in OUTPUT_KEYS:
                true = np.atleast_1d(np.asarray(truth.get(key), dtype=float))
                net_err[key].append(float(np.abs(np.atleast_1d(pred[key]) - true).mean()))
                mid_err[key].append(float(np.abs(lo[key] - true).mean()))
        rows.append(row)
        print(f"{n + 1:3d} {row['weave']:<26s} → {est.weave:<26s} cells {agree:.3f} "
              f"ΔE warp {row['de_warp']:5.1f} weft {row['de_weft']:5.1f} (alone {row['de_warp_alone']:4.1f} "
              f"{row['de_weft_alone']:4.1f}) {est.source:8s} {seconds:5.1f} s", file=sys.stderr)

    des = np.array([[r["de_warp"], r["de_weft"]] for r in rows])
    des_alone = np.array([[r["de_warp_alone"], r["de_weft_alone"]] for r in rows])
    cells = np.array([r["cells"] for r in rows])
    visible = np.array([r["sensitivity"] for r in rows]) >= VISIBLE
    summary = {
        "photos": len(rows), "seed": args.seed, "cell_px": args.cell_px,
        "pattern_exact_share": float(np.mean([r["exact"] for r in rows])),
        "cells_right_share": float(np.sum([r["cells_right"] * r["cells"] for r in rows]) / cells.sum()),
        "colour_de_le5_share": float(np.mean(des <= 5.0)),
        "colour_de_median": float(np.median(des)),
        "colour_alone_de_le5_share": float(np.mean(des_alone <= 5.0)),
        "colour_alone_de_median": float(np.median(des_alone)),
        "colour_alone_visible_de_le5_share": float(np.mean(des_alone[visible] <= 5.0)) if visible.any() else None,
        "colour_visible_yarns": int(visible.sum()),
        "specular_de_median": float(np.median([r["de_specular"] for r in rows])),
        "network_used_share": float(np.mean([r["source"] == "network" for r in rows])),
        "seconds_median": float(np.median([r["seconds"] for r in rows])),
        "seconds_max": float(np.max([r["seconds"] for r in rows])),
    }
    vis = visibility(np.random.default_rng(args.seed + 1), args.visibility) if args.visibility else {}
    if predictor is not None:
        summary["inference_s_max"] = float(max(r["inference_s"] for r in rows))
        summary["initializer_mae"] = {k: {"network": round(float(np.mean(net_err[k])), 4),
                                          "middle": round(float(np.mean(mid_err[k])), 4),
                                          "ratio": round(float(np.mean(net_err[k]) / np.mean(mid_err[k])), 3),
                                          "visibility_rms": vis.get(k)}
                                      for k in OUTPUT_KEYS}
    by_family = {}
    for r in rows:
        f = by_family.setdefault(r["family"], {"photos": 0, "exact": 0})
        f["photos"] += 1
        f["exact"] += int(r["exact"])
    summary["by_family"] = by_family
    print(json.dumps(summary, indent=1))
    if args.out:
        with open(args.out, "w") as fh:
            json.dump({"summary": summary, "photos": rows}, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
