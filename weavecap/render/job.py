"""``weavecap render`` of several params files, as a :class:`weavecap.batch.Job`: each fabric
rendered on the same mesh with the same options into its own folder, so a render batch plans,
resumes, runs on ``--jobs``/``--scheduler`` and reports in ``summary.jsonl`` as a fit batch does.

Layout of ``weavecap render A.json B.json ... MESH -o DIR``: ``DIR/<name>/render.png`` (the
image) and ``DIR/<name>/render.json`` (its record: what was rendered, the timings, the params
file's SHA-256, written last), ``<name>`` from :func:`folder_names`; ``DIR/summary.jsonl``; with
``--sheet`` ``DIR/sheet.png`` of the images finished so far, made anew at the end of each run.
One params file renders straight to the image ``-o`` names (``cli/render.py``), no record.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..io import atomic_path, write_result_set
from ..params import Fabric
from ..photo import file_sha256, load_photo, save_image
from .mesh import RenderMesh
from .run import RenderOptions, render_fabric

IMAGE = "render.png"
RECORD = "render.json"
RECORD_FORMAT = "weavecap.render/1"
SHEET = "sheet.png"


def load_fabric(path: str | Path, pattern: np.ndarray | None = None) -> Fabric:
    """The fabric of a params file, with ``pattern`` ((wefts, warps) uint8, 1 = weft over warp)
    in place of its own when given.

    Raises
    ------
    ParamsError
        The file is not a valid fabric, or ``pattern`` does not fit it.
    """
    from .. import params

    fabric = params.load(path)
    return fabric if pattern is None else fabric.replace({"pattern": pattern})


def folder_names(params_files: list[Path]) -> list[str]:
    """One folder name per params file: its stem, or where stems repeat its folder's name
    (``a/params.json``, ``b/params.json`` → ``a``, ``b``: the folders ``weavecap fit`` writes),
    numbered ``001_...`` where those repeat too."""
    stems = [p.stem for p in params_files]
    if len(set(stems)) < len(stems):
        stems = [p.resolve().parent.name + ("" if p.stem == "params" else f"_{p.stem}") for p in params_files]
    if len(set(stems)) < len(stems):
        stems = [f"{i:03d}_{s}" for i, s in enumerate(stems, 1)]
    return stems


def _input(source: str) -> dict:
    try:  # identify the file, so that a resumed batch knows the record is its own
        return {"path": source, "sha256": file_sha256(source)}
    except OSError:
        return {"path": source, "sha256": ""}


@dataclass(frozen=True, eq=False)
class RenderJob:
    """The render of one params file on ``mesh`` (read once, by the command) with ``options``
    and optionally a known ``pattern``: writes ``IMAGE``, then ``RECORD``.

    The job travels to worker processes and Dask workers whole (the mesh with it), so every
    worker renders the same triangles and UVs, and a seed gives the same image bit for bit on
    any of them.
    """

    mesh: RenderMesh
    options: RenderOptions
    pattern: np.ndarray | None = None
    key = "params"
    outputs = (IMAGE, RECORD)
    record = RECORD

    def run(self, source: str, folder: str) -> dict:
        t0 = time.perf_counter()
        fabric = load_fabric(source, self.pattern)
        result = render_fabric(fabric, self.mesh, self.options)
        folder = Path(folder)
        info = dict(result.info)
        timings = info.pop("timings")
        timings["total"] = time.perf_counter() - t0
        record = {"format": RECORD_FORMAT, "status": "ok", "reason": None, "input": _input(source),
                  "mesh": {"path": str(self.mesh.path), "triangles": int(len(self.mesh.faces))},
                  "output": str(folder / IMAGE), **info,
                  "timings_s": {k: round(v, 3) for k, v in timings.items()}}
        write_result_set(folder, {IMAGE: lambda path: save_image(path, result.image)},
                         record=(RECORD, json.dumps(record, indent=1) + "\n"), outputs=self.outputs)
        return record

    def failure_record(self, source: str, status: str, reason: str, seconds: float) -> dict:
        return {"format": RECORD_FORMAT, "status": status, "reason": reason, "input": _input(source),
                "timings_s": {"total": round(seconds, 3)}}

    def summary(self, record: dict) -> dict:
        return {k: record.get(k) for k in ("output", "mode", "spp", "size", "pitch_mm", "pitch_source")}


def write_sheet(batch, path: Path) -> list[Path]:
    """A contact sheet (:func:`weavecap.render.sheet.contact_sheet`) at ``path`` of the images of
    ``batch`` (:func:`weavecap.batch.plan`) whose record says ``ok``, in the order of its inputs,
    each labelled with its folder's name; written atomically, over an earlier sheet. Returns
    the images on it (none: no sheet written)."""
    from ..batch import read_record
    from .sheet import contact_sheet

    folders = [item.folder for item in batch.items
               if (read_record(batch.job, item.folder) or {}).get("status") == "ok"]
    if folders:
        images = [load_photo(folder / IMAGE).rgb for folder in folders]
        with atomic_path(path) as tmp:
            contact_sheet(images, [folder.name for folder in folders]).save(tmp, format="PNG")
    return [folder / IMAGE for folder in folders]
