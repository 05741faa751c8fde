"""``weavecap bench``: measured speed and accuracy (the tables of docs/performance.md, docs/capture.md
and docs/render.md)."""

from __future__ import annotations

from pathlib import Path

import click

from .report import Reporter


@click.command(context_settings={"max_content_width": 100})
@click.option("--quick", is_flag=True, help="Smaller benches: 3 fit photos (draft and normal presets), 1-2 render cases.")
@click.option("--model/--no-model", "do_model", default=None,
              help="The forward model: cold and warm renders, fit steps, memory.")
@click.option("--fit/--no-fit", "do_fit", default=None, help="Fit the synthetic bench photos at each quality preset.")
@click.option("--render/--no-render", "do_render", default=None,
              help="The output renderers (weavecap render): the reference against Mitsuba's path + diffuse on the "
                   "towel and the fixture meshes, cold and warm, memory; the flat swatch against synth.")
@click.option("--set", "sets", type=click.Choice(["both", "own", "independent", "real"]), default="both",
              show_default=True,
              help="Fit bench photos: the forward model's own renders, the independent generator's "
                   "(weavecap.bench.heightfield_photos: height-field yarns, other shading, exposure and white balance off), "
                   "both, or the real photos of ../shared/realdata (scored against their labels, DEV and HELD-OUT "
                   "fabrics apart).")
@click.option("--stage", type=click.Choice(["fit", "prepare"]), default="fit", show_default=True,
              help="With --set real: capture each photo end to end, or only prepare it (seconds a photo: the "
                   "grid, pitch and rejections, to iterate on preparation's rules).")
@click.option("--realdata", type=click.Path(file_okay=False, path_type=Path),
              help="With --set real: the real photos' folder (default: $WEAVECAP_SHARED/realdata, or "
                   "../shared/realdata beside the checkout).")
@click.option("--preset", "presets", type=click.Choice(["draft", "normal", "high"]), multiple=True,
              help="Quality presets to fit at (repeatable; default: all three, --quick: draft and normal).")
@click.option("--light", type=click.Choice(["auto", "best"]), default="auto", show_default=True,
              help="The fit bench's --light: auto, or best (three captures a photo).")
@click.option("-o", "--output", "out", type=click.Path(file_okay=False, path_type=Path), default=Path("bench-out"),
              show_default=True, help="Folder for the photos, results.json, render.json and the speed-against-error plot.")
def bench(quick, do_model, do_fit, do_render, sets, stage, realdata, presets, light, out):
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

    Real photos (--set real, at the first --preset, default normal): FabricNET, KTH-TIPS2-a,
    two yarn-dyed checks, the easy, hard and negative photos of ../shared/realdata, read in
    place; per photo the status or rejection, the weave and its family against the label,
    the thread-density ratio against the label's, the fidelity figures and seconds; per
    fabric whether its views agree; the summary for the DEV fabrics (rules are decided on),
    the HELD-OUT ones and all. Writes OUT/real/real.md, real.jsonl, real.csv and each photo's
    outputs under OUT/real/fits/; an interrupted run resumes (OUT/real/rows.jsonl). Skipped,
    with a message, where the folder is absent. About 1 to 3 minutes a photo at normal on a
    busy 2-core machine; --stage prepare about a second.

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
      weavecap bench --fit --set real --stage prepare -o bench-out/
      weavecap bench --fit --set real --preset normal -o bench-out/
      weavecap bench -o bench-out/ > performance.md
    """
    from weavecap.bench.sections import BenchRequest, chosen_sections, run

    sections = chosen_sections({"model": do_model, "fit": do_fit, "render": do_render})
    for table in run(BenchRequest(sections, out, quick=quick, sets=sets, stage=stage, realdata=realdata,
                                  presets=presets, light=light), Reporter("bench").say):
        click.echo(table)
