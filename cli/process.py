"""How the ``weavecap`` process runs a command and ends (docs/reliability.md): with the
command's exit status; exit 1 and a short message on an unexpected error (``WEAVECAP_DEBUG=1``:
the traceback); within a fraction of a second on Ctrl-C (exit 130) or SIGTERM (143).

LLVM compiling a Dr.Jit kernel holds the interpreter lock for seconds to minutes, and Python
handles signals only with that lock. So the command runs in a forked child (signals' default
action: it dies at once; it dies with this process too, :func:`weavecap.batch.die_with_parent`),
and this process only waits: on Ctrl-C or SIGTERM it kills the child, removes the temporary
files and staging folders the child journalled to it (:func:`weavecap.io.journal_to`; finished
files and summary lines stay) and exits 130 (143).
"""
from __future__ import annotations

import atexit
import contextlib
import os
import signal
import sys
import traceback
from typing import Callable, NoReturn

import click

from weavecap.errors import outcome

INTERRUPTED = "weavecap: interrupted; finished outputs are kept, partial ones were not written (run again to resume)"


class Terminated(KeyboardInterrupt):
    """SIGTERM, handled as Ctrl-C is (exit 143 instead of 130)."""


def _terminated(signum, frame):
    raise Terminated()


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


def _flush() -> None:
    sys.stdout.flush()
    sys.stderr.flush()


def _child_exit(command: Callable[[], None]) -> NoReturn:
    """Run ``command`` in the child and end the child with its exit status, never returning
    to the caller's code (the fork of a process that goes on after ``run``, a test runner's,
    would go on as a second copy of it)."""
    code = 1
    try:
        _guarded(command)
        code = 0
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    except BaseException:  # noqa: BLE001 - WEAVECAP_DEBUG: the traceback, then exit 1
        traceback.print_exc()
    finally:
        atexit._run_exitfuncs()
        _flush()
        os._exit(code)


def run(command: Callable[[], None]) -> NoReturn:
    """Run ``command`` (a click command line, which ends with ``SystemExit``) in a child
    process and exit as it does; on Ctrl-C or SIGTERM end it at once, as the module says."""
    from weavecap.batch import die_with_parent
    from weavecap.io import Unfinished, journal_to

    reading, writing = os.pipe()
    _flush()
    parent, child = os.getpid(), os.fork()
    if child == 0:  # the command: dies at once on a signal or with its parent, which tidies up
        die_with_parent(parent)
        os.close(reading)
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        journal_to(writing)
        _child_exit(command)
    os.close(writing)
    unfinished = Unfinished()
    signal.signal(signal.SIGTERM, _terminated)
    try:
        status = None
        while status is None:
            open_ = unfinished.read(reading, 0.25)  # False: the child closed its end, it is ending
            done, waited = os.waitpid(child, os.WNOHANG if open_ else 0)
            status = waited if done else None
        code = os.waitstatus_to_exitcode(status)
        if code < 0:  # the child ended by a signal (Ctrl-C at a terminal reaches both processes)
            raise Terminated() if -code == signal.SIGTERM else KeyboardInterrupt()
    except KeyboardInterrupt as exc:
        with contextlib.suppress(ProcessLookupError, ChildProcessError):
            os.kill(child, signal.SIGKILL)
            os.waitpid(child, 0)
        unfinished.read(reading, 0.05, until_closed=True)  # what the child journalled last
        unfinished.remove()
        click.echo(INTERRUPTED, err=True)
        _flush()
        os._exit(143 if isinstance(exc, Terminated) else outcome(exc).exit)
    sys.exit(code)
