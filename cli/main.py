"""Entry point of the ``weavecap`` command: the group, lazy command loading, and exit statuses.

Commands are imported only when invoked, so ``weavecap --help`` starts fast and does not load
Mitsuba. Errors a user can fix (:class:`weavecap.errors.WeavecapError`) become a one-paragraph
message and their exit status from :data:`weavecap.errors.OUTCOMES` (2 input, 3 rejected
photo); anything else — a command module that fails to import included — exits 1 with a short
message (set ``WEAVECAP_DEBUG=1`` for the traceback; :mod:`cli.process`, which also stops a
command at once on Ctrl-C). Only a name missing from :data:`COMMANDS` is "No such command"
(exit 2).
"""

from __future__ import annotations

import importlib

import click

from weavecap import __version__
from weavecap.errors import WeavecapError, outcome

from . import process
from .process import INTERRUPTED

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


def main(argv: list[str] | None = None) -> None:
    """Console-script entry point: the command as :func:`cli.process.run` runs it (a child
    process, so that Ctrl-C and SIGTERM stop it within a fraction of a second)."""
    process.run(lambda: cli.main(args=argv, prog_name="weavecap", standalone_mode=True))


if __name__ == "__main__":
    main()
