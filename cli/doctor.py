"""``weavecap doctor``: what the rendering backend found on this machine."""

from __future__ import annotations

import click

from .options import json_option
from .report import Reporter


@click.command()
@json_option("the findings, one object,")
@click.option("--check", is_flag=True, help="Also render a tiny scene, to prove the backend runs.")
def doctor(as_json: bool, check: bool) -> None:
    """Show the Mitsuba/Dr.Jit set-up: versions, variant, libLLVM, threads, kernel cache.

    \b
    Examples:
      weavecap doctor
      weavecap doctor --json --check
    """
    from weavecap import backend

    info = backend.describe()
    if check:
        mi = backend.mitsuba()
        img = mi.render(mi.load_dict(mi.cornell_box()), spp=1)
        info["check_render"] = f"ok ({img.shape[1]}x{img.shape[0]})"
    if as_json:
        Reporter.json(info)
    else:
        width = max(len(k) for k in info)
        for key, value in info.items():
            click.echo(f"{key:<{width}}  {value}")
