"""Preload of the Dask workers that tests/test_batch_dask.py starts (``dask worker --preload``):
an input (a photo to fit, a params file to render) named ``die_once*`` kills the worker process
working on it the first time, one named ``die_always*`` every time — as a crash or the kernel's
out-of-memory killer would. Each death is recorded as a file in ``$WEAVECAP_TEST_DEATHS``, named
after the input and the worker's pid."""

from __future__ import annotations

import os
from pathlib import Path

from weavecap.pipeline import FitJob
from weavecap.render.job import RenderJob

DEATHS = Path(os.environ["WEAVECAP_TEST_DEATHS"])


def _dying(run):
    """``run`` of a Job, but dying as the module docstring says."""

    def dying_run(self, source: str, folder: str) -> dict:
        name = Path(source).stem
        died = sorted(DEATHS.glob(f"{name}.*"))
        if name.startswith("die_always") or (name.startswith("die_once") and not died):
            (DEATHS / f"{name}.{os.getpid()}").write_text(source)
            os._exit(17)
        return run(self, source, folder)

    return dying_run


for _job in (FitJob, RenderJob):
    _run = getattr(_job, "_run_before_hooks", _job.run)  # a preload may run twice in a process
    _job._run_before_hooks = _run
    _job.run = _dying(_run)
