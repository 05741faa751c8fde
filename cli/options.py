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


def size_pair(form: str, example: str, names: str, high: int):
    """A click callback that reads two whole numbers ``AxB``, each in [1, ``high``]: render's
    ``--size WxH``, synth's ``--tiles NxM``. ``form`` and ``example`` are shown when the form
    is wrong, ``names`` when a number is out of range."""
    def parse(ctx, param, value: str) -> tuple[int, int]:
        try:
            a, b = (int(v) for v in value.lower().split("x"))
        except ValueError:
            raise click.BadParameter(f"{value!r} is not of the form {form}, e.g. {example}") from None
        if not (1 <= a <= high and 1 <= b <= high):
            raise click.BadParameter(f"{value!r}: {names} must be in [1, {high}]")
        return a, b
    return parse


#: synth's ``--tiles``: rows x columns of repeats; render's ``--size``: width x height in pixels
parse_tiles = size_pair("NxM", "4x4", "each count", 64)
parse_size = size_pair("WxH", "1280x720", "width and height", 16384)


def parse_offset(ctx, param, value: str) -> tuple[float, float]:
    """Parse ``U,V`` (render's ``--fabric-offset``, in repeats), e.g. ``0.5,0``."""
    try:
        u, v = (float(x) for x in value.split(","))
    except ValueError:
        raise click.BadParameter(f"{value!r} is not of the form U,V (in repeats), e.g. 0.5,0") from None
    return u, v


def json_option(what: str):
    """``--json``: print ``what`` (``"the summary"``) on standard output (:meth:`Reporter.json`)."""
    return click.option("--json", "as_json", is_flag=True, help=f"Print {what} as JSON on standard output.")
