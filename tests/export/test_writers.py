"""The format writers on a material with known values: what each file stores, and that the
formats' own checkers accept them (U3M schema, Khronos glTF validator, Mitsuba's loader)."""

from __future__ import annotations

import json
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
import pytest
from export_checks import OWN_U3M_SCHEMA, PUBLISHED_U3M_SCHEMA, gltf_validator, read_png, validate_gltf, validator_for

from weavecap.export import gltf, mitsuba, pbr, u3m
from weavecap.export.maps import PbrMaps, map_image
from weavecap.photo import load_photo, srgb_to_linear

H, W = 24, 36


@pytest.fixture(scope="module")
def known() -> PbrMaps:
    """A material whose every value is known: a colour ramp, normals tilted by a known angle
    (towards +y, up the image, on the top half; towards +x below), a roughness ramp, half the
    texels open (opacity 0.25) and a height ramp."""
    rows, cols = np.mgrid[0:H, 0:W]
    base = np.stack([cols / (W - 1), rows / (H - 1), np.full((H, W), 0.3)], axis=-1)
    tilt = np.radians(30.0)
    normal = np.zeros((H, W, 3))
    normal[: H // 2] = (0.0, np.sin(tilt), np.cos(tilt))
    normal[H // 2:] = (np.sin(tilt), 0.0, np.cos(tilt))
    transmission = np.stack([0.3 * cols / (W - 1), np.full((H, W), 0.1), 0.05 * rows / (H - 1)], axis=-1)
    return PbrMaps(base_color=base.astype(np.float32), transmission=transmission.astype(np.float32),
                   translucent_base=np.clip(base * 1.1, 0.0, 1.0).astype(np.float32), normal=normal.astype(np.float32),
                   roughness=(0.2 + 0.6 * cols / (W - 1)).astype(np.float32),
                   opacity=np.where((rows + cols) % 2 == 0, 1.0, 0.25).astype(np.float32),
                   height=(rows / (H - 1)).astype(np.float32), height_mm=0.25, size_mm=(1.8, 1.2), repeats=(1, 1),
                   ior=1.5)


@pytest.mark.parametrize("convention, sign", [("opengl", 1.0), ("directx", -1.0)])
def test_pbr_pngs_store_the_maps(tmp_path, known, convention, sign):
    files = pbr.save_pbr(known, tmp_path, name="f", bits=16, normal_convention=convention)
    assert [p.name for p in files] == ["f_base_color.png", "f_transmission.png", "f_normal.png", "f_roughness.png",
                                       "f_opacity.png", "f_height.png", "f_material.json"]
    np.testing.assert_allclose(load_photo(tmp_path / "f_base_color.png").rgb, known.base_color, atol=2e-4)
    decoded = read_png(tmp_path / "f_normal.png") * 2.0 - 1.0
    expected = known.normal * np.array([1.0, sign, 1.0])
    np.testing.assert_allclose(decoded, expected, atol=1e-4)
    for key in ("roughness", "opacity", "height"):
        stored = read_png(tmp_path / f"f_{key}.png")
        stored = stored[..., 0] if stored.ndim == 3 else stored
        np.testing.assert_allclose(stored, getattr(known, key), atol=1e-4)
    doc = json.loads((tmp_path / "f_material.json").read_text())
    assert doc["size_mm"] == [1.8, 1.2] and doc["height_mm"] == 0.25 and doc["texels"] == [W, H]
    assert doc["maps"]["normal"]["convention"] == convention


def test_pbr_8_bit_base_colour_is_srgb_and_exr_is_linear(tmp_path, known):
    pbr.save_pbr(known, tmp_path / "png", name="f", bits=8)
    codes = read_png(tmp_path / "png" / "f_base_color.png")
    np.testing.assert_allclose(srgb_to_linear(codes), known.base_color, atol=0.01)
    pbr.save_pbr(known, tmp_path / "exr", name="f", fmt="exr")
    np.testing.assert_allclose(load_photo(tmp_path / "exr" / "f_base_color.exr").rgb, known.base_color, atol=1e-6)
    np.testing.assert_allclose(load_photo(tmp_path / "exr" / "f_roughness.exr").rgb[..., 0], known.roughness,
                               atol=1e-6)


def _u3m(tmp_path: Path, known: PbrMaps) -> tuple[Path, dict]:
    preview = np.full((32, 48, 3), 0.4, np.float32)
    files = u3m.save_u3m(known, tmp_path, name="twill", description="a test", material_key=b"key",
                         created=datetime(2025, 1, 2, 3, 4, 5, tzinfo=timezone.utc), preview=preview, bits=16)
    doc = json.loads(files[-1].read_text())
    return files[-1], doc


def test_u3m_passes_its_schema_and_its_files_agree_with_it(tmp_path, known):
    path, doc = _u3m(tmp_path, known)
    errors = list(validator_for(OWN_U3M_SCHEMA).iter_errors(doc))
    assert not errors, errors[0].message
    front = doc["material"]["front"]
    for key in ("alpha", "roughness", "displacement"):
        image = front[key]["texture"]["image"]
        pixels = read_png(path.parent / image["path"])
        # U3M: the dpi must agree with the image's pixels over its width and height in mm
        assert image["dpi"]["x"] == pytest.approx(pixels.shape[1] / (image["width"] / 25.4))
        assert image["dpi"]["y"] == pytest.approx(pixels.shape[0] / (image["height"] / 25.4))
        assert (image["width"], image["height"]) == pytest.approx(known.size_mm)
        # the constant (for software that reads no textures) is the texture's mean after factor
        texture = front[key]["texture"]
        value = texture["offset"] + pixels.mean() * texture["factor"]
        assert front[key]["constant"] == pytest.approx(value, abs=1e-3)
    assert front["displacement"]["texture"]["factor"] == pytest.approx(known.height_mm)
    assert front["ior"]["constant"] == 1.5 and front["specular_value"]["constant"] == pytest.approx(0.04 / 0.08)
    preview = front["preview"]
    assert preview["dpi"]["x"] == pytest.approx(48 / (preview["width"] / 25.4))
    assert doc["material"]["created"] == "2025-01-02T03:04:05Z"


def test_u3m_id_is_a_uuid4_that_depends_only_on_the_key():
    a, b, c = u3m.material_id(b"one"), u3m.material_id(b"one"), u3m.material_id(b"two")
    assert a == b != c and a[14] == "4" and a[19] in "89ab"


def test_u3m_passes_the_published_schema(tmp_path, known, shared):
    schema = shared(*PUBLISHED_U3M_SCHEMA)
    _, doc = _u3m(tmp_path, known)
    errors = list(validator_for(schema).iter_errors(doc))
    assert not errors, errors[0].message


def test_the_own_u3m_schema_refuses_what_the_specification_forbids(tmp_path, known):
    _, doc = _u3m(tmp_path, known)
    check = validator_for(OWN_U3M_SCHEMA)
    bad_path = json.loads(json.dumps(doc))
    bad_path["material"]["front"]["roughness"]["texture"]["image"]["path"] = "../elsewhere/r.png"
    no_visual = json.loads(json.dumps(doc))
    no_visual["material"]["front"] = None
    bad_id = json.loads(json.dumps(doc))
    bad_id["material"]["id"] = "not-a-uuid"
    for broken in (bad_path, no_visual, bad_id):
        assert list(check.iter_errors(broken))


def test_gltf_swatch_passes_the_khronos_validator(tmp_path, known):
    module = gltf_validator()
    if module is None:
        pytest.skip("node/npm absent or gltf-validator not installable")
    path = gltf.save_gltf(known, tmp_path / "swatch.glb", name="twill", swatch_mm=18.0)
    report = validate_gltf(module, path)
    assert report["issues"]["numErrors"] == 0, report["issues"]["messages"]
    assert report["issues"]["numWarnings"] == 0, report["issues"]["messages"]
    assert report["info"]["extensionsRequired"] == ["KHR_texture_transform"]


def test_gltf_swatch_tiles_the_material_over_its_physical_size(tmp_path, known):
    import pygltflib

    path = gltf.save_gltf(known, tmp_path / "swatch.glb", name="twill", swatch_mm=18.0)
    doc = pygltflib.GLTF2().load(str(path))
    scale = doc.materials[0].pbrMetallicRoughness.baseColorTexture.extensions["KHR_texture_transform"]["scale"]
    assert scale == [10.0, 15.0]  # 18 mm over tiles of 1.8 × 1.2 mm
    assert doc.extras["swatch_mm"] == [18.0, 18.0]
    pos = doc.accessors[0]
    assert pos.max[0] - pos.min[0] == pytest.approx(0.018)  # metres
    assert doc.extensionsUsed == ["KHR_texture_transform", "KHR_materials_ior", "KHR_materials_specular"]
    assert doc.materials[0].extensions["KHR_materials_ior"] == {"ior": 1.5}


def _mitsuba_textures(folder: Path, maps: PbrMaps) -> dict[str, str]:
    textures = {key: str(folder / f"{key}.png") for key in mitsuba.TEXTURES}
    mitsuba.write_textures(maps, folder, textures)
    return textures


def test_mitsuba_xml_renders_like_its_dictionary(tmp_path, known):
    textures = _mitsuba_textures(tmp_path, known)
    scene = mitsuba.swatch_scene(known, textures, swatch_mm=18.0, size=(24, 24), spp=8)
    xml = mitsuba.save_scene(scene, tmp_path / "scene.xml")
    np.testing.assert_array_equal(mitsuba.render_scene(xml), mitsuba.render_scene(scene))


def test_mitsuba_normal_map_is_opengl(tmp_path):
    """Normals tilted up the image catch a light from the top of the image more than one from
    the bottom (and the DirectX file, read as OpenGL, does the opposite)."""
    tilt = np.radians(35.0)
    maps = PbrMaps(base_color=np.full((8, 8, 3), 0.5, np.float32), transmission=np.zeros((8, 8, 3), np.float32),
                   translucent_base=np.full((8, 8, 3), 0.5, np.float32),
                   normal=np.broadcast_to(np.array([0.0, np.sin(tilt), np.cos(tilt)], np.float32), (8, 8, 3)).copy(),
                   roughness=np.full((8, 8), 0.9, np.float32), opacity=np.ones((8, 8), np.float32),
                   height=np.zeros((8, 8), np.float32), height_mm=0.1, size_mm=(1.0, 1.0), repeats=(1, 1), ior=1.5)
    textures = _mitsuba_textures(tmp_path, maps)

    def lit_from(direction):
        sun = {"sun": {"type": "directional", "direction": direction, "irradiance": {"type": "rgb", "value": 1.0}}}
        return mitsuba.render_scene(mitsuba.swatch_scene(maps, textures, swatch_mm=4.0, size=(16, 16), spp=4,
                                                         lights=sun)).mean()

    top, bottom = lit_from([0.0, -1.0, -1.0]), lit_from([0.0, 1.0, -1.0])
    assert top > 2.0 * bottom


def test_the_transmission_splits_into_a_weight_and_a_colour(known):
    weight, colour = map_image(known, "transmission_weight"), map_image(known, "transmission_color")
    np.testing.assert_allclose(weight[..., None] * colour, known.transmission, atol=1e-6)
    assert colour.max() <= 1.0 and np.allclose(colour.max(axis=-1)[weight > 0], 1.0)


def test_mitsuba_scene_lets_the_yarns_transmission_through(tmp_path):
    """Lit only from behind, an opaque swatch (no gaps) of transmission T and no reflection
    shows T · E cos θ / π towards the camera (the blend's diffuse transmission)."""
    t = np.array([0.3, 0.2, 0.1], np.float32)
    maps = PbrMaps(base_color=np.zeros((8, 8, 3), np.float32), transmission=np.broadcast_to(t, (8, 8, 3)).copy(),
                   translucent_base=np.zeros((8, 8, 3), np.float32),
                   normal=np.broadcast_to(np.array([0.0, 0.0, 1.0], np.float32), (8, 8, 3)).copy(),
                   roughness=np.full((8, 8), 0.5, np.float32), opacity=np.ones((8, 8), np.float32),
                   height=np.zeros((8, 8), np.float32), height_mm=0.1, size_mm=(1.0, 1.0), repeats=(1, 1), ior=1.0)
    textures = _mitsuba_textures(tmp_path, maps)
    back = {"sun": {"type": "directional", "direction": [0.0, 0.0, 1.0], "irradiance": {"type": "rgb", "value": 2.0}}}
    image = mitsuba.render_scene(mitsuba.swatch_scene(maps, textures, swatch_mm=4.0, size=(16, 16), spp=16,
                                                      lights=back))
    np.testing.assert_allclose(image[4:12, 4:12].reshape(-1, 3).mean(axis=0), t * 2.0 / np.pi, rtol=0.02)
