"""``weavecap fit``: photos in, fabrics out (the main job; DESIGN.md, Wu et al. 2025 §4–6)."""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

import click

from .options import force_option, quiet_option, seed_option, verbose_option

SEVERITY = {0: 0, 2: 1, 3: 2, 1: 3}  # a batch exits with its worst status: 1 > 3 > 2 > 0
STATUS_EXIT = {"ok": 0, "rejected": 3, "invalid": 2, "failed": 1}


def _folders(photos: list[Path], out: Path) -> list[Path]:
    """One output folder per photo: OUT itself for one photo, OUT/<stem>[-k] for several."""
    if len(photos) == 1:
        return [out]
    seen: dict[str, int] = {}
    folders = []
    for p in photos:
        k = seen.get(p.stem, 0)
        seen[p.stem] = k + 1
        folders.append(out / (p.stem if k == 0 else f"{p.stem}-{k + 1}"))
    return folders


def _finished(folder: Path, photo: Path) -> dict | None:
    """The report of an earlier run of this very photo into ``folder``, if it finished."""
    from weavecap.photo import file_sha256

    try:
        report = json.loads((folder / "report.json").read_text())
        if report.get("status") in ("ok", "rejected") and report["input"].get("sha256") == file_sha256(photo):
            return report
    except (OSError, ValueError, KeyError, TypeError):
        return None
    return None


def _summary_line(photo: Path, folder: Path, report: dict, code: int) -> dict:
    fit = report.get("fit", {})
    line = {"photo": str(photo), "folder": str(folder), "status": report.get("status"), "exit": code}
    if report.get("status") == "ok":
        line.update(weave=report.get("weave"), psnr_db=fit.get("psnr_db"),
                    pattern_confidence=fit.get("pattern_confidence"), yarns=report["grid"]["yarns"])
    else:
        line["reason"] = report.get("reason")
    line["seconds"] = report.get("timings_s", {}).get("total")
    return line


def _run_one(photo: str, folder: str, options, threads: int | None) -> tuple[dict, int]:
    """Capture one photo into ``folder``; never raises (a failure is a report). Runs in a
    worker process with ``--jobs``."""
    from weavecap.errors import WeavecapError
    from weavecap.io import atomic_write_text
    from weavecap.pipeline import base_report, capture, write_capture

    if threads:
        from weavecap.backend import mitsuba

        mitsuba()
        import drjit

        drjit.set_thread_count(threads)
    t0 = time.perf_counter()
    try:
        cap = capture(photo, options)
        write_capture(cap, Path(folder))
        return cap.report, STATUS_EXIT[cap.status]
    except WeavecapError as exc:
        status, code = ("rejected", 3) if exc.exit_code == 3 else ("invalid", exc.exit_code)
        reason = str(exc)
    except Exception as exc:  # noqa: BLE001 - one bad photo must not stop a batch
        if os.environ.get("WEAVECAP_DEBUG"):
            raise
        status, code, reason = "failed", 1, f"unexpected error: {type(exc).__name__}: {exc}"
    report = base_report(photo, options)
    report.update(status="failed" if status == "invalid" else status, reason=reason,
                  timings_s={"total": round(time.perf_counter() - t0, 3)})
    Path(folder).mkdir(parents=True, exist_ok=True)
    atomic_write_text(Path(folder) / "report.json", json.dumps(report, indent=1) + "\n")
    return report, code


@click.command(context_settings={"max_content_width": 100})
@click.argument("photos", nargs=-1, required=True, type=click.Path(dir_okay=False, path_type=Path), metavar="PHOTO...")
@click.option("-o", "--output", "out", required=True, type=click.Path(file_okay=False, path_type=Path),
              help="Output folder (one photo: its files; several: one sub-folder each + summary.jsonl).")
@click.option("--quality", type=click.Choice(["draft", "normal", "high"]), default="normal", show_default=True,
              help="Speed against accuracy (see the README's bench table).")
@click.option("--light", type=click.Choice(["both", "front", "back"]), default="both", show_default=True,
              help="How the photo was lit: room light (front, back and sides), or front-only / back-only.")
@click.option("--budget", "budget_s", type=click.FloatRange(min=1), default=None,
              help="Stop each photo's fit after this many seconds (the best result so far is kept).")
@click.option("--jobs", type=click.IntRange(min=1, max=64), default=1, show_default=True,
              help="Photos fitted in parallel processes.")
@click.option("--start-from", "start_from", type=click.Path(dir_okay=False, path_type=Path),
              help="Warm start: begin the fit at this params.json instead of the pre-estimate.")
@click.option("--pattern", "pattern_file", type=click.Path(dir_okay=False, path_type=Path),
              help="A known weave pattern (params .json, .wif weaving draft, or a text file of 0/1 rows), kept fixed.")
@click.option("--no-network", is_flag=True, help="Start from Table 1 defaults instead of the initializer network.")
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON on standard output.")
@seed_option
@force_option
@verbose_option
@quiet_option
def fit(photos, out, quality, light, budget_s, jobs, start_from, pattern_file, no_network, as_json, seed, force,
        verbose, quiet):
    """Capture woven fabrics from close-up photos: pattern, yarn geometry and appearance.

    For each PHOTO: rectify and find the yarn grid (§4), pre-estimate pattern, colours and
    parameters (§5), fit them jointly by annealing and gradients through the renderer (§6),
    and estimate the irregularity noise (§6.3). Writes params.json (the fabric; render it with
    `weavecap synth`), report.json (what was found, how long each stage took), compare.png
    (photo | fit | error), rectified.png, grid.png (check the yarn grid by eye) and loss.png.

    A photo that is not a resolvable woven fabric gets a report.json saying why and no
    params.json. A batch goes on past bad photos, writes OUT/summary.jsonl one line per photo
    as each finishes, and exits with the worst status. Run it again to resume: finished photos
    are skipped (unless --force); results are never overwritten without --force.

    \b
    Examples:
      weavecap fit swatch.jpg -o swatch/
      weavecap fit photos/*.jpg -o catalogue/ --jobs 2 --quality draft
      weavecap fit swatch.dng -o swatch/ --light back --budget 30 --force
      weavecap fit swatch.jpg -o refit/ --start-from swatch/params.json --pattern twill.txt
    """
    from weavecap import params as wparams
    from weavecap.errors import InputError
    from weavecap.patterns import load_pattern
    from weavecap.pipeline import OUTPUT_FILES, CaptureOptions

    def say(message: str, level: int = 0) -> None:
        if not quiet and verbose >= level:
            click.echo(f"weavecap fit: {message}", err=True)

    if out.exists() and not out.is_dir():
        raise InputError(f"{out}: exists and is not a folder; give a folder name for -o")
    for p in photos:
        if not p.is_file():
            raise InputError(f"{p}: no such photo; check the path (nothing was written)")
    options = CaptureOptions(quality=quality, light=light, seed=seed, budget_s=budget_s,
                             start_from=wparams.load(start_from) if start_from else None,
                             pattern=load_pattern(pattern_file) if pattern_file else None,
                             use_network=not no_network)
    folders = _folders(list(photos), out)
    batch = len(photos) > 1
    todo, lines, worst = [], [], 0
    for photo, folder in zip(photos, folders):
        done = None if force else _finished(folder, photo)
        if done is not None and batch:
            code = STATUS_EXIT[done["status"]]
            say(f"{photo}: already done ({done['status']}), skipped; --force redoes it")
            lines.append(_summary_line(photo, folder, done, code))
            worst = max(worst, code, key=SEVERITY.get)
            continue
        if not force and any((folder / name).exists() for name in OUTPUT_FILES):
            raise InputError(f"{folder}: holds results of another run; use --force to overwrite them or choose "
                             "another -o folder (nothing was written)")
        todo.append((photo, folder))

    summary_path = out / "summary.jsonl"
    if batch:
        out.mkdir(parents=True, exist_ok=True)
        recorded = set()
        if summary_path.exists() and not force:
            for raw in summary_path.read_text().splitlines():
                try:
                    recorded.add(json.loads(raw)["photo"])
                except (ValueError, KeyError):
                    continue
        elif force:
            summary_path.unlink(missing_ok=True)
        for line in lines:  # finished earlier but missing from the summary (interrupted write)
            if line["photo"] not in recorded:
                _append(summary_path, line)

    def finished(photo: Path, folder: Path, report: dict, code: int, index: int) -> None:
        nonlocal worst
        worst = max(worst, code, key=SEVERITY.get)
        line = _summary_line(photo, folder, report, code)
        lines.append(line)
        if batch:
            _append(summary_path, line)
        if report.get("status") == "ok":
            say(f"[{index}/{len(todo)}] {photo}: {report['weave']}, {report['grid']['yarns'][0]}x"
                f"{report['grid']['yarns'][1]} repeat, PSNR {report['fit']['psnr_db']:.1f} dB, "
                f"{report['timings_s']['total']:.1f} s -> {folder}")
        else:
            say(f"[{index}/{len(todo)}] {photo}: {report.get('status')}: {report.get('reason')}")

    threads = max(1, (os.cpu_count() or 1) // jobs) if jobs > 1 else None
    if jobs > 1 and len(todo) > 1:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor, as_completed

        with ProcessPoolExecutor(max_workers=jobs, mp_context=multiprocessing.get_context("spawn")) as pool:
            futures = {pool.submit(_run_one, str(p), str(f), options, threads): (p, f) for p, f in todo}
            for i, fut in enumerate(as_completed(futures), 1):
                p, f = futures[fut]
                finished(p, f, *fut.result(), i)
    else:
        for i, (p, f) in enumerate(todo, 1):
            say(f"[{i}/{len(todo)}] {p}: fitting ({quality})")
            finished(p, f, *_run_one(str(p), str(f), options, None), i)

    if as_json:
        click.echo(json.dumps(lines if batch else lines[0], indent=1))
    if worst:
        raise click.exceptions.Exit(worst)


def _append(path: Path, line: dict) -> None:
    """Append one JSON line and flush it to disk (a crash loses at most the line being written)."""
    with open(path, "a", encoding="utf-8") as fh:
        fh.write(json.dumps(line) + "\n")
        fh.flush()
        os.fsync(fh.fileno())
