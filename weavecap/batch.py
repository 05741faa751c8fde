"""Batches: many inputs, one output folder each, one ``summary.jsonl`` line per input.

docs/design.md's contract ("Commands") for a command that takes several inputs (``weavecap fit PHOTO...``,
``weavecap render PARAMS... MESH``): one input writes into ``OUT`` itself; several write into
``OUT/<stem>`` each (``<stem>-2``, ... when stems repeat, or names the command gives) and
append one line per input to ``OUT/summary.jsonl`` as each finishes. A bad input does not stop
the batch; the batch exits with its most severe outcome (:data:`weavecap.errors.OUTCOMES`).
A missing file or a folder among several inputs is ``invalid`` in its summary line, and the
others run. Nothing escapes ``-o``: folder names are made plain (:func:`weavecap.io.folder_name`:
a photo ``...png`` does not write into ``OUT/..``). Nothing is lost: a folder holding another
run's results is refused unless ``force``; each input's results are written as one set
(:func:`weavecap.io.write_result_set`); run again to resume — finished inputs (their record
says ``ok`` or ``rejected`` and names the same file by its SHA-256) are skipped, failed and
interrupted ones are tried again, and each input keeps exactly one summary line. The caller
holds ``OUT``'s lock (:func:`weavecap.io.folder_lock`) from :func:`plan` to the end of :func:`run`.

What is done to each input is a :class:`Job` (``weavecap.pipeline.FitJob`` for ``fit``,
``weavecap.render.job.RenderJob`` for ``render``); this module only plans, runs and records.
Work runs in this process, in a local process pool (``jobs``), or on a Dask distributed cluster
(``scheduler``: an address, or ``local:N``), where an input whose worker dies is tried once
more on another, then reported failed.
"""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import time
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterable, Iterator, Protocol

from .errors import InputError, WeavecapError, outcome, outcome_of_status, worst_exit
from .io import (LOCK, atomic_write_text, check_writable, dumps_json, folder_lock, folder_name, inside, loads_json,
                 not_an_input, staged, write_result_set)

SUMMARY = "summary.jsonl"
FINISHED = ("ok", "rejected")  # statuses of a record that a resumed batch skips


class Job(Protocol):
    """What a batch does to each input; picklable (it travels to worker processes).

    Attributes
    ----------
    key : the summary line's name for the input (``"photo"``)
    outputs : the files a result consists of, in its folder
    record : the one of ``outputs`` written last, a JSON object with ``status``, ``reason``,
        ``timings_s.total`` and ``input.sha256``: its presence marks a finished input
    """

    key: str
    outputs: tuple[str, ...]
    record: str

    def run(self, source: str, folder: str) -> dict:
        """Do the work on ``source``, write its outputs into ``folder`` (``record`` last) and
        return the record. May raise; :func:`attempt` turns errors into outcomes."""

    def failure_record(self, source: str, status: str, reason: str, seconds: float) -> dict:
        """The record of an input that ended with an error (status ``rejected``/``failed``)."""

    def summary(self, record: dict) -> dict:
        """The fields an ``ok`` input adds to its summary line."""


@dataclass(frozen=True)
class Item:
    """One input of a batch and the folder its outputs go to."""

    source: Path
    folder: Path


@dataclass
class Batch:
    """A planned batch (:func:`plan`): what to do, and what an earlier run already did."""

    job: Job
    out: Path
    items: list[Item]
    todo: list[Item]
    done: list[tuple[Item, dict]]  # finished earlier: (item, its record)
    force: bool = False

    @property
    def several(self) -> bool:
        """Several inputs: one folder each and a summary.jsonl (one input writes into ``out``)."""
        return len(self.items) > 1

    @property
    def summary_path(self) -> Path:
        return self.out / SUMMARY


@dataclass(frozen=True)
class Event:
    """Progress of a batch, for the command line to report.

    ``kind``: ``skipped`` (finished earlier), ``started`` (in this process only) or
    ``finished``; ``index`` counts the items to do, of ``total``.
    """

    kind: str
    item: Item
    index: int
    total: int
    record: dict | None = None
    line: dict | None = None


@dataclass
class Result:
    """A batch's summary lines (finished earlier first, then in the order they ended) and its
    exit status (:func:`weavecap.errors.worst_exit`)."""

    lines: list[dict] = field(default_factory=list)

    @property
    def exit(self) -> int:
        return worst_exit(line["exit"] for line in self.lines)


def folders(sources: list[Path], out: Path, names: list[str] | None = None, *, fallback: str = "input",
            reserved: tuple[str, ...] = ()) -> list[Path]:
    """One output folder per input: ``out`` itself for one, ``out/<stem>`` for several, or
    ``out/<name>`` of ``names`` (one per input) where the caller names them.

    Each name is made plain (:func:`weavecap.io.folder_name`: ``..`` becomes ``fallback``, a
    name in ``reserved`` or :data:`SUMMARY` gets a ``_``) and numbered ``-2``, ``-3``, ... where
    it repeats, so every input has its own folder inside ``out``."""
    if len(sources) == 1:
        return [out]
    stems = [p.stem for p in sources] if names is None else list(names)
    if len(stems) != len(sources):
        raise ValueError(f"folders: {len(sources)} inputs need as many names, not {names}")
    used: set[str] = set()
    result = []
    for stem in stems:
        name = folder_name(stem, fallback=fallback, reserved=(SUMMARY, LOCK, *reserved))
        k, unique = 1, name
        while unique in used:
            k += 1
            unique = f"{name}-{k}"
        used.add(unique)
        result.append(inside(out, out / unique))
    return result


def read_record(job: Job, folder: Path) -> dict | None:
    """The record ``job`` wrote in ``folder``, or None (none there, or not a JSON object)."""
    try:
        record = loads_json((folder / job.record).read_text())
    except (OSError, ValueError):
        return None
    return record if isinstance(record, dict) else None


def _same_input(record: dict, source: Path) -> bool:
    from .photo import file_sha256

    try:
        return record["input"]["sha256"] == file_sha256(source)
    except (OSError, KeyError, TypeError):
        return False


def _refusal(job: Job, item: Item, record: dict | None) -> str:
    """Why ``item.folder``'s files are not this run's to replace without ``--force``."""
    held = ", ".join(name for name in job.outputs if (item.folder / name).exists())
    source = record.get("input") if record is not None else None
    if record is None:
        what = (f"holds {held} but no finished {job.record}: not a weavecap result of this input (files of "
                "something else, or of an older weavecap interrupted)")
    elif _same_input(record, item.source):
        what = f"holds results of another run of this file, whose {job.record} says {record.get('status')!r}"
    else:
        of = repr(source.get("path")) if isinstance(source, dict) else "an unknown file"
        what = (f"holds results of another run: its {job.record} is of {of}, a different file from "
                f"{str(item.source)!r} (compared by SHA-256)")
    return f"{item.folder}: {what}; use --force to replace them or choose another -o folder (nothing was written)"


def check_options(jobs: int, scheduler: str | None) -> None:
    """Refuse ``jobs`` > 1 with a ``scheduler``, and a scheduler address weavecap cannot use
    (:func:`scheduler_security`), before any work.

    Raises
    ------
    InputError
        Both given, ``local:`` with a bad count, a protocol other than tcp:// and tls://, or
        tls:// without Dask's TLS settings.
    """
    if scheduler and jobs > 1:
        raise InputError("--jobs and --scheduler exclude each other: --jobs N runs N processes here, "
                         "--scheduler local:N runs N Dask workers here")
    if scheduler:
        scheduler_security(scheduler)


@contextlib.contextmanager
def held(out: Path, *, jobs: int = 1, scheduler: str | None = None) -> Iterator[Path]:
    """A batch's ``-o`` folder, checked before any work (:func:`check_options`, an unwritable
    folder) and held for the run (:func:`weavecap.io.folder_lock`), from :func:`plan` to the
    end of :func:`run`."""
    check_options(jobs, scheduler)
    check_writable(out, folder=True)
    with folder_lock(out):
        yield Path(out)


def run_folder(job: Job, sources: Iterable[Path], out: Path, *, jobs: int = 1, scheduler: str | None = None,
               force: bool = False, on_event: Callable[[Event], None] | None = None) -> Result:
    """A whole batch into ``out``: checked and held (:func:`held`), planned (:func:`plan`) and
    run (:func:`run`), as ``weavecap fit`` does it."""
    with held(out, jobs=jobs, scheduler=scheduler):
        return run(plan(job, sources, out, force=force), jobs=jobs, scheduler=scheduler, on_event=on_event)


def plan(job: Job, sources: Iterable[Path], out: Path, *, force: bool = False,
         names: list[str] | None = None, reserved: tuple[str, ...] = ()) -> Batch:
    """Check a batch before any work and find what an earlier run finished. Writes nothing.

    ``names``: the inputs' folder names under ``out`` (several inputs), instead of their stems;
    ``reserved``: names the command keeps at the top of ``out`` (:func:`folders`). With several
    inputs, one that is missing or a folder stays in the batch and ends ``invalid``
    (:func:`attempt`); a finished input (its record ``ok`` or ``rejected``, of the same file)
    is skipped; a folder whose writing was interrupted (:func:`weavecap.io.staged`) is redone.

    Raises
    ------
    InputError
        ``out`` is a file; the one input is missing; a folder holds results of another run
        (of another input, or files that are not a finished result) and ``force`` is not given.
    """
    sources = [Path(s) for s in sources]
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InputError(f"{out}: exists and is not a folder; give a folder name for -o")
    if len(sources) == 1 and not_an_input(sources[0], job.key):
        raise InputError(not_an_input(sources[0], job.key) + " (nothing was written)")
    items = [Item(p, f) for p, f in zip(sources, folders(sources, out, names, fallback=job.key, reserved=reserved))]
    where = [out / SUMMARY] if len(items) > 1 else []
    for path in where + [item.folder / name for item in items for name in job.outputs]:
        if path.exists() and not path.is_file():
            raise InputError(f"{path}: is a folder (or not a regular file) where weavecap writes a file; move it away "
                             "(nothing was written)")
    todo, done = [], []
    for item in items:
        if not item.source.is_file():  # invalid or rejected when its turn comes; its folder is not touched
            todo.append(item)
            continue
        record = None if force else read_record(job, item.folder)
        same = record is not None and _same_input(record, item.source)
        if same and record.get("status") in FINISHED:
            done.append((item, record))
            continue
        retry = (same and record.get("status") == "failed") or staged(item.folder)  # ours: try again
        if not force and not retry and any((item.folder / name).exists() for name in job.outputs):
            raise InputError(_refusal(job, item, record))
        todo.append(item)
    return Batch(job=job, out=out, items=items, todo=todo, done=done, force=force)


def summary_line(job: Job, item: Item, record: dict, status: str | None = None) -> dict:
    """The summary.jsonl line of one input (``status``: the record's unless given)."""
    status = status or record.get("status")
    line = {job.key: str(item.source), "folder": str(item.folder), "status": status,
            "exit": outcome_of_status(status).exit}
    if status == "ok":
        line.update(job.summary(record))
    else:
        line["reason"] = record.get("reason")
    line["seconds"] = record.get("timings_s", {}).get("total")
    return line


def _set_threads(threads: int | None) -> None:
    """Give Dr.Jit ``threads`` threads in this process (a worker sharing a machine)."""
    if threads:
        from .backend import mitsuba

        mitsuba()
        import drjit

        drjit.set_thread_count(threads)


def write_record(job: Job, folder: str | Path, record: dict) -> None:
    """Write a failure's record as the folder's whole result set: an earlier run's outputs
    go (:func:`weavecap.io.write_result_set`), so no old params.json outlives it."""
    write_result_set(folder, {}, record=(job.record, dumps_json(record, indent=1) + "\n"), outputs=job.outputs)


def attempt(job: Job, source: str, folder: str, threads: int | None = None) -> tuple[dict, str]:
    """Run ``job`` on one input; never raises but KeyboardInterrupt (a failure is a record).

    Returns (record, status). An error a user caused (``invalid``: a missing input among
    several, an option that does not fit it) writes nothing; any other error writes
    ``job.failure_record`` as the folder's record. Set ``WEAVECAP_DEBUG=1`` to let unexpected
    errors through with their traceback.
    """
    _set_threads(threads)
    t0 = time.perf_counter()
    try:
        if not_an_input(Path(source), job.key):
            raise InputError(not_an_input(Path(source), job.key))
        record = job.run(source, folder)
        return record, record["status"]
    except Exception as exc:  # noqa: BLE001 - one bad input must not stop a batch
        result = outcome(exc)
        if result.status == "failed" and os.environ.get("WEAVECAP_DEBUG"):
            raise
        reason = str(exc) if isinstance(exc, WeavecapError) else f"unexpected error: {type(exc).__name__}: {exc}"
    record = job.failure_record(source, result.status, reason, time.perf_counter() - t0)
    if result.status != "invalid":
        write_record(job, folder, record)
    return record, result.status


def _append(path: Path, line: dict) -> None:
    """Append one JSON line and flush it to disk (a crash loses at most the line being written)."""
    with open(path, "a", encoding="utf-8") as fh:
        fh.write(dumps_json(line) + "\n")
        fh.flush()
        os.fsync(fh.fileno())


def _start_summary(batch: Batch, lines: list[dict]) -> None:
    """Make summary.jsonl hold one line per input finished so far: with ``force`` it starts
    empty; otherwise lines of the inputs about to be redone are dropped and those of inputs
    finished earlier but missing (an interrupted write) added. Lines of other inputs stay."""
    path = batch.summary_path
    batch.out.mkdir(parents=True, exist_ok=True)
    if batch.force:
        path.unlink(missing_ok=True)
        return
    redo = {str(item.source) for item in batch.todo}
    kept, recorded = [], set()
    if path.exists():
        for raw in path.read_text().splitlines():
            try:
                source = loads_json(raw)[batch.job.key]
            except (ValueError, KeyError, TypeError):
                continue
            if source in redo or source in recorded:
                continue
            kept.append(raw)
            recorded.add(source)
        if len(kept) != len(path.read_text().splitlines()):
            atomic_write_text(path, "".join(raw + "\n" for raw in kept))
    for line in lines:
        if line[batch.job.key] not in recorded:
            _append(path, line)


Outcomes = Iterator[tuple[Item, dict, str]]

#: a photo whose Dask worker dies is tried on a worker once more, then reported failed
RETRIES = 1
#: deaths of a worker that an input waited on without running (Dask counts those against it too)
QUEUED_DEATHS = 2
#: in an input's folder while a Dask worker runs it: how many times it was started
STARTS = ".starts"


def _lost_reason(starts: int) -> str:
    return (f"lost: its Dask worker died on each of {starts} tries (killed, or out of memory?); "
            "the workers' logs say more")


def counted_attempt(job: Job, source: str, folder: str, threads: int | None = None) -> tuple[dict, str]:
    """:func:`attempt` on a Dask worker, counting its starts in ``FOLDER/.starts``.

    Dask counts a worker's death against every input assigned to it, also those queued behind
    the one that killed it; what counts here is how often this input was *started*: once more
    than ``RETRIES`` starts ended with a dead worker, the next start writes the ``failed``
    record instead of running it again. The count is removed when the attempt returns.
    """
    marker = Path(folder) / STARTS
    starts = int(marker.read_text()) if marker.is_file() else 0
    if starts > RETRIES:
        record = job.failure_record(source, "failed", _lost_reason(starts), 0.0)
        marker.unlink(missing_ok=True)
        write_record(job, folder, record)
        return record, "failed"
    made = not marker.parent.exists()
    marker.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(marker, str(starts + 1))
    try:
        return attempt(job, source, folder, threads)
    finally:
        marker.unlink(missing_ok=True)
        if made and not any(marker.parent.iterdir()):  # an invalid input writes nothing
            marker.parent.rmdir()


def _serial(batch: Batch, on_start: Callable[[Item, int], None]) -> Outcomes:
    for i, item in enumerate(batch.todo, 1):
        on_start(item, i)
        yield (item, *attempt(batch.job, str(item.source), str(item.folder)))


def die_with_parent(parent: int) -> None:
    """Make this process die (SIGKILL from the kernel) when ``parent``, the process that
    started it, ends, however it ends (``kill -9`` included): a ``--jobs`` worker's
    initializer, and the command process of ``cli/process.py``; one left behind would go on
    fitting, ~620 MB each, for nobody."""
    import ctypes

    pr_set_pdeathsig = 1  # <sys/prctl.h>
    ctypes.CDLL(None, use_errno=True).prctl(pr_set_pdeathsig, signal.SIGKILL)
    if os.getppid() != parent:  # it ended before the line above
        os._exit(1)


def _processes(batch: Batch, jobs: int) -> Outcomes:
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    threads = max(1, (os.cpu_count() or 1) // jobs)
    # the death signal follows the thread that starts a worker: the pool starts them in submit(),
    # from this thread, which lives until the pool is shut down
    with ProcessPoolExecutor(max_workers=jobs, mp_context=multiprocessing.get_context("spawn"),
                             initializer=die_with_parent, initargs=(os.getpid(),)) as pool:
        futures = {pool.submit(attempt, batch.job, str(item.source), str(item.folder), threads): item
                   for item in batch.todo}
        for future in as_completed(futures):
            yield (futures[future], *future.result())


def local_workers(address: str) -> int | None:
    """N of a ``local:N`` scheduler address, None for any other address.

    Raises
    ------
    InputError
        ``local:`` followed by anything but a whole number from 1 to 64.
    """
    if not address.startswith("local:"):
        return None
    n = address[len("local:"):]
    if not n.isdigit() or not 1 <= int(n) <= 64:
        raise InputError(f"--scheduler {address}: local:N needs a number of workers N from 1 to 64, e.g. local:2")
    return int(n)


#: the TLS settings of Dask's configuration a ``tls://`` scheduler needs (``distributed.comm.tls.``)
TLS_KEYS = ("ca-file", "client.cert", "client.key")


def scheduler_security(address: str):
    """Check a ``--scheduler`` address before any work; the Dask ``Security`` to connect with.

    ``local:N``, ``tcp://host:port`` (or ``host:port``): None. ``tls://host:port``: a
    ``distributed.security.Security`` from Dask's configuration (``distributed.comm.tls.ca-file``,
    ``.client.cert``, ``.client.key``: ``~/.config/dask/distributed.yaml``, or the variables
    ``DASK_DISTRIBUTED__COMM__TLS__CA_FILE`` ...), which must name files that exist.

    Raises
    ------
    InputError
        Another protocol (``ucx://`` needs ucx-py and a UCX build of Dask; ``ws://``, ``inproc://``
        are not for batches), ``tls://`` without its settings, or a ``local:`` count out of range.
    """
    if local_workers(address) is not None:
        return None
    scheme = address.split("://", 1)[0].lower() if "://" in address else "tcp"
    if scheme == "tcp":
        return None
    if scheme != "tls":
        raise InputError(f"--scheduler {address}: weavecap connects to Dask schedulers over tcp:// or tls:// "
                         f"only, not {scheme}://; give tcp://host:8786, tls://host:8786 (with Dask's TLS settings) "
                         "or local:N (nothing was written)")
    import dask
    from distributed.security import Security

    settings = {key: dask.config.get(f"distributed.comm.tls.{key}", None) for key in TLS_KEYS}
    missing = [f"distributed.comm.tls.{key}" for key, value in settings.items() if not value]
    absent = [f"{value} (distributed.comm.tls.{key})" for key, value in settings.items()
              if value and not Path(value).is_file()]
    if missing or absent:
        what = (f"Dask's configuration lacks {', '.join(missing)}" if missing else
                f"these files do not exist: {', '.join(absent)}")
        raise InputError(f"--scheduler {address}: a tls:// scheduler needs the CA certificate and this client's "
                         f"certificate and key: {what}. Set them in ~/.config/dask/distributed.yaml or as "
                         "DASK_DISTRIBUTED__COMM__TLS__CA_FILE, ..._CLIENT__CERT, ..._CLIENT__KEY (see "
                         "docs/reliability.md; nothing was written)")
    return Security(require_encryption=True)


def _tell_scheduler(dask_scheduler, retries: int) -> None:
    """On a running scheduler (``Client.run_on_scheduler``): a task whose worker dies is
    rescheduled ``retries`` times, then fails with ``KilledWorker``."""
    dask_scheduler.allowed_failures = retries


@contextlib.contextmanager
def _dask_client(address: str) -> Iterator[tuple[object, int | None]]:
    """A Dask client of the scheduler at ``address``, or of a local cluster of N one-thread
    worker processes on 127.0.0.1 for ``local:N``; and the Dr.Jit threads a worker gets
    (``cpu_count // N`` locally; a remote worker keeps its machine's default)."""
    import dask
    from distributed import Client, LocalCluster

    n = local_workers(address)
    with contextlib.ExitStack() as stack:
        stack.enter_context(dask.config.set({"distributed.scheduler.allowed-failures": RETRIES + 1 + QUEUED_DEATHS}))
        if n is not None:
            cluster = stack.enter_context(LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                                       host="127.0.0.1", dashboard_address=None,
                                                       silence_logs=logging.CRITICAL))
            client = stack.enter_context(Client(cluster))
            threads = max(1, (os.cpu_count() or 1) // n)
        else:
            try:  # distributed.comm.timeouts.connect
                client = stack.enter_context(Client(address, security=scheduler_security(address)))
            except (OSError, TimeoutError, ValueError) as exc:
                raise InputError(f"--scheduler {address}: cannot reach a Dask scheduler there ({exc}); start one "
                                 "with `dask scheduler` (see the README), or use local:N (nothing was written)") from None
            client.run_on_scheduler(_tell_scheduler, retries=RETRIES + 1 + QUEUED_DEATHS)
            threads = None
        yield client, threads


def _dask(batch: Batch, client, threads: int | None) -> Outcomes:
    """Each input a task on the cluster, no more at a time than the workers have threads, so a
    worker mostly holds only the input it works on. A result is taken back before a new input
    is sent. A worker that dies takes the input it ran with it, which the scheduler
    reschedules; once an input was started ``RETRIES + 1`` times on workers that died, it ends
    as a ``failed`` record (:func:`counted_attempt`). While a dead worker's input is
    rescheduled, the scheduler can queue another input behind it on a busy worker, and Dask
    counts that worker's death against both: up to ``QUEUED_DEATHS`` such deaths are not held
    against an input; beyond, its ``failed`` record is written here."""
    from distributed import as_completed
    from distributed.scheduler import KilledWorker

    t0 = time.perf_counter()
    run_id = uuid.uuid4().hex[:8]  # keys unique on a scheduler that other batches share
    waiting = list(enumerate(batch.todo))[::-1]
    items = {}

    def submit() -> object:
        i, item = waiting.pop()
        (item.folder / STARTS).unlink(missing_ok=True)  # a new batch gives every input its tries again
        future = client.submit(counted_attempt, batch.job, str(item.source), str(item.folder), threads, pure=False,
                               key=f"weavecap-{run_id}-{i}-{item.source.name}")
        items[future.key] = item
        return future

    slots = max(1, sum(client.nthreads().values()))
    running = as_completed([submit() for _ in range(min(slots, len(waiting)))])
    for future in running:
        item = items.pop(future.key)
        if future.status == "finished":
            outcome_ = (item, *future.result())
        else:
            exc = future.exception()
            if isinstance(exc, KilledWorker):
                reason = _lost_reason(RETRIES + 1) + f" (the last was {exc.last_worker.address})"
                (item.folder / STARTS).unlink(missing_ok=True)
            else:
                reason = f"unexpected error: {type(exc).__name__}: {exc}"
            record = batch.job.failure_record(str(item.source), "failed", reason, time.perf_counter() - t0)
            write_record(batch.job, item.folder, record)
            outcome_ = (item, record, "failed")
        future.release()
        slots = max(1, sum(client.nthreads().values()))
        while waiting and running.count() < slots:
            running.add(submit())
        yield outcome_


def run(batch: Batch, *, jobs: int = 1, scheduler: str | None = None,
        on_event: Callable[[Event], None] | None = None) -> Result:
    """Run a planned batch: each input to do, one after the other, ``jobs`` at a time in
    worker processes, or on a Dask cluster; each finished input's line appended to
    summary.jsonl (several inputs) and reported as an :class:`Event`.

    Parameters
    ----------
    batch : from :func:`plan`
    jobs : worker processes (1: in this process); Dr.Jit gets ``cpu_count // jobs`` threads each
    scheduler : a Dask scheduler's address (``tcp://host:8786``) or ``local:N`` (a local cluster
        of N workers); the inputs' paths must be the same on every worker (a shared file system)
    on_event : called with each skipped, started (in this process) and finished input

    Raises
    ------
    InputError
        ``scheduler`` cannot be reached, or is ``local:`` with a bad count (nothing written).
    """
    tell = on_event or (lambda _event: None)
    total = len(batch.todo)
    result = Result()
    with contextlib.ExitStack() as stack:
        if scheduler is not None and total:
            outcomes = _dask(batch, *stack.enter_context(_dask_client(scheduler)))
        elif jobs > 1 and total > 1:
            outcomes = _processes(batch, jobs)
        else:
            outcomes = _serial(batch, lambda item, i: tell(Event("started", item, i, total)))
        for item, record in batch.done:
            tell(Event("skipped", item, 0, total, record=record))
            result.lines.append(summary_line(batch.job, item, record))
        if batch.several:
            _start_summary(batch, result.lines)
        for i, (item, record, status) in enumerate(outcomes, 1):
            line = summary_line(batch.job, item, record, status)
            result.lines.append(line)
            if batch.several:
                _append(batch.summary_path, line)
            tell(Event("finished", item, i, total, record=record, line=line))
    return result
