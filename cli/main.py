"""Entry point of the ``weavecap`` command: the group, lazy command loading, and exit statuses.

Commands are imported only when invoked, so ``weavecap --help`` starts fast and does not load
Mitsuba. Errors a user can fix (:class:`weavecap.errors.WeavecapError`) become a one-paragraph
message and their exit status from :data:`weavecap.errors.OUTCOMES` (2 input, 3 rejected
photo); anything else — a command module that fails to import included — exits 1 with a short
message (set ``WEAVECAP_DEBUG=1`` for the traceback). Only a name missing from
:data:`COMMANDS` is "No such command" (exit 2).
"""

from __future__ import annotations

import importlib
import os
import sys

import click

from weavecap import __version__
from weavecap.errors import WeavecapError, outcome

#: command name → "module:function" (modules under weavecap.cli)
COMMANDS = {
    "fit": "weavecap.cli.fit:fit",
    "synth": "weavecap.cli.synth:synth",
    "render": "weavecap.cli.render:render",
    "export": "weavecap.cli.export:export",
    "prepare": "weavecap.cli.prepare:prepare",
    "doctor": "weavecap.cli.doctor:doctor",
    "bench": "weavecap.cli.bench:bench",
    "train-initializer": "weavecap.cli.train_initializer:train_initializer",
    "train-renderer": "weavecap.cli.train_renderer:train_renderer",
}


INTERRUPTED = "weavecap: interrupted; finished outputs are kept, partial ones were not written (run again to resume)"


class UserError(click.ClickException):
    """A :class:`WeavecapError` shown to the user, keeping its exit status."""

    def __init__(self, error: WeavecapError):
        super().__init__(str(error))
        self.exit_code = error.exit_code

    def show(self, file=None) -> None:
        click.echo(f"weavecap: error: {self.format_message()}", err=True)


class WeavecapGroup(click.Group):
    """A click group that loads command modules on demand and maps errors to exit statuses."""

    def list_commands(self, ctx):
        return sorted(COMMANDS)

    def get_command(self, ctx, name):
        target = COMMANDS.get(name)
        if target is None:
            return None  # click: "No such command" (exit 2)
        module, attr = target.split(":")
        return getattr(importlib.import_module(module), attr)  # a broken import is a bug: exit 1

    def format_commands(self, ctx, formatter):
        """The command list of ``--help`` (as click's); a command whose module fails to import
        is listed with its error instead of breaking the help of every other command."""
        names = self.list_commands(ctx)
        limit = formatter.width - 6 - max(map(len, names))
        rows = []
        for name in names:
            try:
                command = self.get_command(ctx, name)
            except Exception as exc:  # noqa: BLE001 - shown, not hidden: this command is broken
                rows.append((name, f"(cannot be loaded: {type(exc).__name__}: {exc})"))
                continue
            if not command.hidden:
                rows.append((name, command.get_short_help_str(limit)))
        with formatter.section("Commands"):
            formatter.write_dl(rows)

    def invoke(self, ctx):
        try:
            return super().invoke(ctx)
        except WeavecapError as exc:
            raise UserError(exc) from exc
        except KeyboardInterrupt as exc:
            click.echo(INTERRUPTED, err=True)
            raise click.exceptions.Exit(outcome(exc).exit) from None


@click.group(cls=WeavecapGroup, context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100})
@click.version_option(__version__, prog_name="weavecap")
def cli() -> None:
    """Turn a close-up photo of a woven fabric into a renderable fabric.

    \b
    Examples:
      weavecap fit swatch.jpg -o swatch/
      weavecap synth fixtures/params/twill_2_1.json -o twill.png --tiles 4x4
      weavecap prepare photo.jpg -o prepared/
      weavecap doctor
      weavecap bench

    Exit status: 0 done; 2 bad usage or invalid input file; 3 photo rejected; 1 unexpected;
    130 interrupted.
    """


class Terminated(KeyboardInterrupt):
    """SIGTERM, handled as Ctrl-C is (exit 143 instead of 130)."""


def _terminated(signum, frame):
    raise Terminated()


def _run(argv: list[str] | None) -> None:
    """The command itself; ends with SystemExit (its exit status)."""
    try:
        cli.main(args=argv, prog_name="weavecap", standalone_mode=True)
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


def main(argv: list[str] | None = None) -> None:
    """Console-script entry point: Ctrl-C (and SIGTERM) stop any command within a fraction of a
    second.

    Python runs signal handlers in the main thread between bytecodes, so a long call into C++
    (Dr.Jit compiling a kernel for minutes, a solver) would hold Ctrl-C until it returns. The
    command therefore runs in a worker thread and this thread only waits for it: on Ctrl-C it
    says so, removes the files being written (:func:`weavecap.io.remove_unfinished`; finished
    files and summary lines stay, as each was renamed into place or flushed when done) and ends
    the process, worker thread and compiler included (``os._exit``: exit 130, SIGTERM 143).
    Worker processes of ``--jobs`` die with it (:func:`weavecap.batch._die_with_parent`), and the
    lock of an ``-o`` folder goes with the process.
    """
    import signal
    import threading

    ended: dict[str, object] = {}

    def command() -> None:
        try:
            _run(argv)
        except SystemExit as exc:
            ended["exit"] = exc.code
        except BaseException as exc:  # noqa: BLE001 - WEAVECAP_DEBUG: shown by this thread
            ended["error"] = exc

    signal.signal(signal.SIGTERM, _terminated)
    worker = threading.Thread(target=command, name="weavecap-command", daemon=True)
    worker.start()
    try:
        while worker.is_alive():
            worker.join(0.25)
    except KeyboardInterrupt as exc:
        from weavecap.io import remove_unfinished

        click.echo(INTERRUPTED, err=True)
        remove_unfinished()
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(143 if isinstance(exc, Terminated) else outcome(exc).exit)
    if "error" in ended:
        raise ended["error"]
    code = ended.get("exit")
    status = code if isinstance(code, int) else (0 if code is None else 1)

    def done(signum, frame):  # the work is done: a late Ctrl-C does not wait for the shutdown
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(status)

    signal.signal(signal.SIGINT, done)
    signal.signal(signal.SIGTERM, done)
    sys.exit(code)


if __name__ == "__main__":
    main()
