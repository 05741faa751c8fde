"""Measure the cell lattice's phase against the bench photos' known yarn crossings (issue 11).

For every photo of the fit bench's independent set (:func:`weavecap.fit_bench.make_independent_photos`)
and own-render set (:func:`weavecap.fit_bench.make_photos`): prepare it as ``weavecap fit``
does, align the repeat's cells (:func:`weavecap.fit.target.align_cells`) and compare their
centres with the generator's yarn crossings (:func:`weavecap.fit_bench.crossing_phase`); an
axis more than a quarter cell off is on the wrong half of the cell
(:func:`weavecap.fit_bench.lattice_error`). No fits. Prints one line a photo and the count of
wrong axes per set; ``--json`` also writes the lattices (to check that a change left one
bit-identical). Run: ``nice -n 10 .venv/bin/python scripts/measure_phase.py --folder /tmp/phase``
(the photos are made once into the folder and reused); docs/capture.md quotes its output.
"""

from __future__ import annotations

import argparse
import json
import pickle
from pathlib import Path

import numpy as np

from weavecap import fit_bench
from weavecap.estimate.weave_name import weave_name
from weavecap.fit.target import align_cells, repeat_cells
from weavecap.photo import load_photo
from weavecap.prepare import Rejected, prepare_photo


def bench_photos(folder: Path, sets: list[str]) -> list[fit_bench.BenchPhoto]:
    """The bench photos of ``sets``, made into ``folder`` unless they are there already."""
    photos = []
    for name in sets:
        where, index = folder / name, folder / f"{name}.pickle"
        if index.exists():
            photos += pickle.loads(index.read_bytes())
            continue
        where.mkdir(parents=True, exist_ok=True)
        make = fit_bench.make_photos if name == "own" else fit_bench.make_independent_photos
        made = make(where, quick=False)
        index.write_bytes(pickle.dumps(made))
        photos += made
    return photos


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--folder", type=Path, required=True, help="where the bench photos are made and kept")
    ap.add_argument("--set", choices=("independent", "own", "both"), default="both")
    ap.add_argument("--json", type=Path, help="write every photo's phase and lattice here")
    args = ap.parse_args()
    sets = ["independent", "own"] if args.set == "both" else [args.set]
    rows, wrong, axes = [], {s: 0 for s in sets}, {s: 0 for s in sets}
    for photo in bench_photos(args.folder, sets):
        prepared = prepare_photo(load_photo(photo.path).rgb)
        if isinstance(prepared, Rejected):
            print(f"{photo.set:11s} {photo.path.name:24s} rejected: {prepared.reason}")
            continue
        cells = align_cells(prepared.regularized.image, repeat_cells(prepared, prepared.regularized.box))
        phase = fit_bench.crossing_phase(photo, prepared, cells)
        bad = fit_bench.lattice_error(phase)
        wrong[photo.set] += int(bad.sum())
        axes[photo.set] += 2
        print(f"{photo.set:11s} {photo.path.name:24s} {weave_name(photo.true_pattern):22s} repeat "
              f"{cells.shape[0]}x{cells.shape[1]}  phase rows {phase[0]:+.3f} cols {phase[1]:+.3f}  "
              f"wrong: {'rows ' if bad[0] else ''}{'cols' if bad[1] else ''}", flush=True)
        rows.append({"set": photo.set, "photo": photo.path.name, "phase": phase.tolist(), "wrong": bad.tolist(),
                     "rows": cells.rows.tolist(), "cols": cells.cols.tolist()})
    for s in sets:
        print(f"{s}: axes more than a quarter cell off the crossings {wrong[s]}/{axes[s]}")
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
