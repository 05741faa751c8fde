"""Options shared by several commands, defined once."""

from __future__ import annotations

from pathlib import Path

import click

force_option = click.option("--force", is_flag=True, help="Overwrite outputs that already exist.")
seed_option = click.option("--seed", type=int, default=0, show_default=True,
                           help="Random seed; the same seed gives the same result.")
verbose_option = click.option("-v", "--verbose", count=True, help="Say more (repeat for more).")
quiet_option = click.option("-q", "--quiet", is_flag=True, help="Print nothing but errors.")
pattern_option = click.option(
    "--pattern", "pattern_file", type=click.Path(dir_okay=False, readable=False, path_type=Path),
    help="Use this weave pattern instead of the params file's: a .wif weaving draft, a params .json, "
         "or a text file of 0/1 rows (1 = weft over warp).")


class FiniteFloat(click.FloatRange):
    """A float option in a range, NaN and infinities refused (click's FloatRange lets NaN
    through: every comparison with it is false)."""

    name = "float"

    def convert(self, value, param, ctx):
        import math

        number = super().convert(value, param, ctx)
        if not math.isfinite(number):
            self.fail(f"{value!r} is not a finite number", param, ctx)
        return number


def jobs_option(done: str):
    """``--jobs N`` of a batch command: ``done`` says what happens to its inputs (``"Photos fitted"``)."""
    return click.option("--jobs", type=click.IntRange(min=1, max=64), default=1, show_default=True,
                        help=f"{done} in parallel processes on this machine.")


def scheduler_option(item: str):
    """``--scheduler ADDRESS`` of a batch command (:func:`weavecap.batch.run`); ``item`` names one input."""
    return click.option("--scheduler", metavar="ADDRESS",
                        help="Run the batch on a Dask cluster: a scheduler's address (tcp://host:8786, see "
                             "`dask scheduler`; tls://host:8786 with Dask's TLS settings), or local:N for N workers "
                             f"here. A {item} whose worker dies is retried once. Jobs and results travel as "
                             "pickles: use only a cluster you trust (docs/reliability.md).")


def check_batch_options(jobs: int, scheduler: str | None) -> None:
    """Refuse ``--jobs`` with ``--scheduler``, and a scheduler address weavecap cannot use
    (:func:`weavecap.batch.scheduler_security`), before any work.

    Raises
    ------
    InputError
        Both given, ``local:`` with a bad count, a protocol other than tcp:// and tls://, or
        tls:// without Dask's TLS settings.
    """
    from weavecap.batch import scheduler_security
    from weavecap.errors import InputError

    if scheduler and jobs > 1:
        raise InputError("--jobs and --scheduler exclude each other: --jobs N runs N processes here, "
                         "--scheduler local:N runs N Dask workers here")
    if scheduler:
        scheduler_security(scheduler)


def parse_tiles(ctx, param, value: str) -> tuple[int, int]:
    """Parse ``NxM`` (rows x columns of repeats), e.g. ``4x4``."""
    try:
        rows, cols = (int(v) for v in value.lower().split("x"))
    except ValueError:
        raise click.BadParameter(f"{value!r} is not of the form NxM, e.g. 4x4") from None
    if not (1 <= rows <= 64 and 1 <= cols <= 64):
        raise click.BadParameter(f"{value!r}: each count must be in [1, 64]")
    return rows, cols


def claim_work_folder(work, plan: dict, *, name: str = "config.json") -> None:
    """Make ``work`` hold the data of ``plan`` (a dict of settings, recorded in ``work/name``):
    refuse, naming the file, a folder that holds data made with other settings."""
    import json

    from weavecap.errors import InputError

    plan_file = work / name
    if plan_file.is_file() and json.loads(plan_file.read_text()) != json.loads(json.dumps(plan)):
        raise InputError(f"{work}: holds data or a checkpoint made with other settings ({plan_file}); use another "
                         "--work folder or delete that one")
    work.mkdir(parents=True, exist_ok=True)
    plan_file.write_text(json.dumps(plan, indent=1) + "\n")
