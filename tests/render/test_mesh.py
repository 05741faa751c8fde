"""Reading garment meshes (weavecap.render.mesh): what is refused, what is repaired, and the
fabric coordinates that keep the weave at its physical size.

Known answers: a flat swatch whose UVs are scaled or squashed gets back its own coordinates in
metres; a sheet bent into folds gets its arc length; a mirrored layout is turned back; a
mesh without UVs gets them; every broken file is refused with its name and its problem.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from weavecap.errors import InputError
from weavecap.render import mesh as rmesh
from weavecap.render import shapes

QUAD = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"


def write(tmp_path: Path, name: str, text) -> Path:
    path = tmp_path / name
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text)
    return path


def swatch_obj(tmp_path: Path, uv_scale=(1.0, 1.0), name="swatch.obj", cells=4) -> Path:
    """A 0.2 m flat swatch whose UVs are its own coordinates times ``uv_scale``."""
    shape = shapes.flat_swatch(0.2, 0.2, cells=cells)
    shape = shapes.Shape(shape.name, shape.positions, shape.faces, shape.uv * np.asarray(uv_scale), "test")
    return write(tmp_path, name, shape.obj_text())


# -- refused -----------------------------------------------------------------------------------

BAD = {
    "nan.obj": (QUAD.replace("v 1 1 0", "v 1 nan 0") + "f 1 2 3 4\n", "not finite"),
    "inf.obj": (QUAD.replace("v 1 1 0", "v 1 inf 0") + "f 1 2 3 4\n", "not finite"),
    "empty.obj": ("", "empty"),
    "comments.obj": ("# nothing here\n", "nothing that is a mesh"),
    "text.obj": ("this is a shopping list\nmilk\neggs\n", "nothing that is a mesh"),
    "points.obj": (QUAD, "4 points and no faces"),
    "out_of_range.obj": (QUAD + "f 1 2 3\nf 1 3 9\n", "line 6"),
    "out_of_range.ply": ("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                         "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                         "0 0 0\n1 0 0\n0 1 0\n3 0 1 9\n", "out of range"),
    "points.ply": ("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                   "end_header\n0 0 0\n1 0 0\n0 1 0\n", "no faces"),
    "noise.ply": (bytes(range(256)) * 8, "not a readable"),
    "mesh.stl": (QUAD + "f 1 2 3\n", "unsupported mesh format"),
    "degenerate.obj": ("v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n", "degenerate"),
}


@pytest.mark.parametrize("name", sorted(BAD))
def test_bad_meshes_are_refused_naming_the_file_and_the_problem(tmp_path, name):
    text, words = BAD[name]
    path = write(tmp_path, name, text)
    with pytest.raises(InputError, match=words) as err:
        rmesh.load_mesh(path)
    assert str(path) in str(err.value)


def test_missing_file_and_unknown_units_or_object(tmp_path):
    with pytest.raises(InputError, match="not found"):
        rmesh.load_mesh(tmp_path / "nope.obj")
    path = swatch_obj(tmp_path)
    with pytest.raises(InputError, match="--units 'inch'"):
        rmesh.load_mesh(path, units="inch")
    with pytest.raises(InputError, match="no object named 'Shirt'; the file has: swatch"):
        rmesh.load_mesh(path, object_name="Shirt")


def test_a_mesh_over_the_size_limit_is_refused(tmp_path, monkeypatch):
    monkeypatch.setattr(rmesh, "MAX_FACES", 10)
    with pytest.raises(InputError, match="32 faces is over the mesh size limit of 10"):
        rmesh.load_mesh(swatch_obj(tmp_path))


# -- repaired ----------------------------------------------------------------------------------


def test_missing_mtl_ngons_duplicates_and_degenerate_faces_are_handled(tmp_path):
    """A file naming a missing .mtl, with a pentagon, a duplicated vertex and a zero-area face
    reads: the pentagon becomes 3 triangles, the duplicate is merged, the sliver dropped."""
    text = ("mtllib missing.mtl\nusemtl cloth\n"
            "v 0 0 0\nv 1 0 0\nv 1.3 0.8 0\nv 0.5 1.2 0\nv -0.3 0.8 0\nv 1 0 0\nv 2 0 0\n"
            "f 1 2 3 4 5\nf 6 3 2\nf 2 6 7\n")
    mesh = rmesh.load_mesh(write(tmp_path, "cloth.obj", text), units="m")
    assert len(mesh.faces) == 3  # the pentagon's fan; f 6 3 2 = f 2 3 2 and f 2 6 7 collapse
    assert any("merged 1 duplicate" in n for n in mesh.notes)
    assert any("dropped 2 degenerate" in n for n in mesh.notes)
    assert mesh.uv_source == "xatlas"


def test_multi_object_obj_renders_every_object_or_the_named_one(tmp_path):
    text = ("o Front\n" + QUAD + "f 1 2 3 4\n" + "o Back\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\nf 5 6 7 8\n")
    path = write(tmp_path, "two.obj", text)
    both = rmesh.load_mesh(path)
    assert sorted(both.objects) == ["Back", "Front"] and len(both.faces) == 4
    back = rmesh.load_mesh(path, object_name="Back")
    assert back.objects == ["Back"] and len(back.faces) == 2
    np.testing.assert_allclose(back.positions[:, 2], 1.0)


def test_units_scale_to_metres_and_an_implausible_size_is_warned(tmp_path):
    path = swatch_obj(tmp_path)
    cm = rmesh.load_mesh(path, units="cm")
    np.testing.assert_allclose(np.ptp(cm.positions, axis=0)[:2], 0.002)
    assert any("unlikely for a garment" in n and "--units" in n for n in cm.notes)
    m = rmesh.load_mesh(path, units="m")
    assert not any("unlikely" in n for n in m.notes)


# -- fabric coordinates --------------------------------------------------------------------------


@pytest.mark.parametrize("uv_scale", [(1.0, 1.0), (3.0, 3.0), (2.0, 0.5), (-1.0, 1.0)])
def test_swatch_uvs_become_its_own_coordinates_in_metres(tmp_path, uv_scale):
    """Scaled, squashed or mirrored, a flat swatch's layout is corrected to an isometry: UV
    distances equal surface distances (stretch 1), and the face stays on the normals' side."""
    mesh = rmesh.load_mesh(swatch_obj(tmp_path, uv_scale))
    d_uv = np.linalg.norm(mesh.uv[:, None] - mesh.uv[None], axis=-1)
    d_xyz = np.linalg.norm(mesh.positions[:, None] - mesh.positions[None], axis=-1)
    np.testing.assert_allclose(d_uv, d_xyz, atol=1e-6)
    assert mesh.stretch["after"] == pytest.approx(1.0, abs=1e-6)
    q = mesh.uv[mesh.faces]
    d1, d2 = q[:, 1] - q[:, 0], q[:, 2] - q[:, 0]
    assert np.all(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0] > 0)  # counter-clockwise like the faces
    if uv_scale[0] < 0:
        assert mesh.stretch["mirrored_islands"] == 1


def test_stretched_layout_of_folds_is_corrected_to_the_arc_length(tmp_path):
    """Sine folds whose UVs are the flat projection (x, y) instead of the arc length: the
    weave would shrink on the slopes; corrected, u spans the length of the mesh's profile
    (its polyline), within 0.1%."""
    shape = shapes.sine_folds(amplitude=0.015)
    flat = shapes.Shape("projected", shape.positions, shape.faces, shape.positions[:, :2].copy(), "test")
    mesh = rmesh.load_mesh(write(tmp_path, "folds.obj", flat.obj_text()))
    assert mesh.stretch["before"] > 1.3
    assert mesh.stretch["after"] < 1.01
    row = shape.positions[shape.positions[:, 1] == shape.positions[0, 1]]
    length = np.linalg.norm(np.diff(row[np.argsort(row[:, 0])], axis=0), axis=1).sum()
    assert np.ptp(mesh.uv[:, 0]) == pytest.approx(length, rel=1e-3)


def test_the_towel_keeps_its_uvs_and_the_monkey_gets_some(shared):
    """The towel (UVs in the file, .mtl missing) and the monkey (no UVs: xatlas) both read;
    their corrected coordinates stretch less than their layouts (measured: towel 1.26 → 1.14,
    monkey 1.20 → 1.14, 95th percentile)."""
    towel = rmesh.load_mesh(shared("meshes", "towel.obj"))
    assert towel.uv_source == "file" and len(towel.faces) == 2048
    monkey = rmesh.load_mesh(shared("meshes", "monkey.obj"))
    assert monkey.uv_source == "xatlas" and any("xatlas" in n for n in monkey.notes)
    for m in (towel, monkey):
        assert m.stretch["after"] < m.stretch["before"] and m.stretch["after"] < 1.2
        assert np.isfinite(m.uv).all()
