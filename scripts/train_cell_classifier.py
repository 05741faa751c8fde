"""Train the cell classifier (weavecap/estimate/cell_classifier.py) on procedural woven images.

    python scripts/train_cell_classifier.py                      # the shipped weights' settings
    python scripts/train_cell_classifier.py --work /tmp/cells --out weavecap/estimate/weights

Data shards and a checkpoint go to --work (an interrupted run resumes there); the weights
(cell_classifier.npz) and their record (cell_classifier.json: settings, held-out accuracy per
weave kind, the logits' temperature, seconds) to --out. One CPU thread.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from weavecap.estimate.cell_classifier import weights_dir
from weavecap.training.cell_classifier import CellTrainConfig, run


def main() -> None:
    defaults = CellTrainConfig()
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", type=Path, default=Path("cell-classifier-work"), help="data shards and checkpoint")
    ap.add_argument("--out", type=Path, default=weights_dir(), help="where the weights and record go")
    ap.add_argument("--seed", type=int, default=defaults.seed)
    ap.add_argument("--images", type=int, default=defaults.images)
    ap.add_argument("--epochs", type=int, default=defaults.epochs)
    args = ap.parse_args()
    config = CellTrainConfig(seed=args.seed, images=args.images, epochs=args.epochs)
    record = run(args.work, args.out, config, progress=lambda s: print(s, flush=True))
    print({k: record[k] for k in ("heldout", "temperature", "parameters")})


if __name__ == "__main__":
    main()
