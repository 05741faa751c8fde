"""Shared fixtures and the real-data count.

- ``shared``: the path of a file under ``../shared`` (the real photos, meshes, WIF drafts and
  contracts beside the clone), or a skip when it is absent — a failure under
  ``WEAVECAP_REQUIRE_SHARED=1`` (:mod:`shared_data`). The tests that ask for it are the
  real-data tests; the summary says how many of them ran and how many skipped.
- ``bad_params``: one bad params file per case of :data:`params_cases.BAD_PARAMS`, so that
  every bad file a user might hand to weavecap is checked by the library tests
  (``test_params.py``) and the command tests (``cli/test_cli_errors.py``) with one list.
"""

from __future__ import annotations

import pytest

import shared_data
from params_cases import BAD_PARAMS, BadParams, bad_params_text

#: nodeid → "ran", "skipped" or "missing" (failed for want of ../shared), per real-data test
_REAL_DATA: dict[str, str] = {}


@pytest.fixture(params=BAD_PARAMS, ids=[case[0] for case in BAD_PARAMS])
def bad_params(request, tmp_path) -> BadParams:
    """One bad params file written under tmp_path (each test runs once per case)."""
    name, edit, field, words = request.param
    path = tmp_path / f"{name}.json"
    path.write_text(bad_params_text(edit))
    return BadParams(path=path, field=field, words=words)


@pytest.fixture
def shared():
    """``shared(*parts)``: the path under ../shared, or a skip when it is absent (a failure
    under ``WEAVECAP_REQUIRE_SHARED=1``). A test that asks for it is a real-data test."""
    return shared_data.need


def pytest_configure(config):
    config.addinivalue_line("markers", "shared_data: reads ../shared (the shared fixture); counted in the summary")


def pytest_collection_modifyitems(items):
    for item in items:
        if "shared" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.shared_data)


def pytest_runtest_logreport(report):
    """Each real-data test's outcome: ran (passed or failed), skipped, or missing."""
    if "shared_data" in report.keywords and (report.when == "call" or report.outcome != "passed"):
        missing = report.failed and shared_data.MISSING in report.longreprtext
        _REAL_DATA[report.nodeid] = "skipped" if report.skipped else "missing" if missing else "ran"


def pytest_terminal_summary(terminalreporter):
    """One line before pytest's own: how many real-data tests ran, skipped, or failed for want
    of ../shared (under ``WEAVECAP_REQUIRE_SHARED=1``)."""
    if not _REAL_DATA:
        return
    counts = {k: sum(v == k for v in _REAL_DATA.values()) for k in ("ran", "skipped", "missing")}
    line = f"real-data tests ({shared_data.root()}): {counts['ran']} ran, {counts['skipped']} skipped"
    if counts["missing"]:
        line += f", {counts['missing']} failed for want of it"
    elif counts["skipped"] and not shared_data.required():
        line += f"; {shared_data.REQUIRE}=1 makes a missing file fail"
    terminalreporter.write_sep("-", line, yellow=counts["ran"] < len(_REAL_DATA), green=counts["ran"] == len(_REAL_DATA))
