"""Preparation on the real photos of ``../shared/realdata`` (read in place, never copied).

Skipped when the shared folder is absent. What is asserted is what holds today: every photo
(easy, hard, negative) gives a result or a reason without crashing; every negative is
rejected; the RAW files load or fail with a PhotoError. Which easy photos give a grid that
matches a count by eye is tabulated by ``scripts/bench_prepare.py --realdata``.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from weavecap.errors import PhotoError
from weavecap.photo import load_photo
from weavecap.prepare import Prepared, Rejected, prepare_photo


def _shared() -> Path | None:
    cand = Path(__file__).resolve().parents[3] / "shared"
    if cand.is_dir():
        return cand
    env = os.environ.get("WEAVECAP_SHARED")
    return Path(env) if env and Path(env).is_dir() else None


SHARED = _shared()
pytestmark = pytest.mark.skipif(SHARED is None or not (SHARED / "realdata").is_dir(),
                                reason="../shared/realdata is absent")


def _files(sub: str) -> list[Path]:
    if SHARED is None:
        return []
    return sorted((SHARED / "realdata" / sub).glob("*"))


@pytest.mark.parametrize("path", _files("images/negative"), ids=lambda p: p.name)
def test_negatives_are_rejected_with_a_reason(path):
    r = prepare_photo(load_photo(path).rgb)
    assert isinstance(r, Rejected), f"{path.name} was not rejected"
    assert len(r.reason) > 20


@pytest.mark.parametrize("path", _files("images/easy"), ids=lambda p: p.name)
def test_easy_photos_do_not_crash(path):
    r = prepare_photo(load_photo(path).rgb)
    assert isinstance(r, (Prepared, Rejected))
    if isinstance(r, Prepared):
        assert abs(r.rectification.rotation_deg) <= 45
        assert all(n >= 2 for n in r.grid.yarns)
        assert all(p > 0 for p in r.grid.pitch_px)


@pytest.mark.parametrize("path", [p for p in _files("images/easy") if p.name in
                                  {"itd_type9cam2.png", "fabricnet_W077_plain.jpg", "fabricnet_W027_plain.jpg"}],
                         ids=lambda p: p.name)
def test_plain_weaves_checked_by_eye(path):
    """Photos whose grid.png was checked by eye: plain weave, 2 × 2, nearly frontal."""
    r = prepare_photo(load_photo(path).rgb)
    assert isinstance(r, Prepared)
    assert tuple(r.grid.yarns) == (2, 2)
    assert abs(r.rectification.rotation_deg) < 5


@pytest.mark.parametrize("path", _files("raw"), ids=lambda p: p.name)
def test_raw_files_load_or_fail_cleanly(path):
    try:
        ph = load_photo(path)
    except PhotoError as exc:
        assert path.name in str(exc)
        return
    small = ph.rgb[:: max(1, ph.height // 600), :: max(1, ph.width // 600)]
    assert isinstance(prepare_photo(small), (Prepared, Rejected))
