"""Preload of the Dask workers that tests/test_batch_dask.py starts (``dask worker --preload``):
a photo named ``die_once*`` kills the worker process fitting it the first time, one named
``die_always*`` every time — as a crash or the kernel's out-of-memory killer would. Each death is
recorded as a file in ``$WEAVECAP_TEST_DEATHS``, named after the photo and the worker's pid."""

from __future__ import annotations

import os
from pathlib import Path

from weavecap.pipeline import FitJob

_run = getattr(FitJob, "_run_before_hooks", FitJob.run)  # a preload may run twice in a process
FitJob._run_before_hooks = _run
DEATHS = Path(os.environ["WEAVECAP_TEST_DEATHS"])


def _dying_run(self, source: str, folder: str) -> dict:
    name = Path(source).stem
    died = sorted(DEATHS.glob(f"{name}.*"))
    if name.startswith("die_always") or (name.startswith("die_once") and not died):
        (DEATHS / f"{name}.{os.getpid()}").write_text(source)
        os._exit(17)
    return _run(self, source, folder)


FitJob.run = _dying_run
