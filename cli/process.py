"""How the ``weavecap`` process runs a command and ends (docs/reliability.md): with the
command's exit status; with exit 1 and a short message, not a traceback, on an unexpected
error (set ``WEAVECAP_DEBUG=1`` for the traceback); within a fraction of a second on Ctrl-C
(exit 130) or SIGTERM (143).

Python runs signal handlers in the main thread between bytecodes, so a long call into C++
(Dr.Jit compiling a kernel for minutes, a solver) would hold Ctrl-C until it returns. The
command therefore runs in a worker thread and the main thread only waits for it: on Ctrl-C it
says so, removes the files being written (:func:`weavecap.io.remove_unfinished`; finished
files and summary lines stay, as each was renamed into place or flushed when done) and ends
the process, worker thread and compiler included (``os._exit``: exit 130, SIGTERM 143).
Worker processes of ``--jobs`` die with it (:func:`weavecap.batch._die_with_parent`), and the
lock of an ``-o`` folder goes with the process.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
from typing import Callable, NoReturn

import click

from weavecap.errors import outcome

INTERRUPTED = "weavecap: interrupted; finished outputs are kept, partial ones were not written (run again to resume)"


class Terminated(KeyboardInterrupt):
    """SIGTERM, handled as Ctrl-C is (exit 143 instead of 130)."""


def _terminated(signum, frame):
    raise Terminated()


def _flush() -> None:
    sys.stdout.flush()
    sys.stderr.flush()


def _guarded(command: Callable[[], None]) -> None:
    """``command``, ending with SystemExit (its exit status) whatever happens in it."""
    try:
        command()
    except SystemExit:
        raise
    except KeyboardInterrupt as exc:
        click.echo(INTERRUPTED, err=True)
        sys.exit(outcome(exc).exit)
    except Exception as exc:  # noqa: BLE001 - the last line of defence: no tracebacks for users
        if os.environ.get("WEAVECAP_DEBUG"):
            raise
        click.echo(f"weavecap: unexpected error: {type(exc).__name__}: {exc}\n"
                   "  (set WEAVECAP_DEBUG=1 to see the traceback, and please report it)", err=True)
        sys.exit(outcome(exc).exit)


def run(command: Callable[[], None]) -> NoReturn:
    """Run ``command`` (a click command line, which ends with ``SystemExit``) in a worker
    thread and exit as it does; on Ctrl-C or SIGTERM end the process at once, as the module
    says."""
    ended: dict[str, object] = {}

    def work() -> None:
        try:
            _guarded(command)
        except SystemExit as exc:
            ended["exit"] = exc.code
        except BaseException as exc:  # noqa: BLE001 - WEAVECAP_DEBUG: shown by this thread
            ended["error"] = exc

    signal.signal(signal.SIGTERM, _terminated)
    worker = threading.Thread(target=work, name="weavecap-command", daemon=True)
    worker.start()
    try:
        while worker.is_alive():
            worker.join(0.25)
    except KeyboardInterrupt as exc:
        from weavecap.io import remove_unfinished

        click.echo(INTERRUPTED, err=True)
        remove_unfinished()
        _flush()
        os._exit(143 if isinstance(exc, Terminated) else outcome(exc).exit)
    if "error" in ended:
        raise ended["error"]
    code = ended.get("exit")
    status = code if isinstance(code, int) else (0 if code is None else 1)

    def done(signum, frame):  # the work is done: a late Ctrl-C does not wait for the shutdown
        _flush()
        os._exit(status)

    signal.signal(signal.SIGINT, done)
    signal.signal(signal.SIGTERM, done)
    sys.exit(code)
