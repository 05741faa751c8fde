"""Speed and memory of the forward model, for ``weavecap bench`` and docs/performance.md.

Each case runs in a fresh process with an empty Dr.Jit kernel cache, so "cold" is what a user
waits for the first time (tracing + compiling every kernel) and "warm" the median of later
calls in the same process. Two kinds of call are timed:

- *render*: a new view — the geometry pass (camera, shadow and exit-point rays) and shading;
- *fit step*: what each iteration of a fit does — shading the cached G-buffer with new
  parameter values (:func:`weavecap.model.render.render`), forward only or forward+backward
  (the MSE's gradient with respect to every continuous parameter but the radii).

Peak memory is the child process's maximum resident set size.
"""

from __future__ import annotations

import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from ..fixtures import path as fixture_path

FIXTURE = fixture_path("params", "twill_2_1.json")


@dataclass(frozen=True)
class Case:
    """One measured configuration."""

    name: str
    tiles: tuple[int, int]
    size: int
    spp: int


CASES = (Case("one repeat, 128×128", (1, 1), 128, 4), Case("photo 4×4 repeats, 512×512", (4, 4), 512, 4))
WARM_CALLS = 7


def _timed(fn, calls: int) -> tuple[float, float]:
    """(first call, median of ``calls`` later calls), seconds."""
    t = time.perf_counter()
    fn()
    first = time.perf_counter() - t
    times = []
    for _ in range(calls):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return first, statistics.median(times)


def measure(case: Case, params_path: Path = FIXTURE) -> dict:
    """Time one case in this process (call it in a fresh one for honest cold figures)."""
    import numpy as np

    from weavecap import params
    from weavecap.model.render import mse_and_gradients, render_numpy
    from weavecap.model.scene import GEOMETRY_KEYS, View, build_scene
    from weavecap.params import CONTINUOUS_KEYS

    t0 = time.perf_counter()
    fabric = params.load(params_path)
    scene = build_scene(fabric, View(tiles=case.tiles, size=case.size, spp=case.spp))
    setup = time.perf_counter() - t0
    keys = [k for k in CONTINUOUS_KEYS if k not in GEOMETRY_KEYS]

    def new_view():
        scene.cache.clear()
        return render_numpy(scene)

    out = {"case": case.name, "pixels": case.size, "spp": case.spp, "setup_s": setup}
    out["render"] = _timed(new_view, WARM_CALLS)  # first: the process's first render, compiling
    target = np.clip(render_numpy(scene) * 0.9 + 0.02, 0, None).astype(np.float32)
    out["step_forward"] = _timed(lambda: render_numpy(scene), WARM_CALLS)
    out["step_forward_backward"] = _timed(lambda: mse_and_gradients(scene, target, keys), WARM_CALLS)
    out["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return out


def run_cold(case: Case) -> dict:
    """:func:`measure` in a child process with an empty kernel cache."""
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, DRJIT_CACHE_DIR=cache)
        proc = subprocess.run([sys.executable, "-m", "weavecap.bench.model", "--child", case.name],
                              env=env, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise RuntimeError(f"benchmark case {case.name!r} failed:\n{proc.stderr[-2000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def table(results: list[dict]) -> str:
    """docs/performance.md's table (markdown)."""
    lines = ["| case | call | cold (first) | warm (median) |", "|---|---|---|---|"]
    labels = (("render", "render (new view: rays + shading)"), ("step_forward", "fit step, forward"),
              ("step_forward_backward", "fit step, forward + backward"))
    for r in results:
        for key, label in labels:
            cold, warm = r[key]
            lines.append(f"| {r['case']}, {r['spp']} spp | {label} | {cold:.2f} s | {warm * 1e3:.1f} ms |")
        lines.append(f"| {r['case']} | scene set-up (load params, build meshes) | {r['setup_s']:.2f} s | |")
        lines.append(f"| {r['case']} | peak memory (process) | {r['peak_rss_mb']:.0f} MB | |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    """``python -m weavecap.bench.model --child CASE``: measure one case, print it as JSON (what
    :func:`run_cold` runs in a fresh process)."""
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] != ["--child"] or len(argv) != 2:
        raise SystemExit("usage: python -m weavecap.bench.model --child CASE (use `weavecap bench`)")
    case = next(c for c in CASES if c.name == argv[1])
    print(json.dumps(measure(case)))


if __name__ == "__main__":
    main()
