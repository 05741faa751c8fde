#!/usr/bin/env python3
"""How much the tube sweep of a commit changes renders.

    .venv/bin/python scripts/compare_tubes.py [--before REV] [--radii 1.5,2.5,own] [--size 256]

Renders every fixture fabric (fixtures/params) with the yarn meshes of ``weavecap.model.geometry``
as it is now and as it was at ``--before`` (git show REV:weavecap/model/geometry.py, loaded
in the same process), at each radius of ``--radii`` (``own``: the fixture's radii), one repeat
tiled 2×2 under the default light rig, orthographic, 4 spp, and prints the PSNR of the two
renders (clipped to [0, 1], peak 1) — ∞ where they are identical.
"""

from __future__ import annotations

import argparse
import importlib.util
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def old_geometry(rev: str):
    source = subprocess.run(["git", "-C", str(ROOT), "show", f"{rev}:weavecap/model/geometry.py"], check=True,
                            capture_output=True, text=True).stdout
    path = Path(tempfile.mkdtemp()) / "geometry_before.py"
    path.write_text(source)
    spec = importlib.util.spec_from_file_location("geometry_before", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--before", default="HEAD~1")
    ap.add_argument("--radii", default="1.5,2.5,own")
    ap.add_argument("--size", type=int, default=256)
    a = ap.parse_args()
    from weavecap import params
    from weavecap.model import scene
    from weavecap.model.render import render_numpy
    from weavecap.report import psnr

    now, before = scene.fabric_meshes, old_geometry(a.before).fabric_meshes
    print(f"PSNR (dB) of renders with the tubes of {a.before} against now; {a.size} px, 2x2 repeats, 4 spp")
    radii = a.radii.split(",")
    print(f"  {'fixture':14s} " + " ".join(f"{'r=' + r:>12s}" for r in radii))
    for path in sorted((ROOT / "fixtures" / "params").glob("*.json")):
        fabric = params.load(path)
        cells = []
        for r in radii:
            f = fabric if r == "own" else fabric.replace({"warp.radius": float(r), "weft.radius": float(r)})
            images = []
            for meshes in (before, now):
                scene.fabric_meshes = meshes
                fs = scene.build_scene(f, scene.View(tiles=(2, 2), size=a.size, spp=4), light="both")
                images.append(render_numpy(fs))
            scene.fabric_meshes = now
            value = psnr(images[0], images[1]) if not np.array_equal(images[0], images[1]) else float("inf")
            label = f"{value:.1f}" if np.isfinite(value) else "inf"
            if r == "own":
                label += f" ({f.warp.radius:g}/{f.weft.radius:g})"
            cells.append(label)
        print(f"  {path.stem:14s} " + " ".join(f"{c:>12s}" for c in cells))
    return 0


if __name__ == "__main__":
    sys.exit(main())
