"""How the ``weavecap`` process runs a command and ends (docs/reliability.md): with the
command's exit status; with exit 1 and a short message, not a traceback, on an unexpected
error (set ``WEAVECAP_DEBUG=1`` for the traceback); within a fraction of a second on Ctrl-C
(exit 130) or SIGTERM (143).

Python runs signal handlers in the main thread, holding the interpreter lock, and a long call
into C++ that keeps the lock (LLVM compiling a Dr.Jit kernel for seconds to minutes) holds
Ctrl-C until it returns, whichever thread waits for it. So the command runs in a child
process, forked before any library is loaded, with the signals' default action (it dies at
once), and this process only waits for it: on Ctrl-C or SIGTERM it ends the child, says so,
removes the temporary files and staging folders the child was writing (journalled to it
through a pipe, :func:`weavecap.io.journal_to`; finished files and summary lines stay, as each
was renamed into place or flushed when done) and exits 130 (SIGTERM 143). The child dies with
this process however it ends (``kill -9`` too), the worker processes of ``--jobs`` with the
child (:func:`weavecap.batch.die_with_parent`), and the lock of an ``-o`` folder with it.
"""

from __future__ import annotations

import os
import select
import signal
import sys
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


def run(command: Callable[[], None]) -> NoReturn:
    """Run ``command`` (a click command line, which ends with ``SystemExit``) in a child
    process and exit as it does; on Ctrl-C or SIGTERM end it at once, as the module says."""
    from weavecap.io import Unfinished, journal_to

    reading, writing = os.pipe()
    sys.stdout.flush()
    sys.stderr.flush()
    parent = os.getpid()
    child = os.fork()
    if child == 0:  # the command: dies at once on a signal or with its parent, which tidies up
        from weavecap.batch import die_with_parent

        die_with_parent(parent)
        os.close(reading)
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        journal_to(writing)
        _guarded(command)
        sys.exit(0)
    os.close(writing)
    unfinished = Unfinished()
    signal.signal(signal.SIGTERM, _terminated)
    try:
        while True:
            if select.select([reading], [], [], 0.25)[0]:
                data = os.read(reading, 1 << 16)
                unfinished.feed(data)
                if not data:  # the child closed its end: it is ending
                    status = os.waitpid(child, 0)[1]
                    break
            done, status = os.waitpid(child, os.WNOHANG)
            if done:
                break
        code = os.waitstatus_to_exitcode(status)
        if code < 0:  # the child ended by a signal (Ctrl-C at a terminal reaches both processes)
            raise Terminated() if -code == signal.SIGTERM else KeyboardInterrupt()
    except KeyboardInterrupt as exc:
        try:
            os.kill(child, signal.SIGKILL)
            os.waitpid(child, 0)
        except (ProcessLookupError, ChildProcessError):
            pass
        while select.select([reading], [], [], 0.05)[0]:  # what the child journalled last
            data = os.read(reading, 1 << 16)
            if not data:
                break
            unfinished.feed(data)
        unfinished.remove()
        click.echo(INTERRUPTED, err=True)
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(143 if isinstance(exc, Terminated) else outcome(exc).exit)
    sys.exit(code)
