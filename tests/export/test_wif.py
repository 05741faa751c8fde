"""WIF drafts in and out: drawdowns with a known structure, round trips, refused drafts."""

from __future__ import annotations

import dataclasses
import io
from pathlib import Path

import numpy as np
import pytest
from dtx_to_wif import read_wif as library_read_wif
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from weavecap import params, wif
from weavecap.errors import InputError
from weavecap.estimate.weave_name import minimal_repeat, weave_name
from weavecap.photo import linear_to_srgb

ROOT = Path(__file__).resolve().parents[2]
FIXTURES = sorted((ROOT / "fixtures" / "params").glob("*.json"))


def draft_text(*, threading, liftplan=None, tieup=None, treadling=None, rising=True, ends=None, picks=None,
               extra="") -> str:
    """A WIF 1.1 file with the given sections (dicts of line number → numbers, or raw text)."""

    def section(name, lines):
        if lines is None:
            return ""
        body = lines if isinstance(lines, str) else "".join(
            f"{k}={','.join(map(str, v)) if isinstance(v, (list, tuple)) else v}\n" for k, v in lines.items())
        return f"\n[{name}]\n{body}"

    ends = ends or (len(threading) if isinstance(threading, dict) else 1)
    picks = picks or len(liftplan if liftplan is not None else (treadling or {}))
    return ("[WIF]\nVersion=1.1\nDate=April 20, 1997\nDevelopers=wif@mhsoft.com\nSource Program=test\n"
            + section("THREADING", threading) + section("LIFTPLAN", liftplan) + section("TIEUP", tieup)
            + section("TREADLING", treadling)
            + f"\n[WEAVING]\nRising Shed={'true' if rising else 'false'}\n"
            + f"\n[WARP]\nThreads={ends}\nColor=1\n\n[WEFT]\nThreads={picks}\nColor=2\n"
            + "\n[COLOR TABLE]\n1=255,255,255\n2=0,0,128\n\n[COLOR PALETTE]\nRange=0,255\nEntries=2\n" + extra)


def read_text(tmp_path: Path, text: str, name: str = "draft.wif") -> wif.Draft:
    path = tmp_path / name
    path.write_text(text)
    return wif.read_wif(path)


def refused(tmp_path: Path, text: str) -> str:
    with pytest.raises(InputError) as err:
        read_text(tmp_path, text)
    assert err.value.exit_code == 2
    return str(err.value)


# ---------------------------------------------------------------------------------------------
# drafts with a known structure: which of warp and weft is up


def straight(n):
    return {k: k for k in range(1, n + 1)}


def test_plain_weave_from_two_shafts(tmp_path):
    draft = read_text(tmp_path, draft_text(threading={1: 1, 2: 2, 3: 1, 4: 2}, tieup={1: 1, 2: 2},
                                           treadling={1: 1, 2: 2, 3: 1, 4: 2}))
    assert draft.lifting == "[TIEUP] × [TREADLING]"
    assert draft.drawdown.shape == (4, 4)
    assert weave_name(draft.pattern) == "plain" and draft.pattern.shape == (2, 2)
    # pick 1 raises shaft 1, which holds end 1: warp over weft there, so weft under (0)
    assert draft.pattern[0, 0] == 0 and draft.pattern[0, 1] == 1


def test_one_shaft_raised_of_three_is_a_weft_faced_twill(tmp_path):
    """Rising shed: the raised end lies over the weft, so raising one shaft of three leaves the
    weft over two warps of three — a weft-faced 2/1 twill (weavecap's 1 = weft over warp)."""
    draft = read_text(tmp_path, draft_text(threading=straight(3), tieup=straight(3), treadling=straight(3)))
    np.testing.assert_array_equal(draft.pattern, 1 - np.eye(3, dtype=np.uint8))
    assert draft.pattern.mean() == pytest.approx(2 / 3)
    assert weave_name(draft.pattern) == "twill 2/1 S"


def test_a_sinking_shed_turns_the_same_draft_over(tmp_path):
    rising = read_text(tmp_path, draft_text(threading=straight(3), liftplan=straight(3)), "r.wif")
    sinking = read_text(tmp_path, draft_text(threading=straight(3), liftplan=straight(3), rising=False), "s.wif")
    np.testing.assert_array_equal(sinking.drawdown, 1 - rising.drawdown)
    assert weave_name(sinking.pattern) == "twill 1/2 S"


def test_a_straight_four_shaft_twill_tie_up(tmp_path):
    draft = read_text(tmp_path, draft_text(threading=straight(4), tieup={1: (1, 2), 2: (2, 3), 3: (3, 4), 4: (4, 1)},
                                           treadling=straight(4)))
    assert weave_name(draft.pattern) == "twill 2/2 S"


def test_liftplan_and_treadling_agreeing_is_one_drawdown_disagreeing_is_refused(tmp_path):
    agree = draft_text(threading=straight(3), tieup=straight(3), treadling=straight(3), liftplan=straight(3))
    assert weave_name(read_text(tmp_path, agree).pattern) == "twill 2/1 S"
    disagree = draft_text(threading=straight(3), tieup=straight(3), treadling=straight(3),
                          liftplan={1: 1, 2: 3, 3: 2})
    message = refused(tmp_path, disagree)
    assert "[LIFTPLAN]" in message and "[TREADLING]" in message and "pick 2" in message


def test_a_large_draft_cut_mid_repeat_reads_to_its_period(tmp_path):
    """100 ends and 70 picks of a straight 2/2 twill: 70 picks is not a whole number of
    4-pick repeats, and over 64, so the period drafted (4) is the repeat."""
    twill = {1: (1, 2), 2: (2, 3), 3: (3, 4), 4: (4, 1)}
    text = draft_text(threading={e: (e - 1) % 4 + 1 for e in range(1, 101)}, tieup=twill,
                      treadling={p: (p - 1) % 4 + 1 for p in range(1, 71)})
    draft = read_text(tmp_path, text)
    assert draft.drawdown.shape == (70, 100)
    assert draft.pattern.shape == (4, 4) and weave_name(draft.pattern) == "twill 2/2 S"


def test_unthreaded_ends_and_idle_picks_are_part_of_the_drawdown(tmp_path):
    # end 3 on no shaft is never raised (weft over it on every pick); pick 3 raises nothing
    draft = read_text(tmp_path, draft_text(threading={1: 1, 2: 2}, liftplan={1: 1, 2: 2}, ends=3, picks=3))
    np.testing.assert_array_equal(draft.drawdown, [[0, 1, 1], [1, 0, 1], [1, 1, 1]])


# ---------------------------------------------------------------------------------------------
# the shared drafts (r-owen/dtx_to_wif_converter test data, MIT)


def test_liftplan_with_defaults_reads_to_its_drawdown(shared):
    """From the file: 4 ends, end 1 on shaft 3, end 2 on shaft 2, ends 3-4 unthreaded; 6 picks,
    pick 1 raises shafts 1, 2, 4 (end 2 up), pick 4 raises 3, 4 (end 1 up), the others nothing."""
    draft = wif.read_wif(shared("wif", "good", "liftplan_with_defaults.wif"))
    expected = np.ones((6, 4), dtype=np.uint8)
    expected[0, 1] = expected[3, 0] = 0
    np.testing.assert_array_equal(draft.drawdown, expected)
    np.testing.assert_array_equal(draft.pattern, expected)  # no smaller repeat tiles it
    assert draft.lifting == "[LIFTPLAN]" and draft.title == "liftplan with defaults.dtx"


def test_treadles_with_defaults_reads_to_its_drawdown(shared):
    """From the file: 5 ends, end 3 on shaft 4, end 5 on shaft 1; treadle 1 raises shaft 1,
    treadle 2 shafts 2 and 4, treadles 3-6 nothing; pick 1 treads 1 and 6 (end 5 up), pick 3
    treads 2 and 5 (end 3 up), picks 2, 4-6 raise nothing."""
    draft = wif.read_wif(shared("wif", "good", "treadles_with_defaults.wif"))
    expected = np.ones((6, 5), dtype=np.uint8)
    expected[0, 4] = expected[2, 2] = 0
    np.testing.assert_array_equal(draft.drawdown, expected)
    assert draft.lifting == "[TIEUP] × [TREADLING]"


@pytest.mark.parametrize("name, section, words", [
    ("missing_tieup.wif", "[TIEUP]", ("[TREADLING]", "add a [TIEUP]")),
    ("too_many_treadles_in_treadline.wif", "[TREADLING]", ("treadle 7", "1=1,6,7", "6 treadles")),
    ("warp_color_too_big.wif", "[WEFT COLORS]", ("6=11", "1 to 10")),
])
def test_the_shared_bad_drafts_are_refused_naming_the_section(name, section, words, shared):
    path = shared("wif", "bad", name)
    with pytest.raises(InputError) as err:
        wif.read_wif(path)
    message = str(err.value)
    assert message.startswith(f"{path}: {section}:"), message
    for word in words:
        assert word in message, message


# ---------------------------------------------------------------------------------------------
# malformed drafts

LIFT3 = {"threading": straight(3), "liftplan": straight(3)}


@pytest.mark.parametrize("text, section, words", [
    ("this is not a draft\n", "[WIF]", ("not a WIF file",)),
    ("", "[WIF]", ("not a WIF file",)),
    (draft_text(threading="1=1\n2=x\n", liftplan=straight(2)), "[THREADING]", ("'2=x'", "END=SHAFT")),
    (draft_text(threading=straight(2), liftplan="1=1\ngarbage\n"), "[LIFTPLAN]", ("'garbage'", "PICK=SHAFT")),
    (draft_text(threading=straight(2), liftplan={1: "", 2: 0}), "[LIFTPLAN]", ("no drawdown",)),
    (draft_text(threading=straight(2)), "[LIFTPLAN]", ("no drawdown",)),
    (draft_text(threading=straight(2), tieup=straight(2)), "[TREADLING]", ("add a [TREADLING]",)),
    (draft_text(threading="", liftplan=straight(2)), "[THREADING]", ("no end is threaded",)),
    (draft_text(threading={1: -2, 2: 1}, liftplan=straight(2)), "[THREADING]", ("1=-2", "negative")),
    (draft_text(**LIFT3).replace("Rising Shed=true", "Rising Shed=maybe"), "[WEAVING]", ("rising shed=maybe",)),
    (draft_text(**LIFT3).replace("Threads=3\nColor=2", "Threads=100000\nColor=2"), "[WEFT]", ("100000 picks",)),
    (draft_text(**LIFT3).replace("2=0,0,128", "2=0,0"), "[COLOR TABLE]", ("INDEX=R,G,B",)),
    (draft_text(**LIFT3).replace("[WEAVING]", "WEAVING]"), "[LIFTPLAN]", ("'weaving]'",)),
])
def test_malformed_drafts_are_refused_naming_the_section(tmp_path, text, section, words):
    message = refused(tmp_path, text)
    assert f": {section}:" in message, message
    for word in words:
        assert word in message, message


def test_a_repeat_over_64_is_refused_naming_the_sections(tmp_path):
    # 70 ends all on different shafts, every end raised on its own pick: a 70 × 70 repeat
    text = draft_text(threading=straight(70), liftplan=straight(70))
    message = refused(tmp_path, text)
    assert "[THREADING] and [LIFTPLAN]" in message and "70 picks × 70 ends" in message and "64" in message


def test_a_title_with_a_percent_sign_and_latin1_text_read(tmp_path):
    text = draft_text(**LIFT3, extra="\n[TEXT]\nTitle=50% laine, tissée\n")
    path = tmp_path / "latin.wif"
    path.write_bytes(text.encode("latin-1"))
    assert wif.read_wif(path).title == "50% laine, tissée"


def test_a_missing_file_is_an_input_error(tmp_path):
    with pytest.raises(InputError, match="cannot read the WIF file"):
        wif.read_wif(tmp_path / "nope.wif")


# ---------------------------------------------------------------------------------------------
# writing, and round trips


def write_read(tmp_path: Path, fabric) -> wif.Draft:
    path = tmp_path / "out.wif"
    wif.save_wif(fabric, path, force=True)
    return wif.read_wif(path)


@pytest.mark.parametrize("path", FIXTURES, ids=[p.stem for p in FIXTURES])
def test_every_fixture_round_trips_exactly(tmp_path, path):
    """Pattern and thread colours: the draft spans the fabric's whole repeat (the lcm of the
    weave's and the colour repeats), and its colour orders read back as the params hold them,
    each colour to the table's 8 bits."""
    fabric = params.load(path)
    draft = write_read(tmp_path, fabric)
    np.testing.assert_array_equal(draft.pattern, fabric.pattern)
    reps = np.array(fabric.full_repeat) // np.array(fabric.shape)
    np.testing.assert_array_equal(draft.drawdown, np.tile(fabric.pattern, reps))
    for family in ("warp", "weft"):
        want = fabric.threads.family(family) if fabric.threads else None
        got = draft.threads.family(family) if draft.threads else None
        assert (got is None) == (want is None), family
        if want is not None:
            assert got.sequence == want.sequence
            np.testing.assert_allclose(got.per_thread("body_reflection"), want.per_thread("body_reflection"),
                                       atol=0.004)


def test_thread_colours_round_trip_from_a_fitted_fabric(tmp_path):
    """A colour order of any palette order and length survives params -> WIF -> params: a
    13-pick weft order of 4 colours on a twill 2/1 with a 5-end warp order (lcm 39 picks × 15
    ends drafted)."""
    rng = np.random.default_rng(3)
    base = params.load(ROOT / "fixtures" / "params" / "twill_2_1.json")

    def order(n: int, colours: int) -> params.ThreadColours:
        seq = np.concatenate([np.arange(colours), rng.integers(0, colours, n - colours)])
        rgb = [tuple(float(v) for v in rng.random(3)) for _ in range(colours)]
        return params.ThreadColours(palette=tuple(params.PaletteEntry(c, c) for c in rgb),
                                    sequence=tuple(int(k) for k in seq))

    fabric = base.with_threads(params.Threads(warp=order(5, 2), weft=order(13, 4)))
    draft = write_read(tmp_path, fabric)
    assert draft.drawdown.shape == (39, 15)
    back = fabric.with_threads(draft.threads)
    for family in ("warp", "weft"):
        assert back.threads.family(family).sequence == fabric.threads.family(family).sequence
        np.testing.assert_allclose(back.threads.family(family).per_thread("body_reflection"),
                                   fabric.threads.family(family).per_thread("body_reflection"), atol=0.004)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(arrays(np.uint8, st.tuples(st.integers(1, 64), st.integers(1, 64)), elements=st.integers(0, 1)))
def test_random_patterns_round_trip(tmp_path, pattern):
    """Any pattern up to 64x64 survives pattern -> WIF -> pattern (40 random examples in CI; a run of
    150 passed when this was written)."""
    fabric = params.load(FIXTURES[0]).replace({"pattern": pattern})
    draft = write_read(tmp_path, fabric)
    np.testing.assert_array_equal(draft.drawdown, pattern)
    np.testing.assert_array_equal(draft.pattern, minimal_repeat(pattern))


def test_the_draft_carries_shafts_treadles_colours_and_spacing():
    fabric = dataclasses.replace(params.load(ROOT / "fixtures" / "params" / "twill_2_1.json"), scale={"pitch_mm": 0.42})
    data = library_read_wif(io.StringIO(wif.wif_text(fabric)))
    # a 3 × 3 twill: 3 shafts threaded 1, 2, 3 and 3 treadles, besides the liftplan
    assert data.num_shafts == 3 and data.threading == {1: {1}, 2: {2}, 3: {3}}
    assert len(data.tieup) == 3 and len(data.treadling) == 3 and len(data.liftplan) == 3
    assert data.is_rising_shed
    for yarn, index in (("warp", data.warp.color), ("weft", data.weft.color)):
        srgb = np.rint(linear_to_srgb(np.asarray(fabric.get(f"{yarn}.body_reflection"))) * 255)
        assert data.color_table[index] == tuple(int(c) for c in srgb)
    assert data.warp.units == data.weft.units == "centimeters"
    assert data.warp.spacing == data.weft.spacing == pytest.approx(0.042)
    assert data.name == "weavecap twill 2/1 S"


def test_many_shafts_are_written_as_a_liftplan_only():
    rng = np.random.default_rng(3)
    pattern = rng.integers(0, 2, size=(40, 40), dtype=np.uint8)
    fabric = params.load(FIXTURES[0]).replace({"pattern": pattern})
    data = library_read_wif(io.StringIO(wif.wif_text(fabric)))
    assert data.num_shafts == len({tuple(c) for c in pattern.T}) > wif.TREADLE_LIMIT
    assert not data.tieup and not data.treadling and len(data.liftplan) <= 40


def test_a_pattern_that_never_interlaces_is_written_as_a_sinking_shed(tmp_path):
    fabric = params.load(FIXTURES[0]).replace({"pattern": np.ones((1, 1), dtype=np.uint8)})
    data = library_read_wif(io.StringIO(wif.wif_text(fabric)))
    assert not data.is_rising_shed
    np.testing.assert_array_equal(write_read(tmp_path, fabric).pattern, [[1]])


def test_save_refuses_to_overwrite_without_force(tmp_path):
    fabric = params.load(FIXTURES[0])
    path = tmp_path / "draft.wif"
    path.write_text("keep me")
    with pytest.raises(InputError, match="--force"):
        wif.save_wif(fabric, path)
    assert path.read_text() == "keep me"
    wif.save_wif(fabric, path, force=True)
    assert path.read_text().startswith("[WIF]")
