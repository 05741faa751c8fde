"""What a command tells its user, the same way for every command.

Messages go to standard error as ``weavecap CMD: message``; ``-q`` keeps all but errors,
``-v`` (repeated) adds the more detailed ones (``level``). Progress that only helps someone
watching (samples per pixel, training steps) shows on a terminal or with ``-v``. ``--json``
output, the one thing on standard output, is :meth:`Reporter.json`. A batch's events
(:class:`weavecap.batch.Event`) are told by :meth:`Reporter.batch`: skipped, started, finished
or failed, one line each.
"""

from __future__ import annotations

import contextlib
import logging
import sys
from typing import Callable, Iterator

import click


class Reporter:
    """The messages of one run of ``weavecap command`` (``verbose``: the count of ``-v``)."""

    def __init__(self, command: str, verbose: int = 0, quiet: bool = False):
        self.prefix = f"weavecap {command}: "
        self.verbose = verbose
        self.quiet = quiet

    def say(self, message: str, level: int = 0, *, error: bool = False) -> None:
        """Tell ``message``: errors always, others unless ``-q`` and if ``-v`` was given
        ``level`` times."""
        if error or (not self.quiet and self.verbose >= level):
            click.echo(self.prefix + message, err=True)

    @property
    def watched(self) -> bool:
        """Whether progress shows: not ``-q``, and standard error a terminal or ``-v`` given."""
        return not self.quiet and (sys.stderr.isatty() or self.verbose > 0)

    def progress(self, message: str) -> None:
        """A message that only helps someone watching (:attr:`watched`)."""
        if self.watched:
            self.say(message)

    @contextlib.contextmanager
    def stages(self, channel: str = "weavecap.progress") -> Iterator[None]:
        """Within it, the library's stage messages (the :mod:`logging` channel ``channel``, e.g.
        :data:`weavecap.pipeline.PROGRESS`) show as progress (:meth:`progress`)."""
        reporter = self

        class Shown(logging.Handler):
            def emit(self, record: logging.LogRecord) -> None:
                reporter.progress(record.getMessage())

        logger, handler = logging.getLogger(channel), Shown()
        logger.addHandler(handler)
        logger.setLevel(logging.INFO)
        try:
            yield
        finally:
            logger.removeHandler(handler)

    def counter(self, what: str, unit: str) -> Callable[[int, int], None]:
        """A ``(done, total)`` callable that keeps one line up to date while watched:
        ``weavecap CMD: what: done/total unit``."""
        def count(done: int, total: int) -> None:
            if self.watched:
                click.echo(f"\r{self.prefix}{what}: {done}/{total} {unit}", err=True, nl=False)
                if done == total:
                    click.echo("", err=True)
        return count

    def batch(self, started: str, finished: Callable[[object, str], None], *, started_level: int = 0):
        """An ``on_event`` for :func:`weavecap.batch.run`: an input skipped (finished earlier),
        started (``started``, e.g. ``"fitting (draft)"``, at ``started_level``), failed
        (its status and reason, always shown) or done (``finished(event, "[i/n]")`` says it)."""
        def report(event) -> None:
            source, record, where = event.item.source, event.record, f"[{event.index}/{event.total}]"
            if event.kind == "skipped":
                self.say(f"{source}: already done ({record['status']}), skipped; --force redoes it")
            elif event.kind == "started":
                self.say(f"{where} {source}: {started}", level=started_level)
            elif record.get("status") == "ok":
                finished(event, where)
            else:
                self.say(f"{where} {source}: {event.line['status']}: {record.get('reason')}", error=True)
        return report

    @staticmethod
    def json(doc) -> None:
        """``--json``: ``doc`` on standard output, indented (strict JSON: an unmeasured figure is null)."""
        from weavecap.io import dumps_json

        click.echo(dumps_json(doc, indent=1))

    @staticmethod
    def exit(status: int) -> None:
        """End the command with ``status`` where it is not 0 (a batch's worst outcome)."""
        if status:
            raise click.exceptions.Exit(status)
