"""Promise: a Dask cluster is used only as the user can trust it. Jobs and results travel as
pickles — scheduler, workers and this machine can run code on each other — so the docs and
the help say the cluster must be trusted; ``tls://`` with Dask's TLS settings works (and
without them is refused, naming them); other protocols are refused clearly."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import dask
import distributed  # noqa: F401 - its defaults enter dask's configuration before the tests change it
import pytest

from .conftest import ROOT, files_under, noise_photo, weavecap


@pytest.mark.parametrize("address, words", [
    ("ucx://127.0.0.1:8786", "tcp:// or tls:// only, not ucx://"),
    ("ws://127.0.0.1:8786", "tcp:// or tls:// only, not ws://"),
    ("tls://127.0.0.1:8786", "lacks distributed.comm.tls.ca-file, distributed.comm.tls.client.cert"),
])
def test_a_scheduler_weavecap_cannot_use_is_refused_before_any_work(sandbox, address, words):
    """tls:// and ucx:// crashed with a TypeError (exit 1)."""
    photos = [noise_photo(sandbox / "in" / f"{k}.png", k) for k in range(2)]
    with dask.config.set({"distributed.comm.tls.ca-file": None, "distributed.comm.tls.client.cert": None,
                          "distributed.comm.tls.client.key": None}):
        result = weavecap("fit", *photos, "-o", sandbox / "out", "--scheduler", address)
    assert result.exit_code == 2, result.output
    assert words in result.output and "Traceback" not in result.output
    assert not (sandbox / "out").exists()


def test_tls_settings_naming_missing_files_are_refused(sandbox):
    photos = [noise_photo(sandbox / "in" / f"{k}.png", k) for k in range(2)]
    missing = str(sandbox / "nope.pem")
    with dask.config.set({"distributed.comm.tls.ca-file": missing, "distributed.comm.tls.client.cert": missing,
                          "distributed.comm.tls.client.key": missing}):
        result = weavecap("fit", *photos, "-o", sandbox / "out", "--scheduler", "tls://127.0.0.1:8786")
    assert result.exit_code == 2 and f"these files do not exist: {missing}" in result.output


@pytest.fixture
def certificates(tmp_path) -> dict[str, Path]:
    """A certificate authority and one certificate it signed, for scheduler, worker and client."""
    if shutil.which("openssl") is None:
        pytest.skip("openssl is not installed")
    d = tmp_path / "tls"
    d.mkdir()

    def openssl(*args):
        subprocess.run(["openssl", *args], cwd=d, check=True, capture_output=True)

    openssl("req", "-x509", "-newkey", "rsa:2048", "-nodes", "-keyout", "ca.key", "-out", "ca.pem", "-days", "2",
            "-subj", "/CN=weavecap test CA")
    openssl("req", "-newkey", "rsa:2048", "-nodes", "-keyout", "node.key", "-out", "node.csr", "-subj", "/CN=127.0.0.1")
    openssl("x509", "-req", "-in", "node.csr", "-CA", "ca.pem", "-CAkey", "ca.key", "-CAcreateserial", "-out",
            "node.pem", "-days", "2")
    return {"ca": d / "ca.pem", "cert": d / "node.pem", "key": d / "node.key"}


def test_a_batch_runs_on_a_tls_cluster_with_dasks_tls_settings(sandbox, certificates):
    from distributed import LocalCluster
    from distributed.security import Security

    ca, cert, key = (str(certificates[k]) for k in ("ca", "cert", "key"))
    security = Security(tls_ca_file=ca, tls_scheduler_cert=cert, tls_scheduler_key=key, tls_worker_cert=cert,
                        tls_worker_key=key, tls_client_cert=cert, tls_client_key=key, require_encryption=True)
    photos = [noise_photo(sandbox / "in" / f"{k}.png", k) for k in range(2)]
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tls", host="127.0.0.1",
                      security=security, dashboard_address=None) as cluster:
        assert cluster.scheduler_address.startswith("tls://")
        with dask.config.set({"distributed.comm.tls.ca-file": ca, "distributed.comm.tls.client.cert": cert,
                              "distributed.comm.tls.client.key": key}):
            result = weavecap("fit", *photos, "-o", sandbox / "out", "--scheduler", cluster.scheduler_address, "-q")
    assert result.exit_code == 3, result.output  # both photos rejected (noise): the batch ran
    lines = [json.loads(line) for line in (sandbox / "out" / "summary.jsonl").read_text().splitlines()]
    assert [line["status"] for line in lines] == ["rejected", "rejected"]


def test_the_help_and_the_docs_say_the_cluster_must_be_trusted():
    help_text = weavecap("fit", "--help").output
    assert "pickles" in help_text and "trust" in help_text
    doc = (ROOT / "docs" / "reliability.md").read_text()
    assert "pickle" in doc and "trusted" in doc and "tls://" in doc
