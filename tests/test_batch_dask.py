"""`weavecap fit --scheduler` and `weavecap render --scheduler`: a batch on a Dask cluster of
two workers on 127.0.0.1, started here as a user would (`dask scheduler`, `dask worker`), with
workers dying mid-batch; and `--scheduler local:2` giving the same results as `--jobs 2` (fit)
or a run in this process (render: the same images bit for bit)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np
import pytest
from click.testing import CliRunner
from params_cases import bad_params_text

from weavecap.cli.main import cli
from weavecap.photo import save_png

HERE = Path(__file__).resolve().parent
PLAIN = HERE.parent / "fixtures" / "params" / "plain.json"
MESH = HERE.parent / "fixtures" / "meshes" / "drape.obj"
FIT = ["--quality", "draft", "--seed", "2"]  # no --budget: a wall-time limit stops two runs at different steps
RENDER = ["--size", "32x24", "--spp", "2", "--mode", "direct", "--pitch-mm", "2", "--seed", "2"]


def weavecap(*args):
    return CliRunner().invoke(cli, [str(a) for a in args], catch_exceptions=False)


def tiny_photos(folder: Path, names: dict[str, str]) -> list[Path]:
    """Photos by kind: ``plain`` a 96-px plain weave (3x3 repeats; a real fit in ~10 s),
    ``noise`` (rejected by preparation), ``corrupt`` (unreadable)."""
    folder.mkdir(parents=True, exist_ok=True)
    plain = folder / "plain.src.png"
    assert weavecap("synth", PLAIN, "-o", plain, "--tiles", "3x3", "--size", "96", "-q").exit_code == 0
    noise = np.random.default_rng(0).random((96, 96, 3)).astype(np.float32)
    photos = []
    for name, kind in names.items():
        path = folder / f"{name}.png"
        if kind == "plain":
            path.write_bytes(plain.read_bytes())
        elif kind == "noise":
            save_png(path, noise)
        else:
            path.write_bytes(b"not an image")
        photos.append(path)
    return photos


def params_files(folder: Path, names: dict[str, str]) -> list[Path]:
    """Params files by kind: ``plain`` the plain weave fixture, ``bad`` one with an IOR out of
    range (invalid)."""
    folder.mkdir(parents=True, exist_ok=True)
    files = []
    for name, kind in names.items():
        path = folder / f"{name}.json"
        path.write_text(PLAIN.read_text() if kind == "plain" else bad_params_text({"specular.ior": 3.5}))
        files.append(path)
    return files


@dataclass(frozen=True)
class Command:
    """A batch command as these tests drive it.

    Attributes
    ----------
    inputs : (folder, {name: kind}) → the input files, made there
    args : (inputs, out) → the command's arguments
    key : the summary line's field that names the input
    files : what an ``ok`` input leaves in its folder
    record : the one of them that says how the input ended (a failure leaves it alone)
    same : the file that two inputs of the same content have the same, byte for byte
    """

    name: str
    inputs: Callable[[Path, dict], list[Path]]
    args: Callable[[list[Path], Path], list]
    key: str
    files: tuple[str, ...]
    record: str
    same: str

    def run(self, inputs: list[Path], out: Path, *options):
        return weavecap(*self.args(inputs, out), *options)


FIT_CMD = Command("fit", tiny_photos, lambda inputs, out: ["fit", *inputs, "-o", out, *FIT], "photo",
                  ("params.json", "report.json", "compare.png", "rectified.png", "grid.png", "loss.png"), "report.json",
                  "params.json")
RENDER_CMD = Command("render", params_files, lambda inputs, out: ["render", *inputs, MESH, "-o", out, *RENDER],
                     "params", ("render.png", "render.json"), "render.json", "render.png")


def summary(out: Path) -> list[dict]:
    return [json.loads(line) for line in (out / "summary.jsonl").read_text().splitlines()]


def comparable(line: dict, out: Path) -> dict:
    """A summary line but what differs between two runs: the seconds, and ``out`` in paths."""
    return {k: None if k == "seconds" else str(Path(v).relative_to(out)) if k in ("folder", "output") else v
            for k, v in line.items()}


@pytest.fixture
def cluster(tmp_path):
    """A scheduler and two one-thread workers (each under a nanny, which restarts a worker
    that dies) on 127.0.0.1, the workers preloaded with tests/dask_worker_hooks.py."""
    deaths = tmp_path / "deaths"
    deaths.mkdir()
    file = tmp_path / "scheduler.json"
    env = {**os.environ, "WEAVECAP_TEST_DEATHS": str(deaths)}
    env.pop("WEAVECAP_DEBUG", None)
    dask = [sys.executable, "-m", "dask"]
    logs = open(tmp_path / "cluster.log", "w")
    procs = [subprocess.Popen([*dask, "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                               "--scheduler-file", str(file)], env=env, stdout=logs, stderr=logs,
                              start_new_session=True)]
    try:
        for _ in range(600):
            if file.exists() and file.stat().st_size:
                break
            time.sleep(0.1)
        address = json.loads(file.read_text())["address"]
        procs += [subprocess.Popen([*dask, "worker", address, "--nthreads", "1", "--nworkers", "1", "--no-dashboard",
                                    "--name", f"w{k}", "--preload", str(HERE / "dask_worker_hooks.py")],
                                   env=env, stdout=logs, stderr=logs, start_new_session=True) for k in (1, 2)]
        from distributed import Client

        with Client(address, timeout="60s") as client:
            client.wait_for_workers(2, timeout=120)
        yield address, deaths
    finally:  # each in its own process group (a nanny and its worker): end the groups started here
        for p in reversed(procs):
            os.killpg(p.pid, signal.SIGKILL)
            p.wait()
        logs.close()


# command, {input: kind}, the statuses they end with, those finished (skipped when run again)
DYING = [
    (FIT_CMD, {"a_plain": "plain", "die_once": "plain", "b_noise": "noise", "die_always": "noise",
               "c_corrupt": "corrupt"},
     {"a_plain": "ok", "die_once": "ok", "b_noise": "rejected", "die_always": "failed", "c_corrupt": "rejected"}),
    (RENDER_CMD, {"a_plain": "plain", "die_once": "plain", "b_bad": "bad", "die_always": "plain"},
     {"a_plain": "ok", "die_once": "ok", "b_bad": "invalid", "die_always": "failed"}),
]


@pytest.mark.parametrize("command, kinds, statuses", DYING, ids=[case[0].name for case in DYING])
def test_workers_that_die_lose_only_their_input_which_is_retried_once(cluster, tmp_path, command, kinds, statuses):
    """Inputs on two workers: die_once kills its worker, is retried and done; die_always kills
    a worker on each of its two tries and is reported failed. Every input ends with one summary
    line and its own files; running again skips what is finished and retries the failure."""
    address, deaths = cluster
    inputs = command.inputs(tmp_path / "inputs", kinds)
    out = tmp_path / "out"
    result = command.run(inputs, out, "--scheduler", address)
    assert result.exit_code == 1, result.output  # failed is the most severe outcome
    lines = {Path(line[command.key]).stem: line for line in summary(out)}
    assert len(summary(out)) == len(inputs) and set(lines) == {p.stem for p in inputs}  # each input once
    assert {k: v["status"] for k, v in lines.items()} == statuses
    assert "worker died on each of 2 tries" in lines["die_always"]["reason"]
    assert sorted(p.name.split(".")[0] for p in deaths.iterdir()) == ["die_always", "die_always", "die_once"]
    for name in ("a_plain", "die_once"):
        assert lines[name]["status"] == "ok"
        for file in command.files:
            assert (out / name / file).is_file(), (name, file)
    if command is FIT_CMD:
        assert lines["a_plain"]["weave"] == lines["die_once"]["weave"] == "plain"
    assert json.loads((out / "die_always" / command.record).read_text())["status"] == "failed"
    assert not [p for p in out.rglob(".*")]  # no temporary file left behind
    assert (out / "a_plain" / command.same).read_bytes() == (out / "die_once" / command.same).read_bytes()

    finished = [name for name, status in statuses.items() if status in ("ok", "rejected")]
    mtimes = {p: p.stat().st_mtime_ns for name in finished for p in (out / name).rglob("*")}
    again = command.run(inputs, out, "--scheduler", address)
    assert again.exit_code == 1 and again.output.count("already done") == len(finished)
    assert [Path(line[command.key]).stem for line in summary(out)].count("die_always") == 1
    assert len(summary(out)) == len(inputs)
    assert len(list(deaths.glob("die_always.*"))) == 4  # retried, once more
    assert {p: p.stat().st_mtime_ns for p in mtimes} == mtimes  # finished inputs untouched


# command, {input: kind}, the other way to run it, the exit status, the statuses in input order
LOCAL = [
    (FIT_CMD, {"a_plain": "plain", "b_noise": "noise"}, ["--jobs", "2"], 3, ["ok", "rejected"]),
    (RENDER_CMD, {"a_plain": "plain", "b_bad": "bad", "c_plain": "plain"}, [], 2, ["ok", "invalid", "ok"]),
]


@pytest.mark.parametrize("command, kinds, other, exit_code, statuses", LOCAL, ids=[case[0].name for case in LOCAL])
def test_a_local_cluster_gives_what_a_run_here_gives(tmp_path, command, kinds, other, exit_code, statuses):
    """The same inputs with --scheduler local:2 and here (fit: --jobs 2; render: in this
    process): the same summary lines (but the seconds and the folder) and the same files of
    each finished input, byte for byte (render: the same images bit for bit)."""
    inputs = command.inputs(tmp_path / "inputs", kinds)
    runs = {}
    for name, how in (("dask", ["--scheduler", "local:2"]), ("here", other)):
        result = command.run(inputs, tmp_path / name, *how)
        assert result.exit_code == exit_code, result.output
        runs[name] = sorted((comparable(line, tmp_path / name) for line in summary(tmp_path / name)),
                            key=lambda line: line[command.key])
    assert runs["dask"] == runs["here"] and [line["status"] for line in runs["dask"]] == statuses
    for line in runs["dask"]:
        if line["status"] == "ok":
            assert (tmp_path / "dask" / line["folder"] / command.same).read_bytes() == \
                (tmp_path / "here" / line["folder"] / command.same).read_bytes()


@pytest.mark.parametrize("args, message", [
    (["--scheduler", "local:0"], "local:N needs a number of workers"),
    (["--scheduler", "local:2", "--jobs", "2"], "exclude each other"),
    (["--scheduler", "tcp://127.0.0.1:9"], "cannot reach a Dask scheduler"),
])
def test_bad_scheduler_options_exit_2_and_write_nothing(tmp_path, args, message):
    import dask

    photos = tiny_photos(tmp_path / "photos", {"a": "corrupt", "b": "corrupt"})
    with dask.config.set({"distributed.comm.timeouts.connect": "2s"}):
        result = weavecap("fit", *photos, "-o", tmp_path / "out", *args)
    assert result.exit_code == 2 and message in result.output, result.output
    assert not (tmp_path / "out").exists()
