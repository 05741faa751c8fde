"""The real-photo bench's scoring on known cases (weavecap.bench.real), and the bench on the
real photos of ``../shared/realdata`` where they are (skipped without them)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from weavecap.bench import real

TWILL_22_Z = np.array([[1, 1, 0, 0], [0, 1, 1, 0], [0, 0, 1, 1], [1, 0, 0, 1]], np.uint8)
PLAIN = np.array([[1, 0], [0, 1]], np.uint8)
SATIN_5_2 = np.ones((5, 5), np.uint8)
for _i in range(5):
    SATIN_5_2[_i, (2 * _i) % 5] = 0


@pytest.mark.parametrize("name, family", [
    ("plain", "plain"), ("basket 2/2", "plain"), ("rib 3 (wefts doubled)", "plain"), ("hopsack 2/2", "plain"),
    ("twill 2/1 Z", "twill"), ("twill 1/3 S", "twill"), ("herringbone 2/2, leg 6", "twill"),
    ("broken twill 2/2", "twill"), ("satin 5/2 weft-faced", "satin"), ("satin 8/3 extended 2/6", "satin"),
    ("custom 4×6", "other"), (None, None)])
def test_weave_family_of_weave_names(name, family):
    assert real.weave_family(name) == family


@pytest.mark.parametrize("label, family", [
    ("plain (open, slubby, hessian-like) (visual)", "plain"), ("plain? rotated ~20 deg, fine (visual)", "plain"),
    ("plain, open weave; grey warp/weft mixed with brown yarns (visual)", "plain"),
    ("twill (clear diagonal, ~2/2 or 3/1) (visual)", "twill"),
    ("herringbone weave (broken twill) - Brodatz plate D16 title", "twill"),
    ('"1/15 twill variation" per blog text', "twill"), ("satin", "satin"),
    ("unknown (looks like twill by eye)", None), ("knitted (weft knit)", None), ("non-woven felt", None),
    ("woven cloth but yarns unresolvable -> tool should refuse", None),
    ("woven woollen cloth, weave not stated (Brodatz D19 title)", None), ("", None)])
def test_label_family_reads_the_label_sheets(label, family):
    assert real.label_family(label) == family


def test_density_ratio_is_denser_over_sparser_whichever_is_the_warp():
    # 30 warps and 15 wefts per cm: the wefts are twice as far apart as the warps
    assert real.density_ratio_error((10.0, 20.0), (30, 15)) == pytest.approx(0.0)
    assert real.density_ratio_error((20.0, 10.0), (30, 15)) == pytest.approx(0.0)  # the photo turned
    assert real.density_ratio_error((10.0, 23.0), (30, 15)) == pytest.approx(0.15)
    assert real.density_ratio_error((10.0, 10.0), (26, 25)) == pytest.approx(25 / 26 - 1)
    assert real.density_ratio(3.0, 6.0) == real.density_ratio(6.0, 3.0) == 2.0


def test_same_weave_up_to_a_shift_and_a_quarter_turn():
    assert real.same_weave(TWILL_22_Z, np.roll(TWILL_22_Z, (1, 2), axis=(0, 1)))
    assert real.same_weave(PLAIN, 1 - PLAIN)
    # the photo turned by 90°: warps become wefts, every cell flips
    assert real.same_weave(SATIN_5_2, 1 - np.rot90(SATIN_5_2))
    assert real.same_weave(TWILL_22_Z, np.rot90(TWILL_22_Z, 2))
    assert not real.same_weave(PLAIN, TWILL_22_Z)
    assert not real.same_weave(SATIN_5_2, np.fliplr(SATIN_5_2))  # satin 5/3 seen from the same side


def test_views_agree_only_when_every_view_gave_the_same_weave():
    assert real.views_agree([TWILL_22_Z, np.roll(TWILL_22_Z, 1, axis=0), 1 - np.rot90(TWILL_22_Z)])
    assert not real.views_agree([TWILL_22_Z, PLAIN])
    assert not real.views_agree([PLAIN, None])  # a rejected view gave no weave
    assert not real.views_agree([])


def _row(set_, photo, split, expect, status, weave=None, pattern=None, family=None, fabric=None, pitch=None,
         density=None, sha=None, reason=None, photo_scale=None, neutral=None, noise=None, decided=None):
    r = real.RealPhoto(path=Path(photo), set=set_, family=family, density=density, fabric=fabric, split=split,
                       expect=expect, sha256=sha or photo)
    raw = {"status": status, "code": None if status == "ok" else "no_grid", "reason": reason, "weave": weave,
           "decided": decided,
           "pattern": None if pattern is None else np.asarray(pattern).tolist(), "pitch_px": pitch, "yarns": None,
           "photo_scale": photo_scale, "neutral_delta_e": neutral, "noise": noise, "seconds": 10.0}
    return real.score(r, raw)


def test_summary_counts_the_done_when_figures_per_split():
    rows = [
        _row("fabricnet", "a.jpg", "dev", "fit", "ok", "plain", PLAIN, "plain", "fabricnet:1", (10.0, 20.0), (30, 15),
             photo_scale={"colour_p90": 8.0, "sharpness": 0.9, "structure": 0.7, "structure_ceiling": 0.8}, neutral={"warp": 2.0, "weft": 9.9},
             noise={"brightness": 1.01, "weave": 0.8}, decided=True),
        _row("fabricnet", "b.jpg", "dev", "fit", "ok", "twill 2/2 Z", TWILL_22_Z, "plain", "fabricnet:1",
             (10.0, 10.0), (30, 15), photo_scale={"colour_p90": 14.0, "sharpness": 0.45, "structure": 0.5},
             neutral={"warp": 3.0, "weft": None}, noise={"brightness": 1.5, "weave": 0.3}, decided=False),
        _row("fabricnet", "c.jpg", "held-out", "fit", "rejected", family="satin", fabric="fabricnet:2",
             density=(25, 50), reason="no grid"),
        _row("negative", "d.jpg", "dev", "reject", "rejected", reason="no regular yarn grid"),
        _row("easy", "a-copy.jpg", "dev", "fit", "ok", "plain", PLAIN, "plain", sha="a.jpg"),
    ]
    dev, held, every = real.summary(rows, "dev"), real.summary(rows, "held-out"), real.summary(rows)
    assert dev["fitted"] == (3, 3) and dev["rejected"] == (1, 1)
    assert dev["family"] == (2, 3)  # the twill labelled plain is wrong
    assert dev["family_decided"] == (1, 1) and dev["family_undecided"] == (0, 1)  # the copy made no decision
    assert dev["density"] == (1, 2)  # ratio 2 against 2 (right), 1 against 2 (50 % off)
    assert dev["views"] == (0, 1)  # fabric 1: plain and twill
    assert dev["pixel_p90"] == (1, 2) and dev["pixel_sharpness"] == (1, 2) and dev["pixel_structure"] == (1, 2)
    assert dev["structure_reachable"] == (1, 1)  # b's view held no repeat twice: its ceiling is not counted
    assert dev["not_washed"] == (1, 2)  # the twill's render at sharpness 0.45 is washed out
    assert dev["neutral_colour"] == (2, 2)  # a family the pattern never shows does not count
    rows[1]["neutral_delta_e"]["warp"] = 10.5
    assert real.summary(rows, "dev")["neutral_colour"] == (1, 2)
    assert dev["noise_brightness"] == (1, 2) and dev["noise_weave"] == pytest.approx(0.55)  # the blotches brighten
    assert held["fitted"] == (0, 1) and held["density"] == (0, 1) and held["views"] == (0, 1)
    assert every["photos"] == 4  # the copy of a.jpg counts once
    table = real.summary_table(rows)
    assert "| DEV |" in table and "| HELD-OUT |" in table and "| all |" in table
    assert "| 1/1 (100%) / 0/1 (0%) |" in table


REALDATA = real.find_realdata()


@pytest.mark.skipif(REALDATA is None, reason="../shared/realdata is absent")
def test_the_bench_knows_every_photo_and_its_split():
    photos = real.photos(REALDATA)
    by_set = {s: [p for p in photos if p.set == s] for s, _ in real.FOLDERS}
    assert len(by_set["fabricnet"]) == 64 and len(by_set["kth_tips2a"]) == 78 and len(by_set["plaids"]) == 2
    assert len(by_set["negative"]) == 5 and all(p.expect == "reject" for p in by_set["negative"])
    held = {p.fabric for p in by_set["fabricnet"] if p.split == "held-out"}
    assert held == {f"fabricnet:{k}" for k in (2, 11, 15, 16, 17, 28)}
    assert {p.fabric for p in by_set["kth_tips2a"] if p.split == "held-out"} == {
        "kth_tips2a:44c", "kth_tips2a:46b", "kth_tips2a:46c"}
    w077 = next(p for p in by_set["easy"] if p.name == "fabricnet_W077_plain.jpg")
    assert w077.density == (24.0, 48.0) and w077.family == "plain"  # a copy of fabricnet_0077.jpg
