#!/usr/bin/env python3
"""A batch on a local Dask cluster against the same batch with ``--jobs``.

    .venv/bin/python scripts/bench_batch.py                  # 24 photos, 2 workers, draft
    .venv/bin/python scripts/bench_batch.py --photos 8 --workers 2 --size 96

Makes ``--photos`` synthetic photos (the fixture fabrics in turn, ``--size`` px, 4x4 repeats,
each with its own noise seed), then fits them twice, back to back in this one run: ``weavecap
fit --jobs N`` and ``weavecap fit --scheduler local:N``, each in a fresh process, from an empty
output folder, at ``--quality``. Prints each wall time, their ratio (goal: Dask ≤ 1.15× jobs),
whether the two runs' summary lines agree (but for the seconds), and the load average before
and after, since other work on the machine inflates both.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
WEAVECAP = [sys.executable, "-m", "weavecap.cli.main"]


def make_photos(folder: Path, n: int, size: int) -> list[Path]:
    params = sorted((ROOT / "fixtures" / "params").glob("*.json"))
    photos = []
    for k in range(n):
        p = params[k % len(params)]
        photo = folder / f"{k:02d}_{p.stem}.png"
        subprocess.run([*WEAVECAP, "synth", str(p), "-o", str(photo), "--tiles", "4x4", "--size", str(size),
                        "--seed", str(k), "-q"], check=True)
        photos.append(photo)
    return photos


def timed_fit(photos: list[Path], out: Path, how: list[str], quality: str) -> float:
    t = time.perf_counter()
    proc = subprocess.run([*WEAVECAP, "fit", *map(str, photos), "-o", str(out), "--quality", quality, "-q", *how])
    if proc.returncode not in (0, 3):
        raise SystemExit(f"weavecap fit {' '.join(how)} exited {proc.returncode}")
    return time.perf_counter() - t


def lines(out: Path) -> list[dict]:
    rows = [json.loads(x) for x in (out / "summary.jsonl").read_text().splitlines()]
    return sorted((dict(r, seconds=None, folder=Path(r["folder"]).name) for r in rows), key=lambda r: r["photo"])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--photos", type=int, default=24)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--quality", default="draft")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="weavecap-bench-batch-") as tmp:
        work = Path(tmp)
        photos = make_photos(work / "photos", a.photos, a.size)
        load0 = os.getloadavg()
        t_jobs = timed_fit(photos, work / "jobs", ["--jobs", str(a.workers)], a.quality)
        t_dask = timed_fit(photos, work / "dask", ["--scheduler", f"local:{a.workers}"], a.quality)
        load1 = os.getloadavg()
        same = lines(work / "jobs") == lines(work / "dask")
    print(f"{a.photos} photos ({a.size} px, {a.quality}), {a.workers} workers, {os.cpu_count()} cores")
    print(f"  --jobs {a.workers}:              {t_jobs:7.1f} s")
    print(f"  --scheduler local:{a.workers}:   {t_dask:7.1f} s")
    print(f"  ratio Dask / jobs:      {t_dask / t_jobs:7.3f}   (goal ≤ 1.15)")
    print(f"  same summary lines:     {same}")
    print(f"  load average before {load0[0]:.2f}, after {load1[0]:.2f} (1 min)")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
