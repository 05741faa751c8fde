"""The fit bench's scoring (weavecap.bench.fit) on fabrics with known errors; no rendering."""

from __future__ import annotations

import numpy as np
import pytest

from weavecap import params
from weavecap.bench import fit as fit_bench
from weavecap.fixtures import path as fixture_path

FIXTURES = fixture_path("params")


def test_compare_scores_errors_against_what_the_photo_determines():
    truth = params.load(FIXTURES / "twill_2_1.json")
    fit = truth.replace({"specular.roughness": truth.specular.roughness + 0.1, "plies": truth.plies + 2,
                         "pattern": np.roll(truth.pattern, 1, axis=1)})
    determined = {"specular.roughness": {"standard_error": 0.04, "determined": True},
                  "specular.ior": {"standard_error": 0.3, "determined": False},
                  "warp.radius": {"standard_error": None, "determined": False}}
    row = fit_bench.compare(fit, truth, determined)
    assert row["pattern_exact"] and not row["plies_ok"] and row["fibers_ok"]
    assert row["relative_error"]["specular.roughness"] == pytest.approx(0.1)
    assert row["relative_error"]["specular.ior"] == 0.0
    assert row["determined"] == ["specular.roughness"]
    assert row["within_2se"] == pytest.approx(0.5)  # roughness 0.1 > 2 × 0.04; ior 0 ≤ 0.6
    assert fit_bench.compare(None, truth) == {"fitted": False, "pattern_exact": False}


def test_summary_and_table_pool_the_determined_errors():
    truth = params.load(FIXTURES / "plain.json")
    rows = []
    for k, (off, se) in enumerate([(0.02, 0.03), (0.3, 0.2), (0.06, 0.04)]):
        fit = truth.replace({"specular.roughness": truth.specular.roughness + off})
        det = {"specular.roughness": {"standard_error": se, "determined": se <= 0.05}}
        rows.append({"preset": "draft", "seconds": 10.0 + k, "psnr_db": 30.0 + k, **fit_bench.compare(fit, truth, det)})
    rows.append({"preset": "draft", "seconds": 5.0, "psnr_db": None, **fit_bench.compare(None, truth)})
    (summary,) = fit_bench.summary(rows)
    assert summary["fitted"] == 3 and summary["photos"] == 4 and summary["pattern_exact"] == 0.75
    assert summary["median_error_determined"] == pytest.approx(0.04)  # 0.02 and 0.06; 0.3 not determined
    assert summary["determined_per_photo"] == 1 and summary["median_psnr_db"] == 31.0
    table = fit_bench.table([summary])
    assert "| draft | 3/4 |" in table and "4.0%" in table


def test_independent_rows_are_scored_on_pattern_and_fidelity():
    truth = np.array([[1, 1, 0], [0, 1, 1], [1, 0, 1]], np.uint8)
    fit = params.load(FIXTURES / "twill_2_1.json")
    assert fit_bench.score_pattern(fit.replace({"pattern": np.roll(truth, 1, axis=0)}), truth)["pattern_exact"]
    assert not fit_bench.score_pattern(fit.replace({"pattern": 1 - truth}), truth)["pattern_exact"]  # other face
    assert not fit_bench.score_pattern(fit.replace({"pattern": truth[:, ::-1].copy()}), truth)["pattern_exact"]
    rows = [{"set": "independent", "preset": "normal", "seconds": 20.0 + k, "psnr_db": 25.0, "fitted": True,
             "pattern_exact": k < 3, "fidelity": {"sharpness": 0.8 + 0.05 * k, "structure": 0.9,
                                                  "delta_e": {"warp": 1.0 + k, "weft": None}},
             "timings_s": {"total": 20.0 + k, **({"captures": {"auto": 10.0, "lamp": 10.0 + k}} if k == 1 else {})}}
            for k in range(4)]
    (row,) = fit_bench.summary(rows)
    assert row["rigs_searched"] == 1
    assert row["pattern_exact"] == 0.75 and row["sharpness_worst"] == pytest.approx(0.8)
    assert row["delta_e_median"] == pytest.approx(2.5) and row["delta_e_worst"] == 4.0
    table = fit_bench.independent_table([row])
    assert "| normal | 4/4 |" in table and "75%" in table and table.endswith("| 1 |") and fit_bench.table([row]) == ""
    ex = fit_bench.exposure_table([{"fabric": "f", "preset": "draft", "fitted": 4, "delta_e_max": {"warp": 1.23,
                                    "weft": 2.5}, "rendered": {"warp": 0.81, "weft": 0.6},
                                    "rendered_stops": {"warp": 0.3, "weft": 0.26}, "gain": {"as shot": [1.0, 1.0, 1.0]}}])
    assert "| f | draft | rig | 4/4 | 1.2 / 2.5 | 0.8 / 0.6 | 0.3 / 0.3 |" in ex
