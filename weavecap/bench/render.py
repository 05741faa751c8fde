"""Speed, memory and agreement of the output renderers, for ``weavecap bench --render``.

A list of sections (:data:`SECTIONS`); the woven and fold renderers add theirs with
:func:`register_section`. Built in:

- ``reference``: ``weavecap render --mode reference`` of a fixture fabric on the towel
  (``../shared/meshes``, when present) and on every fixture mesh, at 1280×720, 64 spp, path
  depth 8, studio light — against Mitsuba's own ``path`` integrator with a plain ``diffuse``
  BSDF on the same mesh, camera, lights, size, spp and depth. Each mesh runs in a fresh
  process with an empty Dr.Jit kernel cache: *cold* is each renderer's first render (tracing
  and compiling its kernels included), *warm* the fastest of WARM_ROUNDS later ones, taken
  alternately so the machine's load falls on both alike; the bake is timed apart; peak memory
  is the process's maximum resident set after the baseline's first render and at the end.
  The goal: the reference at most 4× the diffuse baseline, as a ratio measured
  side by side.
- ``consistency``: :func:`weavecap.render.consistency.compare_with_synth` for every fixture
  params file at the fixture photos' scale (4×4 repeats, 512 pixels, 64 spp).
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from ..fixtures import path as fixture_path

SHARED_MESHES = Path(__file__).resolve().parents[2] / ".." / "shared" / "meshes"
FABRIC = fixture_path("params", "twill_2_1.json")
SIZE, SPP, DEPTH = (1280, 720), 64, 8
QUICK_MESHES = ("swatch",)
WARM_ROUNDS = 4


@dataclass(frozen=True)
class Section:
    """One part of the render bench: ``run(quick, progress) -> rows`` and ``table(rows) -> str``
    (markdown)."""

    name: str
    title: str
    run: Callable
    table: Callable


SECTIONS: list[Section] = []


def register_section(section: Section) -> None:
    """Add a section (replacing one of the same name)."""
    SECTIONS[:] = [s for s in SECTIONS if s.name != section.name] + [section]


# --------------------------------------------------------------------------------------------
# reference against Mitsuba's path + diffuse


def bench_meshes(quick: bool = False) -> list[tuple[str, Path]]:
    """(name, path): the towel when ../shared is present, then the fixture meshes."""
    from ..render.shapes import FIXTURES

    meshes = []
    towel = SHARED_MESHES / "towel.obj"
    if towel.is_file():
        meshes.append(("towel", towel.resolve()))
    names = QUICK_MESHES if quick else tuple(FIXTURES)
    return meshes + [(name, fixture_path("meshes", f"{name}.obj")) for name in names]


def _scenes(mesh_path: Path) -> tuple[dict, dict]:
    """The two scenes of a bench mesh, built the same way: Mitsuba's ``path`` + ``diffuse``, and
    ``weavecap render``'s reference (bake timed); and what was measured building them."""
    from .. import params
    from ..backend import mitsuba
    from ..render.mesh import load_mesh
    from ..render.run import RenderOptions, prepare_render

    mi = mitsuba()
    t = time.perf_counter()
    mesh = load_mesh(mesh_path)
    info = {"triangles": int(len(mesh.faces)), "mesh_s": time.perf_counter() - t}
    options = RenderOptions(spp=SPP, size=SIZE, max_depth=DEPTH)
    prepared = prepare_render(params.load(FABRIC), mesh, options)  # the diffuse baseline sees its camera and lights
    diffuse = mi.load_dict({"type": "scene", "integrator": {"type": "path", "max_depth": DEPTH},
                            "sensor": prepared.camera.sensor(SPP),
                            "garment": mesh.to_mitsuba(mi.load_dict({"type": "diffuse"})), **prepared.lighting.emitters})
    info.update(bake_s=prepared.timings["bake"], texture_filter=prepared.info["texture_filter"],
                texels_per_yarn=prepared.info["texels_per_yarn"])
    return {"diffuse": diffuse, "reference": prepared.scene}, info


def measure(mesh_path: Path) -> dict:
    """Both renderers on one mesh in this process (call it in a fresh one with an empty kernel
    cache): each one's cold render (its kernels traced and compiled), then WARM_ROUNDS warm
    renders of each, alternating so that the machine's load falls on both alike (the fastest
    is kept); peak memory after the baseline's first render and at the end."""
    from ..render.run import render_passes

    scenes, out = _scenes(mesh_path)
    times: dict[str, list[float]] = {"diffuse": [], "reference": []}
    for name in ("diffuse", "reference"):
        t = time.perf_counter()
        render_passes(scenes[name], SPP, 0)
        out[f"{name}_cold_s"] = time.perf_counter() - t
        if name == "diffuse":
            out["diffuse_peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    for k in range(WARM_ROUNDS):
        for name in ("diffuse", "reference"):
            t = time.perf_counter()
            render_passes(scenes[name], SPP, 1 + k)
            times[name].append(time.perf_counter() - t)
    for name in times:
        out[f"{name}_warm_s"] = min(times[name])
    out["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return out


def _child(args: list[str]) -> dict:
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, DRJIT_CACHE_DIR=cache)
        proc = subprocess.run([sys.executable, "-m", "weavecap.bench.render", "--child", *args], env=env,
                              capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise RuntimeError(f"render bench {args} failed:\n{proc.stderr[-2000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def run_reference(quick: bool = False, progress=None) -> list[dict]:
    """Both renderers on every bench mesh, each mesh in a fresh process."""
    rows = []
    for name, path in bench_meshes(quick):
        if progress:
            progress(f"render bench: {name} ...")
        row = {"mesh": name, "load_average": os.getloadavg()[0], **_child([str(path)])}
        for key in ("cold", "warm"):
            row[f"ratio_{key}"] = row[f"reference_{key}_s"] / row[f"diffuse_{key}_s"]
        rows.append(row)
    return rows


def reference_table(rows: list[dict]) -> str:
    lines = ["| mesh | triangles | `path` + `diffuse` cold / warm | reference cold / warm | ratio cold / warm | "
             "bake | peak memory (diffuse / with reference) |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['mesh']} | {r['triangles']} | {r['diffuse_cold_s']:.1f} / {r['diffuse_warm_s']:.1f} s | "
                     f"{r['reference_cold_s']:.1f} / {r['reference_warm_s']:.1f} s | {r['ratio_cold']:.2f}× / "
                     f"{r['ratio_warm']:.2f}× | {r['bake_s']:.1f} s | {r['diffuse_peak_rss_mb']:.0f} / "
                     f"{r['peak_rss_mb']:.0f} MB |")
    return "\n".join(lines)


# --------------------------------------------------------------------------------------------
# consistency with the forward model


def run_consistency(quick: bool = False, progress=None) -> list[dict]:
    from .. import params
    from ..render.consistency import compare_with_synth

    rows = []
    files = sorted(fixture_path("params").glob("*.json"))
    for path in files[:2] if quick else files:
        if progress:
            progress(f"render bench: consistency, {path.stem} ...")
        result = compare_with_synth(params.load(path), tiles=4, size=512, spp=SPP)
        rows.append({"params": path.stem, "psnr_db": result["psnr_db"], "size": list(result["size"]),
                     "texels_per_yarn": result["texels_per_yarn"], "seconds": result["seconds"]})
    return rows


def consistency_table(rows: list[dict]) -> str:
    lines = ["| fixture | size | texels/yarn | PSNR after 1-px blur | render (bake included) |", "|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['params']} | {r['size'][0]}×{r['size'][1]} | {r['texels_per_yarn']} | "
                     f"{r['psnr_db']:.1f} dB | {r['seconds']:.1f} s |")
    return "\n".join(lines)


register_section(Section("reference", "Reference renderer against Mitsuba's path + diffuse (1280×720, 64 spp, "
                                      "depth 8, studio light)", run_reference, reference_table))
register_section(Section("consistency", "Flat swatch against synth (rig both, 4×4 repeats, 512 px, 64 spp)",
                         run_consistency, consistency_table))


#: optional modules of the other renderers that register a section when imported
PLUGIN_SECTIONS = ("weavecap.bench.woven", "weavecap.bench.fold", "weavecap.bench.agreement")


def _load_plugin_sections() -> None:
    import importlib

    for name in PLUGIN_SECTIONS:
        try:
            importlib.import_module(name)
        except ModuleNotFoundError as exc:
            if exc.name is None or not name.startswith(exc.name):  # it exists, but something it needs does not
                raise


def run(quick: bool = False, progress=None) -> dict:
    """Every section: {name: rows}."""
    _load_plugin_sections()
    return {section.name: section.run(quick, progress) for section in SECTIONS}


def tables(results: dict) -> str:
    """Every section's table under its title (markdown)."""
    parts = []
    for section in SECTIONS:
        if section.name in results:
            parts.append(f"### {section.title}\n\n{section.table(results[section.name])}")
    return "\n\n".join(parts)


def main(argv: list[str] | None = None) -> None:
    """``python -m weavecap.bench.render --child MESH``: measure one mesh, print JSON."""
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] != ["--child"] or len(argv) != 2:
        raise SystemExit("usage: python -m weavecap.bench.render --child MESH (use `weavecap bench --render`)")
    print(json.dumps(measure(Path(argv[1]))))


if __name__ == "__main__":
    main()
