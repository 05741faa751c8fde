"""Where the tests find the shared data — the real photos, meshes, WIF drafts and contracts in
``../shared`` beside the clone (``$WEAVECAP_SHARED`` elsewhere) — in one place.

A test that reads it asks for the ``shared`` fixture (tests/conftest.py) and gets
:func:`need`: the path, or a skip naming what is absent — a failure instead when
``WEAVECAP_REQUIRE_SHARED=1`` (CI sets it where ``../shared`` exists), so that real-data tests
cannot vanish from a run that should have them. The suite's summary counts them.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

REQUIRE = "WEAVECAP_REQUIRE_SHARED"
#: the words a failure for a missing shared file carries (the summary counts those failures)
MISSING = "requires the shared data"
#: the name :func:`names` gives when a folder is absent (see there)
ABSENT = "(absent)"


def root() -> Path:
    """``$WEAVECAP_SHARED``, else ``shared`` beside the repository (which may not exist)."""
    env = os.environ.get("WEAVECAP_SHARED")
    return Path(env) if env else Path(__file__).resolve().parents[2] / "shared"


def path(*parts: str) -> Path:
    """``root() / parts``, present or not (for constants; read it through :func:`need`)."""
    return root().joinpath(*parts)


def required() -> bool:
    """Whether a missing shared file fails the run (``WEAVECAP_REQUIRE_SHARED=1``)."""
    return os.environ.get(REQUIRE, "") not in ("", "0")


def need(*parts: str) -> Path:
    """The shared file or folder at ``parts``; a skip when it is absent, a failure under
    ``WEAVECAP_REQUIRE_SHARED=1``."""
    wanted = path(*parts)
    if not wanted.exists():
        message = f"../shared/{'/'.join(parts)} is absent (looked in {root()})"
        if required():
            pytest.fail(f"{message}, and {REQUIRE}=1 {MISSING}", pytrace=False)
        pytest.skip(message)
    return wanted


def names(*parts: str, pattern: str = "*") -> list[str]:
    """The names in the shared folder ``parts`` (sorted), to parametrize a test over; when the
    folder is absent, the one name :data:`ABSENT`, so that the test still runs, asks for its
    file (:func:`need`) and skips — or fails under ``WEAVECAP_REQUIRE_SHARED=1`` — rather than
    vanish as an empty parameter set."""
    folder = path(*parts)
    return sorted(p.name for p in folder.glob(pattern)) if folder.is_dir() else [ABSENT]
