"""`weavecap fit --scheduler`: a batch on a Dask cluster of two workers on 127.0.0.1, started
here as a user would (`dask scheduler`, `dask worker`), with workers dying mid-batch; and
`--scheduler local:2` giving the same results as `--jobs 2`."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from weavecap.cli.main import cli
from weavecap.photo import save_png

HERE = Path(__file__).resolve().parent
PLAIN = HERE.parent / "fixtures" / "params" / "plain.json"
FIT = ["--quality", "draft", "--budget", "1", "--seed", "2"]


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


def summary(out: Path) -> list[dict]:
    return [json.loads(line) for line in (out / "summary.jsonl").read_text().splitlines()]


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


def test_workers_that_die_lose_only_their_photo_which_is_retried_once(cluster, tmp_path):
    """Five photos on two workers: die_once kills its worker, is retried and fitted; die_always
    kills a worker on each of its two tries and is reported failed. Every photo ends with one
    summary line and its own files; running again skips what is done and retries the failure."""
    address, deaths = cluster
    photos = tiny_photos(tmp_path / "photos", {"a_plain": "plain", "die_once": "plain", "b_noise": "noise",
                                               "die_always": "noise", "c_corrupt": "corrupt"})
    out = tmp_path / "out"
    result = weavecap("fit", *photos, "-o", out, "--scheduler", address, *FIT)
    assert result.exit_code == 1, result.output  # failed is the most severe outcome
    lines = {Path(line["photo"]).stem: line for line in summary(out)}
    assert len(summary(out)) == 5 and set(lines) == {p.stem for p in photos}  # each photo once
    assert {k: v["status"] for k, v in lines.items()} == {
        "a_plain": "ok", "die_once": "ok", "b_noise": "rejected", "die_always": "failed", "c_corrupt": "rejected"}
    assert "worker died on each of 2 tries" in lines["die_always"]["reason"]
    assert sorted(p.name.split(".")[0] for p in deaths.iterdir()) == ["die_always", "die_always", "die_once"]
    for name in ("a_plain", "die_once"):
        assert lines[name]["weave"] == "plain"
        for file in ("params.json", "report.json", "compare.png", "rectified.png", "grid.png", "loss.png"):
            assert (out / name / file).is_file(), (name, file)
    assert json.loads((out / "die_always" / "report.json").read_text())["status"] == "failed"
    assert not [p for p in out.rglob(".*")]  # no temporary file left behind
    assert (out / "a_plain" / "params.json").read_text() == (out / "die_once" / "params.json").read_text()

    mtimes = {p: p.stat().st_mtime_ns for p in out.rglob("*") if p.is_file() and "die_always" not in str(p)
              and p.name != "summary.jsonl"}
    again = weavecap("fit", *photos, "-o", out, "--scheduler", address, *FIT)
    assert again.exit_code == 1 and again.output.count("already done") == 4
    assert [line["photo"] for line in summary(out)].count(str(photos[3])) == 1 and len(summary(out)) == 5
    assert len(list(deaths.glob("die_always.*"))) == 4  # retried, once more
    assert {p: p.stat().st_mtime_ns for p in mtimes} == mtimes  # finished photos untouched


def test_a_local_cluster_gives_what_jobs_gives(tmp_path):
    """The same photos with --scheduler local:2 and --jobs 2: the same summary lines (but the
    seconds) and the same params.json."""
    photos = tiny_photos(tmp_path / "photos", {"a_plain": "plain", "b_noise": "noise"})
    runs = {}
    for name, how in (("dask", ["--scheduler", "local:2"]), ("jobs", ["--jobs", "2"])):
        result = weavecap("fit", *photos, "-o", tmp_path / name, *how, *FIT)
        assert result.exit_code == 3, result.output
        runs[name] = sorted((dict(line, seconds=None, folder=Path(line["folder"]).name) for line in
                             summary(tmp_path / name)), key=lambda line: line["photo"])
    assert runs["dask"] == runs["jobs"] and [line["status"] for line in runs["dask"]] == ["ok", "rejected"]
    assert (tmp_path / "dask" / "a_plain" / "params.json").read_text() == \
        (tmp_path / "jobs" / "a_plain" / "params.json").read_text()


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
