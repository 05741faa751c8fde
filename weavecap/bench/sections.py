"""``weavecap bench``'s sections run in order, each writing its files under the output folder
and returning its tables (what the command prints on standard output).

The sections: the forward model (:mod:`.model`), the fit bench on photos with known truth
(:mod:`.fit`) or the real-photo bench (:mod:`.real`), and the output renderers (:mod:`.render`).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from ..errors import InputError
from ..io import atomic_write_text


@dataclass(frozen=True)
class BenchRequest:
    """What ``weavecap bench`` was asked.

    Attributes
    ----------
    sections : the sections to run, of ``model``, ``fit``, ``render``
    out : the output folder
    quick : smaller benches
    sets : the fit bench's photos: ``both``, ``own``, ``independent`` or ``real``
    stage : with ``real``: ``fit`` or ``prepare``
    realdata : with ``real``: the real photos' folder, or None (found beside the checkout)
    presets : quality presets (empty: the section's default)
    light : the fit bench's ``--light``
    """

    sections: frozenset[str]
    out: Path
    quick: bool = False
    sets: str = "both"
    stage: str = "fit"
    realdata: Path | None = None
    presets: tuple[str, ...] = ()
    light: str = "auto"


def chosen_sections(flags: dict[str, bool | None]) -> frozenset[str]:
    """The sections to run from ``--X/--no-X`` flags (True, False or None when not given):
    the named ones, else all but those turned off."""
    named = [k for k, v in flags.items() if v]
    return frozenset(named) if named else frozenset(k for k, v in flags.items() if v is None)


def run(request: BenchRequest, say: Callable[[str], None]) -> list[str]:
    """Run the requested sections; return the tables to print, one string per section.
    ``say`` is told progress and where the files are."""
    tables = []
    if "model" in request.sections:
        tables.append(_model(say))
    if "fit" in request.sections:
        tables.append(_real(request, say) if request.sets == "real" else _fit(request, say))
    if "render" in request.sections:
        tables.append(_render(request, say))
    return [t for t in tables if t]


def _model(say) -> str:
    from .model import CASES, run_cold, table

    results = []
    for case in CASES:
        say(f"measuring: {case.name} ...")
        results.append(run_cold(case))
    return table(results) + "\n"


def _real(request: BenchRequest, say) -> str:
    from . import real

    folder = real.find_realdata(request.realdata)
    if folder is None and request.realdata is not None:
        raise InputError(f"{request.realdata}: holds no fabricnet/labels.csv; give --realdata the realdata folder of "
                         "../shared")
    if folder is None:
        say("the real photos were not found (give --realdata, or set WEAVECAP_SHARED): the real-photo bench is skipped")
        return ""
    out = request.out / "real"
    rows = real.run(folder, out, stage=request.stage, quality=(request.presets or ("normal",))[0], progress=say)
    real.write(rows, out)
    say(f"(per photo: {out / 'real.md'}; {out / 'real.jsonl'}; outputs: {out / 'fits'})")
    return f"real photos ({request.stage}):\n{real.summary_table(rows)}\n"


def _fit(request: BenchRequest, say) -> str:
    from . import fit as fit_bench

    out = request.out
    presets = request.presets or (("draft", "normal") if request.quick else ("draft", "normal", "high"))
    photo_sets = fit_bench.SETS if request.sets == "both" else (request.sets,)
    rows = fit_bench.run(presets, quick=request.quick, folder=out, sets=photo_sets, light=request.light, progress=say)
    summary = fit_bench.summary(rows)
    exposure = []
    if "independent" in photo_sets and not request.quick:
        for preset in presets:
            for mode in ("rig", "photo"):
                exposure += fit_bench.exposure_invariance(preset, out / "exposure", exposure=mode, progress=say)
    atomic_write_text(out / "results.json", json.dumps({"photos": rows, "summary": summary, "exposure": exposure},
                                                       indent=1) + "\n")
    text = [f"fit bench, {name} photos:\n{make(summary)}\n"
            for name, make in (("own", fit_bench.table), ("independent", fit_bench.independent_table))
            if name in photo_sets]
    if exposure:
        text.append(f"exposure invariance (independent photos):\n{fit_bench.exposure_table(exposure)}\n")
    if "own" in photo_sets:
        fit_bench.plot(summary, out / "speed_vs_error.png")
    say(f"(plot: {out / 'speed_vs_error.png'}; details: {out / 'results.json'}; fits: {out / 'fits'})")
    return "\n".join(text)


def _render(request: BenchRequest, say) -> str:
    from . import render as render_bench

    results = render_bench.run(quick=request.quick, progress=say)
    atomic_write_text(request.out / "render.json", json.dumps(results, indent=1) + "\n")
    say(f"(details: {request.out / 'render.json'})")
    return render_bench.tables(results)
