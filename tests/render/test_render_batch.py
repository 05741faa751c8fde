"""``weavecap render A.json B.json ... MESH -o DIR`` is a batch like ``weavecap fit``'s
(weavecap/batch.py): a folder per params file with its image and record, ``summary.jsonl`` one
line each, the same image as a single render, a rerun that renders nothing twice, a bad params
file reported (exit 2) while the others finish. Dask: tests/test_batch_dask.py.

Renders are tiny (32x24 pixels, 2 samples, direct light) so the file stays quick.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from click.testing import CliRunner
from params_cases import bad_params_text

from weavecap.cli.main import cli
from weavecap.photo import file_sha256, load_photo

ROOT = Path(__file__).resolve().parents[2]
PARAMS = ROOT / "fixtures" / "params"
MESH = ROOT / "fixtures" / "meshes" / "drape.obj"
TINY = ["--size", "32x24", "--spp", "2", "--mode", "direct", "--pitch-mm", "2"]
NAMES = ("plain", "twill_2_1", "satin_5")


def render(*args):
    return CliRunner().invoke(cli, ["render", *map(str, args)])


def summary(out: Path) -> list[dict]:
    return [json.loads(line) for line in (out / "summary.jsonl").read_text().splitlines()]


def outputs(out: Path) -> dict[Path, int]:
    """Every file under ``out`` but the summary, and when it was last written."""
    return {p: p.stat().st_mtime_ns for p in out.rglob("*") if p.is_file() and p.name != "summary.jsonl"}


def test_three_params_give_three_images_and_three_summary_lines(tmp_path):
    out = tmp_path / "looks"
    result = render(*[PARAMS / f"{n}.json" for n in NAMES], MESH, "-o", out, *TINY, "--sheet")
    assert result.exit_code == 0, result.output
    lines = summary(out)
    assert [Path(line["params"]).stem for line in lines] == list(NAMES)  # serial: in order
    images = {}
    for name, line in zip(NAMES, lines):
        assert line["status"] == "ok" and line["exit"] == 0 and line["mode"] == "direct" and line["spp"] == 2
        assert line["output"] == str(out / name / "render.png") and line["folder"] == str(out / name)
        record = json.loads((out / name / "render.json").read_text())
        assert record["status"] == "ok" and record["input"]["sha256"] == file_sha256(PARAMS / f"{name}.json")
        assert record["timings_s"]["render"] > 0 and record["mesh"]["triangles"] == 2048
        images[name] = load_photo(out / name / "render.png").rgb
        assert images[name].shape == (24, 32, 3) and images[name].mean() > 0.02
    assert not np.array_equal(images["plain"], images["twill_2_1"])  # each its own fabric
    assert sorted(p.name for p in out.iterdir()) == ["plain", "satin_5", "sheet.png", "summary.jsonl", "twill_2_1"]
    assert load_photo(out / "sheet.png").rgb.shape[1] > 2 * 32
    single = tmp_path / "plain.png"  # one params file: a batch of one, into the image -o names and its record
    assert render(PARAMS / "plain.json", MESH, "-o", single, *TINY).exit_code == 0
    assert single.read_bytes() == (out / "plain" / "render.png").read_bytes()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["looks", "plain.png", "plain.png.json"]
    record, batch_record = (json.loads(p.read_text()) for p in (tmp_path / "plain.png.json", out / "plain" / "render.json"))
    assert record["output"] == str(single) and record["input"] == batch_record["input"]
    assert record["timings_s"]["mesh"] > 0 and "mesh" not in batch_record["timings_s"]
    for doc in (record, batch_record):  # all but the image's name and the seconds are the same
        doc["fold_detail"].pop("timings")
        del doc["output"], doc["timings_s"]
    assert record == batch_record


def test_a_rerun_resumes_renders_nothing_twice_and_force_redoes_all(tmp_path):
    """An interrupted batch (the last render and its line lost) resumes with that render only;
    run again, nothing is rendered; each params file keeps one summary line."""
    out = tmp_path / "looks"
    args = [*[PARAMS / f"{n}.json" for n in NAMES], MESH, "-o", out, *TINY]
    assert render(*args).exit_code == 0
    for p in (out / "satin_5").iterdir():
        p.unlink()
    (out / "summary.jsonl").write_text("".join(json.dumps(line) + "\n" for line in summary(out)[:2]))
    kept = outputs(out)

    again = render(*args)
    assert again.exit_code == 0, again.output
    assert again.output.count("already done (ok), skipped") == 2 and again.output.count("wrote") == 1
    assert {p: outputs(out)[p] for p in kept} == kept  # the finished two untouched
    assert sorted(Path(line["params"]).stem for line in summary(out)) == sorted(NAMES)

    done = outputs(out)
    third = render(*args)
    assert third.exit_code == 0 and third.output.count("already done") == 3 and "wrote" not in third.output
    assert outputs(out) == done and len(summary(out)) == 3

    forced = render(*args, "--force")
    assert forced.exit_code == 0 and forced.output.count("wrote") == 3 and "already done" not in forced.output
    assert all(outputs(out)[p] != t for p, t in done.items()) and len(summary(out)) == 3


def test_a_folder_of_another_params_file_is_refused(tmp_path):
    """The same name, other content: its folder holds another run's results (exit 2, nothing
    written) until --force."""
    out = tmp_path / "looks"
    src = tmp_path / "src"
    src.mkdir()
    files = [src / f"{n}.json" for n in NAMES[:2]]
    for n, f in zip(NAMES, files):
        f.write_bytes((PARAMS / f"{n}.json").read_bytes())
    assert render(*files, MESH, "-o", out, *TINY).exit_code == 0
    files[1].write_bytes((PARAMS / "satin_5.json").read_bytes())
    before = outputs(out)
    refused = render(*files, MESH, "-o", out, *TINY)
    assert refused.exit_code == 2 and "holds results of another run" in refused.output
    assert outputs(out) == before


def test_a_bad_params_file_gets_its_line_and_exit_2_while_the_others_finish(tmp_path):
    """In worker processes (--jobs 2): the bad file's line says which field and why, it writes
    nothing; fixed, a rerun renders just it."""
    bad = tmp_path / "bad.json"
    bad.write_text(bad_params_text({"specular.ior": 3.5}))
    out = tmp_path / "looks"
    args = [PARAMS / "plain.json", bad, PARAMS / "satin_5.json", MESH, "-o", out, *TINY, "--jobs", "2"]
    result = render(*args)
    assert result.exit_code == 2, result.output
    lines = {Path(line["params"]).stem: line for line in summary(out)}
    assert len(summary(out)) == 3 and {k: v["status"] for k, v in lines.items()} == {
        "plain": "ok", "bad": "invalid", "satin_5": "ok"}
    assert lines["bad"]["exit"] == 2 and str(bad) in lines["bad"]["reason"] and "specular.ior" in lines["bad"]["reason"]
    assert "specular.ior" in result.output and "Traceback" not in result.output
    assert not (out / "bad").exists()
    for name in ("plain", "satin_5"):
        assert load_photo(out / name / "render.png").rgb.mean() > 0.02

    bad.write_text(bad_params_text({"specular.ior": 1.5}))
    fixed = render(*args)
    assert fixed.exit_code == 0 and fixed.output.count("already done") == 2 and fixed.output.count("wrote") == 1
    assert [line["status"] for line in summary(out)] == ["ok", "ok", "ok"]
    assert (out / "bad" / "render.png").is_file()


def test_batch_options_need_several_params_and_exclude_each_other(tmp_path):
    one = [PARAMS / "plain.json", MESH, "-o", tmp_path / "x.png", *TINY]
    for option in (["--jobs", "2"], ["--scheduler", "local:2"], ["--sheet"]):
        result = render(*one, *option)
        assert result.exit_code == 2 and f"{option[0]} needs several PARAMS files" in result.output
    two = [PARAMS / "plain.json", PARAMS / "satin_5.json", MESH, "-o", tmp_path / "looks", *TINY]
    both = render(*two, "--jobs", "2", "--scheduler", "local:2")
    assert both.exit_code == 2 and "exclude each other" in both.output
    assert render(*two, "--scheduler", "local:x").exit_code == 2
    assert list(tmp_path.iterdir()) == []
