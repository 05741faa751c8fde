"""The procedural cloth shapes (weavecap.render.shapes) and the fixture meshes made from them.

Known answers: the committed fixtures are what the generator writes today; every sheet is
bent without stretching, so its UVs (metres) have the area of the surface; the faces face the
side the module says; the folds have the amplitude and the opening they were asked for.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

from weavecap.render import shapes

MESHES = Path(__file__).resolve().parents[2] / "fixtures" / "meshes"


def uv_area_ratio(shape: shapes.Shape) -> tuple[float, float]:
    """(surface area / UV area, share of faces whose UVs are mirrored)."""
    p, q = shape.positions[shape.faces], shape.uv[shape.faces]
    area = np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1).sum() / 2
    d1, d2 = q[:, 1] - q[:, 0], q[:, 2] - q[:, 0]
    signed = (d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]) / 2
    return float(area / np.abs(signed).sum()), float(np.mean(signed < 0))


@pytest.mark.parametrize("name", sorted(shapes.FIXTURES))
def test_committed_fixture_is_what_the_generator_makes(name):
    """fixtures/meshes/NAME.obj is byte for byte `python fixtures/make_meshes.py`'s output,
    small (< 200 KB), and reads back with the same vertices and UVs."""
    from weavecap.fixtures.make_meshes import COMMAND  # noqa: PLC0415  (the generator beside the files)

    shape = shapes.FIXTURES[name]()
    path = MESHES / f"{name}.obj"
    assert path.read_text() == shape.obj_text(COMMAND)
    assert path.stat().st_size < 200_000
    mesh = trimesh.load(path, process=False)
    np.testing.assert_allclose(mesh.vertices, shape.positions, atol=1e-4)
    np.testing.assert_allclose(mesh.visual.uv, shape.uv, atol=1e-4)


@pytest.mark.parametrize("name", ["swatch", "sine_low", "sine_high", "wave", "horseshoe_wide", "horseshoe_narrow"])
def test_sheets_are_bent_without_stretching(name):
    """The sheets' UVs are the flat cloth: area within 1.5% of the surface's, none mirrored."""
    ratio, mirrored = uv_area_ratio(shapes.FIXTURES[name]())
    assert ratio == pytest.approx(1.0, abs=0.015)
    assert mirrored == 0.0


@pytest.mark.parametrize("name, axis, sign", [("swatch", 2, 1), ("sine_high", 2, 1), ("horseshoe_narrow", 2, 1),
                                              ("drape", 1, 1)])
def test_faces_face_the_fabric_side(name, axis, sign):
    """The mean face normal points to the side the fabric's face is on (+z sheets, drape up)."""
    shape = shapes.FIXTURES[name]()
    normals = shape.to_trimesh().face_normals
    assert sign * normals[:, axis].mean() > 0.3


def test_skirt_faces_outwards_and_its_uvs_barely_stretch():
    """The skirt's normals point away from its axis; its flat pattern (a cone's annular sector)
    covers the surface within 10% (the folds stretch it), none mirrored."""
    shape = shapes.skirt()
    mesh = shape.to_trimesh()
    radial = mesh.triangles_center[:, [0, 2]]
    assert np.all(np.sum(mesh.face_normals[:, [0, 2]] * radial, axis=1) > 0)
    ratio, mirrored = uv_area_ratio(shape)
    assert ratio == pytest.approx(1.0, abs=0.1) and mirrored == 0.0


def test_fold_amplitudes_and_openings():
    """Sine folds span 2A in depth; a horseshoe's loop overhangs its neck (wider than the
    opening) and its neck is as wide as asked."""
    for amplitude in (0.004, 0.015):
        z = shapes.sine_folds(amplitude=amplitude).positions[:, 2]
        assert np.ptp(z) == pytest.approx(2 * amplitude, rel=0.02)
    shoe = shapes.horseshoe(opening=0.015, radius=0.025)
    p = shoe.positions
    lifted = p[p[:, 2] > 1e-6]
    assert np.ptp(lifted[:, 0]) == pytest.approx(0.05, rel=0.03)  # the loop is 2 radii wide
    near_floor = p[(p[:, 2] > 1e-6) & (p[:, 2] < 0.002)]
    assert np.ptp(near_floor[:, 0]) < 0.025  # the neck, just above the floor, is narrow
    with pytest.raises(ValueError, match="opening"):
        shapes.horseshoe(opening=0.06, radius=0.025)
