"""``weavecap bench``: measured speed and accuracy (docs/performance.md's and docs/capture.md's tables)."""

from __future__ import annotations

import json
from pathlib import Path

import click


@click.command(context_settings={"max_content_width": 100})
@click.option("--quick", is_flag=True, help="A smaller fit bench: 3 photos, draft and normal presets (~2 min).")
@click.option("--render/--no-render", "do_render", default=True, show_default=True,
              help="Measure the forward model (cold and warm renders, fit steps, memory) and the woven neural "
                   "renderer against the reference (OUT/woven.json, OUT/woven_*.png; ~10 min).")
@click.option("--fit/--no-fit", "do_fit", default=True, show_default=True,
              help="Fit the synthetic bench photos at each quality preset.")
@click.option("-o", "--output", "out", type=click.Path(file_okay=False, path_type=Path), default=Path("bench-out"),
              show_default=True, help="Folder for the photos, results.json and the speed-against-error plot.")
def bench(quick, do_render, do_fit, out):
    """Measure speed and accuracy on this machine.

    Forward model: each case runs in a fresh process with an empty kernel cache, so "cold"
    includes compiling the kernels and "warm" is the median of later calls.

    Fit: synthetic photos with known truth (plain, twills, satins 5 and 8, basket, random
    patterns up to 8x8; about 1 megapixel, turned, mild perspective, noise, JPEG) are captured
    end to end at each preset and compared with the truth. Writes OUT/results.json and
    OUT/speed_vs_error.png. The full fit bench takes about 15 minutes on a 2-core machine.

    \b
    Examples:
      weavecap bench --quick
      weavecap bench --no-fit
      weavecap bench -o bench-out/ > performance.md
    """
    from weavecap.io import atomic_write_text

    if do_render:
        from weavecap.bench import CASES, run_cold, table

        results = []
        for case in CASES:
            click.echo(f"measuring: {case.name} ...", err=True)
            results.append(run_cold(case))
        click.echo(table(results))
        click.echo("")
        from weavecap.render.woven import bench as woven_bench

        woven = woven_bench.run(progress=lambda m: click.echo(m, err=True))
        out.mkdir(parents=True, exist_ok=True)
        woven_bench.write(woven, out)
        click.echo(woven_bench.table(woven))
        click.echo("")
    if do_fit:
        from weavecap import fit_bench

        presets = ("draft", "normal") if quick else ("draft", "normal", "high")
        rows = fit_bench.run(presets, quick=quick, folder=out / "photos", progress=lambda m: click.echo(m, err=True))
        summary = fit_bench.summary(rows)
        atomic_write_text(out / "results.json", json.dumps({"photos": rows, "summary": summary}, indent=1) + "\n")
        fit_bench.plot(summary, out / "speed_vs_error.png")
        click.echo(fit_bench.table(summary))
        click.echo(f"\n(plot: {out / 'speed_vs_error.png'}; details: {out / 'results.json'})", err=True)
