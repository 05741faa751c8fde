"""report.json (weavecap.report): the project's schema is the shared contract, and a photo that
stops early still gets a report that follows it."""

from __future__ import annotations

import json
from pathlib import Path

import jsonschema
import numpy as np

from weavecap import report
from weavecap.stages import CaptureOptions, Rejection

SCHEMA = Path(report.__file__).parent / "schemas" / "report.schema.json"


def test_project_report_schema_is_the_contract(shared):
    contract = shared("contracts", "report.schema.json")
    assert json.loads(SCHEMA.read_text()) == json.loads(contract.read_text())


def test_early_reports_follow_the_schema():
    """A photo rejected at load (its hash known), one rejected by preparation's checks, and one a
    batch could not capture: each report follows the schema and keeps the user's options."""
    schema = json.loads(SCHEMA.read_text())
    options = CaptureOptions(quality="draft", light="best", seed=3)
    unreadable = report.rejected("a.jpg", options, Rejection("not an image", "unreadable",
                                                             input={"sha256": "ab" * 32, "width": 0, "height": 0}),
                                 {"load": 0.01, "total": 0.0123456})
    not_woven = report.rejected("b.jpg", options, Rejection("no repeat", "no_period", checks={"period": False}),
                                {"load": 0.2, "prepare": 1.5, "total": 1.7})
    crashed = report.failed("c.jpg", options, status="failed", reason="out of memory", seconds=60.0004, sha256="cd" * 32)
    for doc in (unreadable, not_woven, crashed):
        jsonschema.validate(doc, schema)
        assert doc["options"] == {"quality": "draft", "light": "best", "seed": 3, "budget_s": None, "network": True,
                                  "exposure": "rig"}
    assert unreadable["status"] == "rejected" and unreadable["input"]["sha256"] == "ab" * 32
    assert unreadable["timings_s"] == {"load": 0.01, "total": 0.012}
    assert not_woven["checks"] == {"period": False} and not_woven["code"] == "no_period"
    assert crashed["status"] == "failed" and crashed["timings_s"] == {"total": 60.0}


def test_psnr_of_a_known_error():
    """A uniform error of 0.1 on a [0, 1] image: 20 dB; values beyond [0, 1] are clipped first."""
    a = np.full((4, 4, 3), 0.5)
    assert abs(report.psnr(a, a + 0.1) - 20.0) < 1e-9
    assert abs(report.psnr(np.full((4, 4, 3), 1.5), np.full((4, 4, 3), 0.9)) - 20.0) < 1e-9
