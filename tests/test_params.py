"""Tests for weavecap.params: params files load, save and round-trip exactly, and every kind
of bad file is refused with a message naming the field, the value and the allowed range."""

from __future__ import annotations

import json
import math
from pathlib import Path

import jsonschema
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from weavecap import params
from weavecap.errors import InputError, ParamsError
from weavecap.photo import save_png

FIXTURE_PARAMS = Path(__file__).resolve().parents[1] / "fixtures" / "params"
FIXTURES = sorted(FIXTURE_PARAMS.glob("*.json"))
CONTRACT = Path(__file__).resolve().parents[2] / "shared" / "contracts" / "params.schema.json"


def plain() -> params.Fabric:
    return params.load(FIXTURE_PARAMS / "plain.json")


def test_fixtures_exist():
    """The six bundled fabrics of the issue are there (plain, twills, satin, basket, custom)."""
    assert len(FIXTURES) >= 6, FIXTURES


@pytest.mark.parametrize("path", FIXTURES, ids=[p.stem for p in FIXTURES])
def test_fixture_round_trip(path, tmp_path):
    """load → save → load gives the same fabric, and every value in the file survives."""
    fabric = params.load(path)
    out = tmp_path / "saved.json"
    params.save(fabric, out)
    assert params.load(out) == fabric
    original = json.loads(path.read_text())
    saved = json.loads(out.read_text())
    assert {key: saved[key] for key in original} == original
    assert [p.name for p in tmp_path.iterdir()] == ["saved.json"], "a temporary file was left behind"


def test_saved_file_has_ordinary_permissions(tmp_path):
    """A saved params file is as readable as any file the user creates (not mkstemp's 0600)."""
    reference = tmp_path / "reference.txt"
    reference.write_text("x")
    out = tmp_path / "saved.json"
    params.save(plain(), out)
    assert out.stat().st_mode & 0o777 == reference.stat().st_mode & 0o777


@pytest.mark.skipif(not CONTRACT.is_file(), reason="../shared/contracts not available")
@pytest.mark.parametrize("path", FIXTURES, ids=[p.stem for p in FIXTURES])
def test_saved_file_follows_the_contract(path, tmp_path):
    """What weavecap writes validates against the shared params contract."""
    out = tmp_path / "saved.json"
    params.save(params.load(path), out)
    jsonschema.validate(json.loads(out.read_text()), json.loads(CONTRACT.read_text()))


def test_project_schema_is_the_contract():
    """The project's own copy of the schema has not drifted from the shared contract."""
    if not CONTRACT.is_file():
        pytest.skip("../shared/contracts not available")
    own = Path(params.__file__).parent / "schemas" / "params.schema.json"
    assert json.loads(own.read_text()) == json.loads(CONTRACT.read_text())


def test_loaded_types_and_shape():
    """A loaded fabric has a uint8 (wefts, warps) pattern, integer counts and RGB tuples."""
    fabric = params.load(FIXTURE_PARAMS / "custom_4x6.json")
    assert fabric.pattern.dtype == np.uint8
    assert fabric.shape == (4, 6)
    assert fabric.pattern[0].tolist() == [1, 1, 0, 1, 0, 0]
    assert isinstance(fabric.plies, int) and isinstance(fabric.fibers, int)
    assert fabric.get("warp.body_reflection") == (0.1, 0.35, 0.2)
    assert fabric.get("specular.ior") == 1.5


def test_fit_ranges_are_table_1():
    """FIT_RANGES holds Table 1 of Wu et al. 2025 (spot checks of every kind of entry)."""
    r = params.FIT_RANGES
    assert r["plies"] == (1, 7) and r["fibers"] == (20, 50)
    assert r["specular.coefficient"] == (0.2, 0.8)
    assert r["specular.ior"] == r["specular.ior_exit"] == (1.4, 1.6)
    assert r["specular.attenuation"] == (9.0, 11.0)
    assert r["body_attenuation"] == (0.1, 0.7)
    assert r["warp.radius"] == r["weft.radius"] == (1.0, 5.0)
    assert r["specular.roughness"] == r["shadowing.fiber"] == (0.0, 1.0)
    assert len(r) == 20  # Table 1 less the pattern, warp/weft colours counted separately
    assert set(params.CONTINUOUS_KEYS) == set(r) - {"plies", "fibers"}


@pytest.mark.parametrize("end", [0, 1], ids=["low", "high"])
def test_both_ends_of_every_fit_range_are_valid(end):
    """Every Table 1 bound is a valid value of its field (colours on every channel)."""
    base = plain()
    values = {}
    for key, bounds in params.FIT_RANGES.items():
        value = bounds[end]
        values[key] = [value] * 3 if isinstance(base.get(key), tuple) else value
    fabric = base.replace(values)
    for key, value in values.items():
        assert np.array_equal(np.asarray(fabric.get(key), dtype=float), np.asarray(value, dtype=float)), key


def test_replace_refuses_out_of_range_and_unknown_keys():
    """Fabric.replace validates: a bad value names the field; an unknown key is refused."""
    with pytest.raises(ParamsError) as err:
        plain().replace({"specular.roughness": 1.5})
    assert err.value.field == "specular.roughness" and "[0, 1]" in str(err.value)
    with pytest.raises(ParamsError) as err:
        plain().replace({"specular.shininess": 0.5})
    assert err.value.field == "specular.shininess"
    # each replaced value is checked, whatever its kind, and a good one beside it does not hide it
    for bad, field in (({"warp.radius": 2.0, "specular.ior": float("nan")}, "specular.ior"),
                       ({"weft.body_reflection": (0.2, 1.2, 0.2)}, "weft.body_reflection[1]"),
                       ({"pattern": [[0, 2], [1, 0]]}, "pattern[0][1]"),
                       ({"warp": {"radius": -1.0, "body_reflection": [0.5] * 3, "body_subsurface": [0.5] * 3}},
                        "warp.radius"),
                       ({"plies": 8}, "plies")):
        with pytest.raises(ParamsError) as err:
            plain().replace(bad)
        assert err.value.field == field, bad


def test_every_bad_file_is_refused(bad_params):
    """Each bad params file raises ParamsError (exit status 2) naming field, value and range."""
    with pytest.raises(ParamsError) as err:
        params.load(bad_params.path)
    assert err.value.exit_code == 2
    assert err.value.field == bad_params.field
    message = str(err.value)
    assert str(bad_params.path) in message
    for word in bad_params.words:
        assert word in message, f"{word!r} missing from: {message}"


def test_missing_file(tmp_path):
    """A path that is not there, or a folder, is an input error naming the path."""
    for path, words in ((tmp_path / "nope.json", "not found"), (tmp_path, "is a folder")):
        with pytest.raises(ParamsError, match=words) as err:
            params.load(path)
        assert str(path) in str(err.value)
        assert isinstance(err.value, InputError)


def test_binary_file_is_refused(tmp_path):
    """A file that is not UTF-8 text is an input error, not a crash."""
    path = tmp_path / "photo.json"
    path.write_bytes(b"\xff\xd8\xff\xe0 not json")
    with pytest.raises(ParamsError, match="UTF-8"):
        params.load(path)


def test_texture_paths_are_relative_to_the_params_file(tmp_path):
    """A texture given relative to its params file loads, and stays right when saved elsewhere."""
    (tmp_path / "tex").mkdir()
    texture = tmp_path / "tex" / "warp.png"
    save_png(texture, np.full((8, 8, 3), 0.5, np.float32))  # textures are read when the params are
    doc = json.loads((FIXTURE_PARAMS / "plain.json").read_text())
    doc["warp"]["body_reflection"] = "tex/warp.png"
    (tmp_path / "in.json").write_text(json.dumps(doc))

    fabric = params.load(tmp_path / "in.json")
    assert fabric.warp.body_reflection == str(texture.resolve())

    out = tmp_path / "out" / "saved.json"
    params.save(fabric, out)
    assert json.loads(out.read_text())["warp"]["body_reflection"] == "../tex/warp.png"
    assert params.load(out) == fabric


def test_nan_in_a_parsed_document_is_refused():
    """NaN inside an otherwise valid document is refused, naming the field and its range."""
    doc = params.to_dict(plain())
    doc["specular"]["transmission"] = [0.1, math.nan, 0.1]
    with pytest.raises(ParamsError, match=r"\[0, 1\]") as err:
        params.from_dict(doc)
    assert err.value.field == "specular.transmission[1]"


# -- property: any fabric within Table 1's ranges round-trips exactly --------------------------


def _fit_values(draw) -> dict:
    base = plain()
    values = {}
    for key, (lo, hi) in params.FIT_RANGES.items():
        if key in ("plies", "fibers"):
            values[key] = draw(st.integers(int(lo), int(hi)))
        elif isinstance(base.get(key), tuple):
            values[key] = draw(st.lists(st.floats(lo, hi), min_size=3, max_size=3))
        else:
            values[key] = draw(st.floats(lo, hi))
    return values


@st.composite
def fabrics(draw) -> params.Fabric:
    rows, cols = draw(st.integers(1, 8)), draw(st.integers(1, 8))
    pattern = draw(st.lists(st.lists(st.integers(0, 1), min_size=cols, max_size=cols), min_size=rows,
                            max_size=rows))
    return plain().replace({"pattern": pattern, **_fit_values(draw)})


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(fabric=fabrics())
def test_random_fabrics_round_trip_exactly(fabric, tmp_path):
    """Random fabrics in Table 1's ranges survive save → load bit for bit."""
    out = tmp_path / "fabric.json"
    params.save(fabric, out)
    again = params.load(out)
    assert again == fabric
    for key in params.CONTINUOUS_KEYS:
        assert again.get(key) == fabric.get(key), key
    assert np.array_equal(again.pattern, fabric.pattern)
