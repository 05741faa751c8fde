"""Promise: every record a command writes (report.json, summary.jsonl, the render and prepare
records, `--json`) is strict JSON (RFC 8259) that jq or a browser reads:
a figure that could not be measured — the structure correlation of a render with no contrast,
a sharpness against a flat photo — is ``null``, never Python's ``NaN`` or ``Infinity``."""

from __future__ import annotations

import json
import math

import numpy as np

from weavecap.io import dumps_json
from weavecap.pipeline import Capture, write_capture


def strict_loads(text: str):
    """``json.loads`` that refuses the non-standard constants ``NaN``, ``Infinity``, ``-Infinity``."""
    def refuse(name):
        raise ValueError(f"non-standard JSON constant {name}")
    return json.loads(text, parse_constant=refuse)


def test_non_finite_figures_are_null_and_numpy_values_plain():
    doc = {"structure": float("nan"), "ratio": [math.inf, -math.inf, 1.5], "gain": np.float32(0.25),
           "cells": np.arange(3), "pair": (np.int64(2), "x"), "nested": {"p90": np.float64("nan")}}
    back = strict_loads(dumps_json(doc, indent=1))
    assert back == {"structure": None, "ratio": [None, None, 1.5], "gain": 0.25, "cells": [0, 1, 2],
                    "pair": [2, "x"], "nested": {"p90": None}}


def test_a_report_with_an_unmeasured_figure_is_written_as_strict_json(tmp_path):
    report = {"status": "ok", "fit": {"fidelity": {"sharpness": 0.0, "structure": float("nan")}},
              "moves": {"family_colours": {"structure": float("nan")}}}
    write_capture(Capture(report=report), tmp_path / "out")
    back = strict_loads((tmp_path / "out" / "report.json").read_text())
    assert back["fit"]["fidelity"] == {"sharpness": 0.0, "structure": None}
    assert back["moves"]["family_colours"]["structure"] is None
