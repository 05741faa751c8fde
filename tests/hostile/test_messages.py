"""Promise: a message says what is wrong and what to do, truthfully — never the wrong field, a
file "missing" that exists, a library the user never asked for, or "another run" for the
same one."""

from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image

from .conftest import PLAIN, SWATCH, noise_photo, params_with, weavecap


def test_a_missing_object_field_says_an_object_is_expected(sandbox):
    """A missing ``warp`` was "allowed: a number"."""
    path = params_with(sandbox / "in", "p.json", warp=None)
    result = weavecap("synth", path, "-o", sandbox / "x.png")
    assert result.exit_code == 2
    assert "warp: missing required field (allowed: an object with radius, body_reflection, body_subsurface)" \
        in result.output


def test_a_device_as_a_texture_is_not_called_missing(sandbox):
    """/dev/zero as a texture "does not exist" (it does; it is no file)."""
    path = params_with(sandbox / "in", "p.json", weft__body_reflection="/dev/zero")
    result = weavecap("synth", path, "-o", sandbox / "x.png")
    assert result.exit_code == 2 and "weft.body_reflection: texture '/dev/zero' is not a regular file" in result.output


@pytest.mark.parametrize("fmt, suffix", [("GIF", ".gif"), ("WEBP", ".webp"), ("WEBP", ".png"), ("BMP", ".bmp")])
def test_an_image_of_another_format_is_named(sandbox, fmt, suffix):
    """GIF and WebP photos were "not an image" (a WebP even "corrupt RAW data")."""
    path = sandbox / "in" / f"photo{suffix}"
    Image.fromarray(np.zeros((16, 16, 3), np.uint8)).save(path, format=fmt)
    result = weavecap("fit", path, "-o", sandbox / "out", "-q")
    assert result.exit_code == 3
    assert f"is a {fmt} image, which weavecap does not read; convert it to PNG, TIFF or JPEG" in result.output


def test_a_device_as_a_photo_is_rejected_at_once(sandbox):
    """Reading /dev/zero would never end."""
    result = weavecap("fit", "/dev/zero", "-o", sandbox / "out", "-q")
    assert result.exit_code == 3 and "/dev/zero: is not a regular file" in result.output


def test_a_garbage_obj_blames_the_file_not_a_python_package(sandbox):
    """trimesh's error named a missing ``charset_normalizer``."""
    path = sandbox / "in" / "garbage.obj"
    path.write_bytes(np.random.default_rng(0).integers(0, 256, 3000, dtype=np.uint8).tobytes())
    result = weavecap("render", PLAIN, path, "-o", sandbox / "x.png")
    assert result.exit_code == 2
    assert "not a readable OBJ mesh: an OBJ file is text, this one holds binary data" in result.output
    assert "charset_normalizer" not in result.output


def test_a_folder_given_as_a_mesh_or_params_file_is_called_a_folder(sandbox):
    result = weavecap("render", PLAIN, sandbox / "in", "-o", sandbox / "x.png")
    assert result.exit_code == 2 and "is a folder; give the path of an OBJ or PLY mesh file" in result.output
    result = weavecap("render", sandbox / "in", SWATCH, "-o", sandbox / "x.png")
    assert result.exit_code == 2 and "is a folder; give the path of a params.json file" in result.output


def test_the_same_photo_again_is_already_done_and_another_photo_is_named(sandbox):
    """A finished photo's folder "holds results of another run" when the same photo was run
    again; now it is skipped as a batch's would be, and a different photo's refusal names
    the photo whose results are there."""
    photo = noise_photo(sandbox / "in" / "a.png")
    out = sandbox / "out"
    assert weavecap("fit", photo, "-o", out, "-q").exit_code == 3
    again = weavecap("fit", photo, "-o", out)
    assert again.exit_code == 3 and "already done (rejected), skipped; --force redoes it" in again.output
    other = weavecap("fit", noise_photo(sandbox / "in" / "b.png", seed=1), "-o", out)
    assert other.exit_code == 2
    assert f"its report.json is of {str(photo)!r}, a different file" in other.output and "--force" in other.output
    assert json.loads((out / "report.json").read_text())["input"]["path"] == str(photo)
