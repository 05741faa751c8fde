"""The fold bench's figures and picture from known images (the bench itself runs in `weavecap bench --render`)."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from weavecap.bench import fold as bench


def test_mask_and_rmse_see_only_the_garment():
    sky = np.full((6, 8, 3), 0.3)
    a = sky.copy()
    a[2:4, 2:6] = 0.1  # the garment: 8 pixels
    b = a.copy()
    b[2:4, 2:6] += 0.02
    mask = bench.garment_mask(a)
    assert mask.sum() == 8
    assert bench.rmse(a, b, mask) == pytest.approx(0.02)


def row(mesh, seen, direct, fold, noise=0.0001):
    return {"mesh": mesh, "seen": seen, "radius_m": 0.03, "local_rms": direct, "reference_noise": noise,
            "rmse_localpt": {"direct": direct, "direct_fold": fold, "direct_fold_k4": fold * 1.2},
            "rmse_pt": {"direct": direct * 1.5, "direct_fold": fold * 1.5},
            "equal_time": {"spp_fold": 64, "spp_localpt": 200, "rmse_fold": 0.008, "rmse_localpt": 0.005,
                           "seconds_fold": 1.5, "seconds_localpt": 1.25},
            "seconds": {"fold": 1.0, "fold_k4": 0.5}, "fold_detail": {"weights_parameters": 1500, "neighbours": 64},
            "local_equal_time": {"seconds_fold": 1.0, "spp_localpt": 300, "rmse_fold": fold, "rmse_localpt": fold * 1.1}}


def test_summary_gives_the_done_when_figures():
    frame = {"mesh": "towel", "frame_seconds": 10.0, "fold_seconds": 1.0, "ratio": 0.1, "warm_ratio": 0.08,
             "equal_time": {"spp_fold": 64, "spp_localpt": 30, "rmse_fold": 0.004, "rmse_localpt": 0.006,
                            "seconds_fold": 6.0, "seconds_localpt": 5.5},
             "local_equal_time": {"seconds_fold": 1.0, "spp_localpt": 20, "rmse_fold": 0.0005, "rmse_localpt": 0.0004,
                                  "rmse_direct": 0.001}}
    result = {"meshes": [row("a", True, 0.002, 0.001), row("b", True, 0.001, 0.0008), row("c", False, 0.002, 0.0012)],
              "frames": [frame]}
    s = bench.summary(result)
    assert s["gain_over_direct"] == pytest.approx({"a": 2.0, "b": 1.25, "c": 2.0 / 1.2})
    assert s["seen_rmse"] == pytest.approx(0.0009) and s["unseen_rmse"] == pytest.approx(0.0012)
    assert all(s["closer_to_pt"].values()) and not any(s["beats_localpt_equal_time"].values())
    assert s["beats_localpt_equal_time_1280x720"] == {"towel": True}
    assert s["beats_localpt_local_light_equal_time"] == {"a": True, "b": True, "c": True, "towel 1280x720": False}
    text = bench.table(result)
    assert "| a | yes | 30 | 0.00200 | 0.00010 | 0.00200 | 0.00100 | 2.00× |" in text
    assert "Unseen / seen RMSE: 1.33 (absolute)" in text and "| towel | 10.0 | 1.00 | 10 % | 0.00100 |" in text
    assert "| Sampling | 64 view samples | Seen |" in text  # the count the run used
    assert "| 0.00800 (64, 1.50 s) | 0.00500 (200, 1.25 s) |" in text  # both sides' spp and seconds
    assert "| 0.00400 (64, 6.00 s) | 0.00600 (30, 5.50 s) |" in text
    assert s["frame_ratio_warm"] == {"towel": 0.08}


class Clock:
    """A clock that moves only when a timed part runs: each call of a part takes its next duration."""

    def __init__(self):
        self.now = 0.0

    def __call__(self):
        return self.now

    def part(self, durations):
        it = iter(durations)

        def fn():
            self.now += next(it)
            return self.now
        return fn


def test_steady_times_waits_for_two_agreeing_timings_on_every_part():
    clock = Clock()
    # first call (untimed, compiles) is slow; then ours settles at the 3rd timing, theirs at the 2nd
    parts = {"ours": clock.part([5.0, 2.0, 1.5, 1.0, 1.05, 9.0]), "theirs": clock.part([4.0, 1.0, 1.08, 1.2, 1.25, 9.0])}
    seconds, timings, out = bench.steady_times(parts, clock=clock)
    assert timings["ours"] == pytest.approx([2.0, 1.5, 1.0, 1.05])  # 1.0 | 1.05 agree; theirs kept in the same rounds
    assert timings["theirs"] == pytest.approx([1.0, 1.08, 1.2, 1.25])
    assert seconds == pytest.approx({"ours": 1.025, "theirs": 1.225})
    assert out["ours"] == pytest.approx(clock.now - 1.25)  # the last call's result


def test_steady_times_falls_back_to_the_median():
    clock = Clock()
    parts = {"a": clock.part([1.0, 1.0, 2.0, 1.0, 2.0, 1.0, 2.0])}
    seconds, timings, _ = bench.steady_times(parts, clock=clock, rounds=5)
    assert len(timings["a"]) == 5 and seconds["a"] == pytest.approx(1.0)  # median of 1, 2, 1, 2, 1


def test_picture_is_one_labelled_row_per_mesh(tmp_path):
    rng = np.random.default_rng(0)
    for name in ("m1", "m2"):
        direct = rng.uniform(0.1, 0.5, (10, 16, 3)).astype(np.float32)
        np.savez(tmp_path / f"{name}.npz", direct=direct, fold=direct + 0.01, localpt=direct + 0.012, pt=direct + 0.02,
                 mask=np.ones((10, 16), bool))
    out = bench.picture(tmp_path, ["m1", "m2"], tmp_path / "row.png")
    image = Image.open(out)
    assert image.size == (6 * 16 + 7 * 4, 2 * (10 + 14 + 4) + 4)
