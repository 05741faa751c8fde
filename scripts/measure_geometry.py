"""Measure the two ways Mitsuba can draw yarns on weavecap's own scenes: ``bsplinecurve`` shapes
and triangle tubes swept along the same splines (weavecap.model.geometry).

For each scene: the same camera rays and shadow rays (the integrator's workload) cast against
both, first call in the process and the warm median, plus whether they agree on what is hit.
Run: ``.venv/bin/python scripts/measure_geometry.py``; docs/model.md quotes its output.
"""

from __future__ import annotations

import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from weavecap import params
from weavecap.model.geometry import control_points
from weavecap.model.render import _camera_rays
from weavecap.model.scene import View, build_scene

mi = __import__("weavecap.backend", fromlist=["mitsuba"]).mitsuba()
import drjit as dr  # noqa: E402

FIXTURE = Path(__file__).resolve().parents[1] / "fixtures" / "params" / "twill_2_1.json"
LIGHTS = [(0.25, -0.35, 1.0), (1.0, 0.0, 0.45), (-1.0, 0.0, 0.45)]


def curve_scene(fs, directory: Path):
    """A scene of bsplinecurve shapes on the control points the tubes are swept along."""
    fab = fs.fabric
    curves = control_points(fab.pattern, r_warp=fab.warp.radius, r_weft=fab.weft.radius,
                            rows=fs.frame.rows, cols=fs.frame.cols)
    shapes = {"type": "scene"}
    for name, pts, radius in (("wefts", curves.weft, fab.weft.radius), ("warps", curves.warp, fab.warp.radius)):
        path = directory / f"{name}.txt"
        path.write_text("\n\n".join("\n".join(f"{x} {y} {z} {radius}" for x, y, z in c) for c in pts) + "\n")
        shapes[name] = {"type": "bsplinecurve", "filename": str(path)}
    return mi.load_dict(shapes)


def cast(scene, ray):
    """Primary hits plus one shadow ray per front light, evaluated."""
    si = scene.ray_intersect(ray)
    out = [si.is_valid(), si.t]
    for d in LIGHTS:
        d = dr.normalize(mi.Vector3f(*d))
        out.append(scene.ray_test(si.spawn_ray(d), si.is_valid()))
    dr.eval(out)
    dr.sync_thread()  # kernels run asynchronously: wait, or the timing is of the launch
    return si.is_valid()


def timed(scene, ray, repeats: int = 7):
    t = time.perf_counter()
    hit = cast(scene, ray)
    first = time.perf_counter() - t
    warm = []
    for _ in range(repeats):
        t = time.perf_counter()
        cast(scene, ray)
        warm.append(time.perf_counter() - t)
    return first, statistics.median(warm), np.array(hit, dtype=bool)


def main() -> None:
    fabric = params.load(FIXTURE)
    print("| scene | rays | tubes first / warm | curves first / warm | same hit |")
    print("|---|---|---|---|---|")
    for tiles, size, spp in (((1, 1), 128, 4), ((4, 4), 512, 4)):
        fs = build_scene(fabric, View(tiles=tiles, size=size, spp=spp))
        ray, _ = _camera_rays(fs, spp, 0)
        dr.eval(ray)
        with tempfile.TemporaryDirectory() as tmp:
            curves = curve_scene(fs, Path(tmp))
            t_first, t_warm, t_hit = timed(fs.scene, ray)
            c_first, c_warm, c_hit = timed(curves, ray)
        print(f"| {tiles[0]}x{tiles[1]} repeats, {size}² px, {spp} spp | {t_hit.size} | "
              f"{t_first * 1e3:.0f} / {t_warm * 1e3:.1f} ms | {c_first * 1e3:.0f} / {c_warm * 1e3:.1f} ms | "
              f"{np.mean(t_hit == c_hit):.1%} |")


if __name__ == "__main__":
    main()
