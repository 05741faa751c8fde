"""Shared fixtures: ``bad_params``, one bad params file per case of
:data:`params_cases.BAD_PARAMS`, so that every bad file a user might hand to weavecap is checked
by the library tests (``test_params.py``) and the command tests (``test_cli_errors.py``) with
one list."""

from __future__ import annotations

import pytest

from params_cases import BAD_PARAMS, BadParams, bad_params_text


@pytest.fixture(params=BAD_PARAMS, ids=[case[0] for case in BAD_PARAMS])
def bad_params(request, tmp_path) -> BadParams:
    """One bad params file written under tmp_path (each test runs once per case)."""
    name, edit, field, words = request.param
    path = tmp_path / f"{name}.json"
    path.write_text(bad_params_text(edit))
    return BadParams(path=path, field=field, words=words)
