"""Preparation on the real photos of ``../shared/realdata`` (read in place, never copied).

Read through the ``shared`` fixture (skipped where ../shared is absent). What is asserted is
what holds today: every photo (easy, hard, negative) gives a result or a reason without
crashing; every negative is rejected; the RAW files load or fail with a PhotoError; the easy
photos whose grid.png was checked by eye keep their grid. The whole table is printed by
``scripts/bench_prepare.py --realdata``.
"""

from __future__ import annotations

import pytest
from shared_data import names

from weavecap.errors import PhotoError
from weavecap.photo import load_photo
from weavecap.prepare import Prepared, Rejected, prepare_photo


@pytest.mark.parametrize("name", names("realdata", "images", "negative"))
def test_negatives_are_rejected_with_a_reason(name, shared):
    path = shared("realdata", "images", "negative", name)
    r = prepare_photo(load_photo(path).rgb)
    assert isinstance(r, Rejected), f"{path.name} was not rejected"
    assert len(r.reason) > 20


@pytest.mark.parametrize("name", names("realdata", "images", "easy"))
def test_easy_photos_do_not_crash(name, shared):
    r = prepare_photo(load_photo(shared("realdata", "images", "easy", name)).rgb)
    assert isinstance(r, (Prepared, Rejected))
    if isinstance(r, Prepared):
        assert abs(r.rectification.rotation_deg) <= 45
        assert all(n >= 2 for n in r.grid.yarns)
        assert all(p > 0 for p in r.grid.pitch_px)


@pytest.mark.parametrize("name", ["itd_type9cam2.png", "fabricnet_W077_plain.jpg", "fabricnet_W027_plain.jpg"])
def test_plain_weaves_checked_by_eye(name, shared):
    """Photos whose grid.png was checked by eye: plain weave, 2 × 2, nearly frontal."""
    r = prepare_photo(load_photo(shared("realdata", "images", "easy", name)).rgb)
    assert isinstance(r, Prepared)
    assert tuple(r.grid.yarns) == (2, 2)
    assert abs(r.rectification.rotation_deg) < 5


@pytest.mark.parametrize("name", names("realdata", "raw"))
def test_raw_files_load_or_fail_cleanly(name, shared):
    path = shared("realdata", "raw", name)
    try:
        ph = load_photo(path)
    except PhotoError as exc:
        assert path.name in str(exc)
        return
    small = ph.rgb[:: max(1, ph.height // 600), :: max(1, ph.width // 600)]
    assert isinstance(prepare_photo(small), (Prepared, Rejected))


def _input_pitch(r: Prepared) -> tuple[float, float]:
    return tuple(p / r.rectification.scale for p in r.grid.pitch_px)


@pytest.mark.parametrize("name, yarns, warp_px, weft_px", [
    # a 4-end twill: its diagonal is as strong as the yarns in the Radon transform; warps ~20 px
    # apart, wefts ~39 px (FabricNET sheet: 52 warps, 30 wefts per cm)
    ("fabricnet_W057_twill.jpg", (4, 4), (18.5, 22.5), (35.0, 42.0)),
    # a 5-end satin whose weft floats hide the weft boundaries: the weft pitch comes from the
    # lattice of interlacings (sheet: 50 warps, 93 wefts per cm)
    ("fabricnet_W108_satin.jpg", (5, 5), (24.0, 28.0), (9.5, 11.0)),
    # a 2/2 twill whose hairy dark warps leave the warp projection flat: the warp pitch comes
    # from the lattice, confirmed by the 4-yarn repeat (sheet: 26 warps, 25 wefts per cm)
    ("fabricnet_W103_twill.jpg", (4, 4), (48.0, 55.0), (46.0, 52.0)),
    # a satin whose weft floats hide the weft boundaries; warps ~52 px. Its wefts are ~15.8 px
    # apart, not the sheet's 25 × 53 per cm (24.8 px): the photo's autocorrelation has its
    # interlacings at (-104, 16), (55, 46), (160, 30) px = (-2, 1), (1, 3), (3, 2) yarns for
    # a 52.6 × 15.5 px grid, a cell of 7 yarns (a 7-end satin of step 3); the spectral lattice
    # gives 7 warps a unit and 15.8 px, and the weft projection's only period is 15.9 px (its
    # spectrum has a peak on the fy axis at 15.7 px). The 7-warp repeat shows once in the
    # photo's 12 warps, too few for a DMF: the lattice counts it (7×11 before)
    ("fabricnet_W127_satin.jpg", (7, 7), (50.0, 55.0), (15.0, 16.8)),
    # a herringbone: pitch from the projections (the 2D spectrum has its yarn peaks at 8.4, 9.1 px);
    # the diagonal reverses every 58-67 px (7-8 warps), the look repeats every 126 px = 15
    # warps; its cells repeat over 2 wefts (a 2/2 twill's complement looks alike in this grey
    # photo) and over 2 warps within a leg: the 2/2 base's 4 wefts (2×15 before)
    ("brodatz_D16_herringbone_000deg.tiff", (4, 15), (8.0, 8.8), (8.7, 9.5)),
])
def test_twill_and_satin_grids_checked_by_eye(name, yarns, warp_px, weft_px, shared):
    r = prepare_photo(load_photo(shared("realdata", "images", "easy", name)).rgb)
    assert isinstance(r, Prepared), getattr(r, "reason", "")
    assert abs(r.rectification.rotation_deg) < 5
    warp, weft = _input_pitch(r)
    assert warp_px[0] <= warp <= warp_px[1] and weft_px[0] <= weft <= weft_px[1], (warp, weft)
    if yarns is not None:
        assert tuple(r.grid.yarns) == yarns


@pytest.mark.parametrize("name", ["brodatz_D16_herringbone_030deg.tiff", "brodatz_D16_herringbone_120deg.tiff"])
def test_turned_herringbone_keeps_its_repeat(name, shared):
    """The same Brodatz D16 cloth digitised turned by 30° and 120°: the same 4 × 15 repeat (the
    warps and wefts swap at 120°: the turn is taken to within ±45°), 8.4 × 9.1 px yarns."""
    r = prepare_photo(load_photo(shared("realdata", "images", "hard", name)).rgb)
    assert isinstance(r, Prepared), getattr(r, "reason", "")
    assert sorted(r.grid.yarns) == [4, 15]
    fine, coarse = sorted(_input_pitch(r))
    assert 8.0 <= fine <= 8.8 and 8.7 <= coarse <= 9.5, (fine, coarse)


def test_a_given_repeat_is_checked_against_the_repeat_the_photo_shows_not_its_widening(shared):
    """D16's cells repeat over 2 wefts, widened to the 2/2 twill base's 4 (a grey twill's
    complement looks alike): a pattern given over 2 wefts is a multiple of what the photo shows
    and is used; 3 wefts is no multiple of 2 and is refused."""
    from weavecap.errors import ParamsError

    rgb = load_photo(shared("realdata", "images", "easy", "brodatz_D16_herringbone_000deg.tiff")).rgb
    own = prepare_photo(rgb)
    assert tuple(own.grid.yarns) == (4, 15) and own.checks["repeat_doubled"] == [True, False]
    given = prepare_photo(rgb, repeat=(2, 15))
    assert isinstance(given, Prepared) and tuple(given.grid.yarns) == (2, 15)
    assert given.checks["repeat_in_photo"] == [2, 15]
    with pytest.raises(ParamsError, match="the photo's repeat is 2 wefts x 15 warps, which does not divide it"):
        prepare_photo(rgb, repeat=(3, 15))
