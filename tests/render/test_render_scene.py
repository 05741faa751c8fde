"""The scene around a mesh (weavecap.render.scene): views, framing, lights.

Known answers: ``front`` is on +z looking at −z with y up, the other named views turn about y or
look down; with margin 0 the bounding box's corners touch the frame and none leaves it; the
capture rigs keep the forward model's light directions relative to the camera.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from weavecap.backend import mitsuba
from weavecap.errors import InputError
from weavecap.model.scene import light_rig
from weavecap.render import scene as rs

mi = mitsuba()

BOX = np.array([[-0.3, -0.2, -0.1], [0.5, 0.4, 0.3]])


@pytest.mark.parametrize("view, axis", [("front", (0, 0, 1)), ("back", (0, 0, -1)), ("left", (-1, 0, 0)),
                                        ("right", (1, 0, 0)), ("top", (0, 1, 0)), ("0,-90", (0, -1, 0))])
def test_named_views_put_the_camera_where_the_contract_says(view, axis):
    cam = rs.frame_camera(BOX, view=rs.parse_view(view))
    direction = np.asarray(cam.origin) - np.asarray(cam.target)
    np.testing.assert_allclose(direction / np.linalg.norm(direction), axis, atol=1e-9)
    if view in ("front", "back", "left", "right"):
        assert cam.up == (0.0, 1.0, 0.0)
    right, up, back = cam.basis
    assert abs(np.dot(right, up)) < 1e-9 and abs(np.linalg.det(np.stack([right, up, back])) - 1) < 1e-9


def test_parse_view_accepts_azimuth_elevation_and_refuses_nonsense():
    assert rs.parse_view("30,20") == (30.0, 20.0)
    for bad in ("sideways", "30", "1,2,3", "0,91", "nan,0"):
        with pytest.raises(InputError, match="--view"):
            rs.parse_view(bad)


def _projected(cam: rs.Camera, points: np.ndarray) -> np.ndarray:
    """Points in normalised image coordinates: x, y in [-1, 1] fill the frame's width/height."""
    right, up, back = cam.basis
    rel = points - np.asarray(cam.origin)
    x, y, depth = rel @ right, rel @ up, -(rel @ back)
    w, h = cam.size
    if cam.kind == "orthographic":
        return np.stack([x / cam.half_width, y / (cam.half_width * h / w)], axis=1)
    t = math.tan(math.radians(cam.fov_deg) / 2)
    return np.stack([x / (depth * t), y / (depth * t * h / w)], axis=1)


@pytest.mark.parametrize("kind", ["perspective", "orthographic"])
@pytest.mark.parametrize("view", ["front", "30,20", "top"])
def test_margin_zero_frames_the_bounding_box_exactly(kind, view):
    corners = np.array([[BOX[i, 0], BOX[j, 1], BOX[k, 2]] for i in (0, 1) for j in (0, 1) for k in (0, 1)])
    cam = rs.frame_camera(BOX, view=rs.parse_view(view), kind=kind, margin=0.0, size=(640, 360))
    p = _projected(cam, corners)
    assert np.abs(p).max() == pytest.approx(1.0, abs=1e-9)
    wide = rs.frame_camera(BOX, view=rs.parse_view(view), kind=kind, margin=0.25, size=(640, 360))
    assert np.abs(_projected(wide, corners)).max() == pytest.approx(1 / 1.25, rel=1e-6 if kind == "orthographic" else 0.2)


def test_orthographic_sensor_covers_the_frame_it_promises():
    """Rays of the Mitsuba sensor at the image corners land where _projected says ±1 is."""
    cam = rs.frame_camera(BOX, view=(0.0, 0.0), kind="orthographic", margin=0.0, size=(400, 300))
    sensor = mi.load_dict(cam.sensor(1))
    ray, _ = sensor.sample_ray(0.0, 0.0, mi.Point2f([0.0, 1.0], [0.0, 1.0]), mi.Point2f(0.5, 0.5))
    o = np.array(ray.o)
    right, up, _ = cam.basis
    half_h = cam.half_width * 300 / 400
    np.testing.assert_allclose(np.abs((o.T - np.asarray(cam.target)) @ right), cam.half_width, rtol=1e-5)
    np.testing.assert_allclose(np.abs((o.T - np.asarray(cam.target)) @ up), half_h, rtol=1e-5)


def test_capture_rigs_keep_the_forward_models_directions_relative_to_the_camera():
    """Front view: the rig's front light (towards +x, up the image, towards the camera in the
    forward model's frame, whose y runs down the image) comes from +x, +y, +z in the world."""
    cam = rs.frame_camera(BOX, view=(0.0, 0.0))
    lights = rs.lighting("both", cam)
    rig = light_rig("both")
    assert lights.ambient == rig.ambient and lights.background == rig.backdrop
    first = -np.asarray(lights.emitters["light_0"]["direction"])
    d = np.asarray(rig.lights[0].direction)
    np.testing.assert_allclose(first, [d[0], -d[1], d[2]], atol=1e-9)


def test_studio_and_sun_and_environment_maps(tmp_path):
    cam = rs.frame_camera(BOX, view=(0.0, 0.0))
    assert len(rs.lighting("studio", cam).emitters) == 4
    assert set(rs.lighting("sun", cam).emitters) == {"sun", "sky"}
    env = tmp_path / "sky.exr"
    mi.util.write_bitmap(str(env), np.full((8, 16, 3), 0.5, dtype=np.float32), write_async=False)
    lit = rs.lighting(str(env), cam)
    assert lit.emitters["environment"]["type"] == "envmap"
    broken = tmp_path / "broken.hdr"
    broken.write_text("not an image")
    with pytest.raises(InputError, match="not a readable environment map"):
        rs.lighting(str(broken), cam)
