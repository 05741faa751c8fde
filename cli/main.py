"""Entry point of the ``weavecap`` command: the group, lazy command loading, and exit statuses.

Commands are imported only when invoked, so ``weavecap --help`` starts fast and does not load
Mitsuba. Errors a user can fix (:class:`weavecap.errors.WeavecapError`) become a one-paragraph
message and their exit status (2 input, 3 rejected photo); anything else exits 1 with a short
message (set ``WEAVECAP_DEBUG=1`` for the traceback).
"""

from __future__ import annotations

import importlib
import os
import sys

import click

from weavecap import __version__
from weavecap.errors import WeavecapError

#: command name → "module:function" (modules under weavecap.cli)
COMMANDS = {
    "fit": "weavecap.cli.fit:fit",
    "synth": "weavecap.cli.synth:synth",
    "prepare": "weavecap.cli.prepare:prepare",
    "doctor": "weavecap.cli.doctor:doctor",
    "bench": "weavecap.cli.bench:bench",
    "train-initializer": "weavecap.cli.train_initializer:train_initializer",
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
            return None
        module, attr = target.split(":")
        try:
            return getattr(importlib.import_module(module), attr)
        except ModuleNotFoundError:
            return None

    def invoke(self, ctx):
        try:
            return super().invoke(ctx)
        except WeavecapError as exc:
            raise UserError(exc) from exc
        except KeyboardInterrupt:
            click.echo(INTERRUPTED, err=True)
            raise click.exceptions.Exit(130) from None


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

    Exit status: 0 done; 2 bad usage or invalid input file; 3 photo rejected; 1 unexpected.
    """


def main(argv: list[str] | None = None) -> None:
    """Console-script entry point."""
    try:
        cli.main(args=argv, prog_name="weavecap", standalone_mode=True)
    except SystemExit:
        raise
    except KeyboardInterrupt:
        click.echo(INTERRUPTED, err=True)
        sys.exit(130)
    except Exception as exc:  # noqa: BLE001 - the last line of defence: no tracebacks for users
        if os.environ.get("WEAVECAP_DEBUG"):
            raise
        click.echo(f"weavecap: unexpected error: {type(exc).__name__}: {exc}\n"
                   "  (set WEAVECAP_DEBUG=1 to see the traceback, and please report it)", err=True)
        sys.exit(1)


if __name__ == "__main__":
    main()
