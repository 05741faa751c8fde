"""``weavecap bench``: measured speed and memory (the README's Performance table)."""

from __future__ import annotations

import click


@click.command(context_settings={"max_content_width": 100})
def bench():
    """Measure the forward model: cold and warm render times, fit steps, peak memory.

    Each case runs in a fresh process with an empty kernel cache, so "cold" includes compiling
    the kernels and "warm" is the median of later calls. Takes about half a minute.

    \b
    Examples:
      weavecap bench
      weavecap bench > performance.md
    """
    from weavecap.bench import CASES, run_cold, table

    results = []
    for case in CASES:
        click.echo(f"measuring: {case.name} ...", err=True)
        results.append(run_cold(case))
    click.echo(table(results))
