"""``weavecap render``: each params file rendered on the same mesh with the same options, as a
:class:`weavecap.batch.Job`, so a render plans, resumes, runs on ``--jobs``/``--scheduler`` and
reports in ``summary.jsonl`` as a fit does; :func:`render_files` is the whole command.

Layout of ``weavecap render A.json B.json ... MESH -o DIR``: ``DIR/<name>/render.png`` (the
image) and ``DIR/<name>/render.json`` (its record: what was rendered, the timings, the params
file's SHA-256, written last), ``<name>`` from :func:`folder_names`; ``DIR/summary.jsonl``; with
``--sheet`` ``DIR/sheet.png`` of the images finished so far, made anew at the end of each run.
One params file is a batch of one: ``-o IMAGE`` gets the image and its record ``IMAGE.json``
beside it (``dress.png``, ``dress.png.json``).
"""

from __future__ import annotations

import contextlib
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from .. import batch as wbatch
from ..errors import InputError
from ..io import atomic_path, atomic_write_text, dumps_json, check_writable, refuse_overwrite, write_result_set
from ..params import Fabric
from ..photo import file_sha256, load_photo, save_image, supported_output
from .mesh import RenderMesh, load_mesh
from .run import RenderOptions, render_fabric

IMAGE = "render.png"
RECORD = "render.json"
RECORD_FORMAT = "weavecap.render/1"
SHEET = "sheet.png"
IMAGE_SUFFIXES = (".png", ".exr", ".tif", ".tiff")


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
    and optionally a known ``pattern``: writes the image ``image``, then its record ``record``.

    The job travels to worker processes and Dask workers whole (the mesh with it), so every
    worker renders the same triangles and UVs, and a seed gives the same image bit for bit on
    any of them.

    A single render (``alone``) writes the image ``-o`` names into a folder it shares with the
    user's other files and does not lock: the image is linked into place (one that appeared
    meanwhile is kept, unless ``force``), then its record; ``mesh_s``, the mesh's reading, is
    counted in its timings, and ``progress`` (``(done, total)`` samples per pixel) is told.
    """

    mesh: RenderMesh
    options: RenderOptions
    pattern: np.ndarray | None = None
    image: str = IMAGE
    record: str = RECORD
    alone: bool = False
    force: bool = False
    mesh_s: float = 0.0
    progress: Callable[[int, int], None] | None = None
    key = "params"

    @property
    def outputs(self) -> tuple[str, str]:
        return self.image, self.record

    def run(self, source: str, folder: str) -> dict:
        t0 = time.perf_counter()
        fabric = load_fabric(source, self.pattern)
        result = render_fabric(fabric, self.mesh, self.options, progress=self.progress)
        folder = Path(folder)
        info = dict(result.info)
        timings = {"mesh": self.mesh_s} if self.alone else {}
        timings.update(info.pop("timings"), total=time.perf_counter() - t0 + self.mesh_s)
        record = {"format": RECORD_FORMAT, "status": "ok", "reason": None, "input": _input(source),
                  "mesh": {"path": str(self.mesh.path), "triangles": int(len(self.mesh.faces))},
                  "output": str(folder / self.image), **info,
                  "timings_s": {k: round(v, 3) for k, v in timings.items()}}
        text = dumps_json(record, indent=1) + "\n"
        if self.alone:
            if self.force:  # the old record goes first: it never stands beside the new image
                (folder / self.record).unlink(missing_ok=True)
            save_image(folder / self.image, result.image, overwrite=self.force)
            atomic_write_text(folder / self.record, text)
        else:
            write_result_set(folder, {self.image: lambda path: save_image(path, result.image)},
                             record=(self.record, text), outputs=self.outputs)
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


@dataclass
class Rendered:
    """What :func:`render_files` did: the mesh it read (``mesh``: path, triangles, objects, where
    the UVs came from, their stretch before and after correction, area in m², bounds in
    metres, notes, seconds), one summary line per params file
    (:func:`weavecap.batch.summary_line`), the contact sheet's images and the exit status."""

    mesh: dict
    lines: list[dict]
    sheet: list[Path]
    exit: int


def render_files(params_files: list[Path], mesh_file: Path, out: Path, options: RenderOptions, *,
                 pattern: np.ndarray | None = None, units: str = "m", object_name: str | None = None,
                 sheet: bool = False, jobs: int = 1, scheduler: str | None = None, force: bool = False,
                 on_step: Callable[[str], None] | None = None,
                 on_mesh: Callable[[dict], None] = lambda mesh: None,
                 on_event: Callable[[wbatch.Event], None] | None = None,
                 progress: Callable[[int, int], None] | None = None) -> Rendered:
    """``weavecap render PARAMS... MESH -o OUT``: the params files rendered on the mesh, each a
    batch input (:class:`RenderJob`).

    One params file renders to the image ``out`` and its record ``out + ".json"``; an existing
    image is refused without ``force`` (its name is the user's, and options may have changed:
    it is not skipped as done), and the fabric is checked before the mesh is read. Several
    render into the folder ``out``, held (:func:`weavecap.batch.held`) before the mesh is read.
    The mesh (:func:`weavecap.render.mesh.load_mesh`) is read once: ``on_step`` is told each
    step of a long read, ``on_mesh`` what it is (``Rendered.mesh``) once read. ``on_event``:
    the batch's events; ``progress``: a single render's samples per pixel.

    Raises
    ------
    InputError
        An output that cannot be written or exists, batch options with one params file, a bad
        fabric (one params file), pattern or mesh; nothing is written then.
    """
    many = len(params_files) > 1
    with contextlib.ExitStack() as stack:
        if many:
            if out.suffix.lower() in IMAGE_SUFFIXES or out.is_file():
                raise InputError(f"{out}: with several PARAMS files, -o names a folder (one image each)")
            folder = stack.enter_context(wbatch.held(out, jobs=jobs, scheduler=scheduler))
            alone = {}
        else:
            for name, given in (("--sheet", sheet), ("--jobs", jobs > 1), ("--scheduler", scheduler)):
                if given:
                    raise InputError(f"{name} needs several PARAMS files")
            supported_output(out)
            check_writable(out, folder=False)
            refuse_overwrite(out, force=force)
            load_fabric(params_files[0], pattern)  # checked before any work
            folder, alone = out.parent, {"image": out.name, "record": out.name + ".json", "alone": True,
                                         "force": force, "progress": progress}
        t0 = time.perf_counter()
        mesh = load_mesh(mesh_file, units=units, object_name=object_name, progress=on_step)
        mesh_s = time.perf_counter() - t0
        info = {"path": str(mesh_file), "triangles": int(len(mesh.faces)), "objects": mesh.objects,
                "uv_source": mesh.uv_source, "stretch": mesh.stretch, "area_m2": mesh.area,
                "bounds_m": mesh.bounds.tolist(), "notes": mesh.notes, "seconds": round(mesh_s, 3)}
        on_mesh(info)
        job = RenderJob(mesh=mesh, options=options, pattern=pattern, **alone, **({"mesh_s": mesh_s} if alone else {}))
        batch = wbatch.plan(job, params_files, folder, force=force, names=folder_names(params_files),
                            reserved=(SHEET,))
        result = wbatch.run(batch, jobs=jobs, scheduler=scheduler, on_event=on_event)
        on_sheet = write_sheet(batch, out / SHEET) if sheet else []
    return Rendered(mesh=info, lines=result.lines, sheet=on_sheet, exit=result.exit)
