"""``weavecap prepare``: a photo prepared (:func:`weavecap.prepare.prepare_photo`) into a folder
of images a person can check by eye, and ``prepare.json``.

The folder is held for the run (:func:`weavecap.io.folder_lock`), nothing in it is overwritten
without ``force``, and the files are written as one result set, ``prepare.json`` last
(:func:`weavecap.io.write_result_set`). A rejected photo's set is ``diagnosis.png`` (what the
grid search saw) and ``prepare.json`` (why), in place of an earlier set.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Callable

import numpy as np

from ..errors import InputError
from ..io import check_writable, dumps_json, folder_lock, not_an_input, refuse_overwrite, write_result_set
from ..photo import load_photo, save_png
from .config import PrepareConfig
from .pipeline import Rejected, prepare_photo

#: what a prepared photo leaves in its folder, its record last
OUTPUTS = ("rectified.png", "regularized.png", "grid.png", "diagnosis.png", "prepare.json")
RECORD_FORMAT = "weavecap.prepare/1"


def prepare_into(photo: Path, out: Path, *, repeat: tuple[int, int] | None = None, force: bool = False,
                 say: Callable[..., None] = lambda message, level=0: None) -> dict:
    """Prepare ``photo`` into the folder ``out``: ``rectified.png`` (warps vertical,
    perspective undone), ``regularized.png`` (whole repeats, denoised), ``grid.png`` (the yarn
    grid over the rectified photo) and ``prepare.json`` (the photo, then the ``rectification``
    and ``grid`` parts of report.json, regularization, checks and timings in seconds).

    ``repeat``: a known pattern's (wefts, warps), used where the photo shows a shorter one.
    ``say(message, level)`` is told each stage (level 0) and the photo's size (level 1).

    Returns
    -------
    dict
        The record written, ``status`` ``"ok"``; or, the photo rejected, its rejection
        (``status`` ``"rejected"``, ``code``, ``reason``, ``checks``), written beside
        ``diagnosis.png`` (:meth:`weavecap.prepare.Rejected.diagnosis`).

    Raises
    ------
    InputError
        ``photo`` missing or a folder, ``out`` unwritable, held by another run, or holding
        outputs without ``force`` (all before any work).
    PhotoError
        The photo cannot be read as an image.
    """
    if not_an_input(photo, "photo"):
        raise InputError(not_an_input(photo, "photo") + " (nothing was written)")
    check_writable(out, folder=True)
    with folder_lock(out):
        for name in OUTPUTS:
            refuse_overwrite(out / name, force=force)
        t0 = time.perf_counter()
        say(f"reading {photo}")
        loaded = load_photo(photo)
        say(f"{loaded.width}×{loaded.height} {loaded.source_format}, {loaded.bit_depth}-bit", 1)
        result = prepare_photo(loaded.rgb, PrepareConfig(), repeat=repeat, progress=say)
        photo_info = {"path": str(photo), "sha256": loaded.sha256, "width": loaded.width, "height": loaded.height}
        record = {"format": RECORD_FORMAT, "input": photo_info, **result.to_json()}
        if isinstance(result, Rejected):
            write_result_set(out, {"diagnosis.png": lambda path: save_png(path, result.diagnosis(loaded.rgb))},
                             record=(OUTPUTS[-1], dumps_json(record, indent=1) + "\n"), outputs=OUTPUTS)
            return record
        say("writing " + ", ".join(OUTPUTS))
        record["timings_s"]["with_io"] = round(time.perf_counter() - t0, 4)
        images: dict[str, np.ndarray] = {"rectified.png": result.rectification.image,
                                         "regularized.png": result.regularized.image,
                                         "grid.png": result.grid_overlay()}
        write_result_set(out, {name: lambda path, image=image: save_png(path, image) for name, image in images.items()},
                         record=(OUTPUTS[-1], dumps_json(record, indent=1) + "\n"), outputs=OUTPUTS)
    return record
