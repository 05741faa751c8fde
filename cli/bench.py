"""``weavecap bench``: measured speed and accuracy (the tables of docs/performance.md, docs/capture.md
and docs/render.md)."""

from __future__ import annotations

import json
from pathlib import Path

import click


@click.command(context_settings={"max_content_width": 100})
@click.option("--quick", is_flag=True, help="Smaller benches: 3 fit photos (draft and normal presets), 1-2 render cases.")
@click.option("--model/--no-model", "do_model", default=None,
              help="The forward model: cold and warm renders, fit steps, memory.")
@click.option("--fit/--no-fit", "do_fit", default=None, help="Fit the synthetic bench photos at each quality preset.")
@click.option("--render/--no-render", "do_render", default=None,
              help="The output renderers (weavecap render): the reference against Mitsuba's path + diffuse on the "
                   "towel and the fixture meshes, cold and warm, memory; the flat swatch against synth.")
@click.option("--set", "sets", type=click.Choice(["both", "own", "independent"]), default="both", show_default=True,
              help="Fit bench photos: the forward model's own renders, the independent generator's "
                   "(weavecap.bench.heightfield_photos: height-field yarns, other shading, exposure and white balance off), "
                   "or both.")
@click.option("--preset", "presets", type=click.Choice(["draft", "normal", "high"]), multiple=True,
              help="Quality presets to fit at (repeatable; default: all three, --quick: draft and normal).")
@click.option("--light", type=click.Choice(["auto", "best"]), default="auto", show_default=True,
              help="The fit bench's --light: auto, or best (three captures a photo).")
@click.option("-o", "--output", "out", type=click.Path(file_okay=False, path_type=Path), default=Path("bench-out"),
              show_default=True, help="Folder for the photos, results.json, render.json and the speed-against-error plot.")
def bench(quick, do_model, do_fit, do_render, sets, presets, light, out):
    """Measure speed and accuracy on this machine.

    Sections: --model (the forward model), --fit (the fit bench), --render (the output
    renderers). Naming sections runs only those; --no-X runs all but X; neither runs all.

    Forward model: each case runs in a fresh process with an empty kernel cache, so "cold"
    includes compiling the kernels and "warm" is the median of later calls.

    Fit: photos with known truth (plain, twills, satins 5 and 8, basket, random patterns up to
    8x8; about 1 megapixel, turned, mild perspective, noise, JPEG) are captured end to end at
    each preset and compared with the truth, from two sets: 8 renders of the forward model
    itself (scored on the pattern, PSNR and every parameter) and 18 photos of an independent
    generator that shares no code with it (scored on the pattern, face and direction included,
    and on fidelity: sharpness, each yarn family's colour difference, structure), plus an
    exposure check (two of them 1 stop darker, 1 stop brighter and with a colour cast: how far
    the fitted colours move). Writes
    OUT/results.json, each fit's outputs under OUT/fits/ and OUT/speed_vs_error.png. The own
    set at all presets takes about 15 minutes on a 2-core machine, the independent set at
    normal about as long.

    Render: each renderer in a fresh process with an empty kernel cache, side by side on the
    same mesh, camera, lights, size (1280x720), samples (64 spp) and depth (8); the ratio is
    the reference's time over Mitsuba's path + diffuse. Writes OUT/render.json. About 15
    minutes on a 2-core machine.

    \b
    Examples:
      weavecap bench --quick
      weavecap bench --render
      weavecap bench --no-fit
      weavecap bench --fit --set independent --preset normal
      weavecap bench --fit --set independent --preset normal --light best
      weavecap bench -o bench-out/ > performance.md
    """
    from weavecap.io import atomic_write_text

    chosen = {"model": do_model, "fit": do_fit, "render": do_render}
    named = [k for k, v in chosen.items() if v]
    run = set(named) if named else {k for k, v in chosen.items() if v is None}
    say = lambda m: click.echo(m, err=True)  # noqa: E731
    if "model" in run:
        from weavecap.bench.model import CASES, run_cold, table

        results = []
        for case in CASES:
            say(f"measuring: {case.name} ...")
            results.append(run_cold(case))
        click.echo(table(results))
        click.echo("")
    if "fit" in run:
        from weavecap.bench import fit as fit_bench

        presets = presets or (("draft", "normal") if quick else ("draft", "normal", "high"))
        photo_sets = fit_bench.SETS if sets == "both" else (sets,)
        rows = fit_bench.run(presets, quick=quick, folder=out, sets=photo_sets, light=light, progress=say)
        summary = fit_bench.summary(rows)
        exposure = []
        if "independent" in photo_sets and not quick:
            for preset in presets:
                for mode in ("rig", "photo"):
                    exposure += fit_bench.exposure_invariance(preset, out / "exposure", exposure=mode, progress=say)
        atomic_write_text(out / "results.json", json.dumps({"photos": rows, "summary": summary,
                                                            "exposure": exposure}, indent=1) + "\n")
        for name, make in (("own", fit_bench.table), ("independent", fit_bench.independent_table)):
            if name in photo_sets:
                click.echo(f"fit bench, {name} photos:\n{make(summary)}\n")
        if exposure:
            click.echo(f"exposure invariance (independent photos):\n{fit_bench.exposure_table(exposure)}\n")
        if "own" in photo_sets:
            fit_bench.plot(summary, out / "speed_vs_error.png")
        click.echo(f"(plot: {out / 'speed_vs_error.png'}; details: {out / 'results.json'}; fits: {out / 'fits'})",
                   err=True)
    if "render" in run:
        from weavecap.render import bench as render_bench

        results = render_bench.run(quick=quick, progress=say)
        atomic_write_text(out / "render.json", json.dumps(results, indent=1) + "\n")
        click.echo(render_bench.tables(results))
        click.echo(f"\n(details: {out / 'render.json'})", err=True)
