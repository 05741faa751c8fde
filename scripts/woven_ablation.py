"""Ablations of the woven network's choices (docs/woven.md): the same data, the same number of
steps and schedule, one change at a time; held-out RGB errors of each.

    .venv/bin/python scripts/woven_ablation.py WORK/woven/data --steps 2000 \
        ours paper features-only small-encoder > ablation.json

Variants: ``ours`` (the shipped design: map statistics + the prefiltered guess corrected),
``paper`` (Chen et al.'s decoder: one-blob footprint only, outputs from scratch),
``features-only`` (map statistics, no prefiltered guess), ``small-encoder`` (ours with an
encoder of half the width).
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
import time
from pathlib import Path

VARIANTS = {
    "ours": {},
    "paper": {"use_features": False, "use_baseline": False},
    "features-only": {"use_baseline": False},
    "small-encoder": {"encoder_widths": (8, 16, 32, 32)},
}


def main() -> None:
    from weavecap.training import woven as train

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("data", type=Path, help="a data folder made by weavecap train-renderer (WORK/woven/data)")
    parser.add_argument("variants", nargs="+", choices=sorted(VARIANTS))
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--fabrics", type=int, default=320)
    args = parser.parse_args()
    config = train.DataConfig(fabrics=args.fabrics)
    dataset = train.Dataset(args.data, config)
    out = {"steps": args.steps, "queries": int(len(dataset.inputs)),
           "prefilter_only": train.evaluate(None, dataset, dataset.held_materials, baseline_only=True)}
    for name in args.variants:
        folder = Path(tempfile.mkdtemp(prefix=f"woven-{name}-"))
        t0 = time.perf_counter()
        model, summary = train.train(dataset, folder, train.TrainConfig(steps=args.steps, checkpoint_every=10 ** 9,
                                                                         **VARIANTS[name]))
        out[name] = {"seconds": time.perf_counter() - t0, "final_loss": summary["history"][-1],
                     "parameters": int(sum(p.numel() for p in model.parameters())),
                     "held_out": train.evaluate(model, dataset, dataset.held_materials)}
        shutil.rmtree(folder, ignore_errors=True)
        print(f"{name}: held-out rel MSE {out[name]['held_out']['all']['rel_mse']:.4f} "
              f"({out[name]['seconds']:.0f} s)", file=sys.stderr, flush=True)
    json.dump(out, sys.stdout, indent=1)


if __name__ == "__main__":
    main()
