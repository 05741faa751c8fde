"""The exported material, baked from the surface model: seamless maps, the files' checkers,
and plain Mitsuba's principled BSDF with the maps against weavecap's own surface BSDF."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from export_checks import OWN_U3M_SCHEMA, PUBLISHED_U3M_SCHEMA, gltf_validator, read_png, validate_gltf, validator_for

from weavecap import params
from weavecap.cli.main import cli
from weavecap.export import mitsuba
from weavecap.export.material import pbr_maps
from weavecap.photo import linear_to_srgb, load_photo

ROOT = Path(__file__).resolve().parents[2]
FIXTURE = ROOT / "fixtures" / "params"
PITCH_MM = 0.4
T = 8  # texels per yarn in these tests


def run(*args):
    return CliRunner().invoke(cli, ["export", *map(str, args)], catch_exceptions=False)


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    """Every format of the 2/1 twill, 8 texels a yarn, a 6 mm swatch."""
    out = tmp_path_factory.mktemp("export")
    result = run(FIXTURE / "twill_2_1.json", "-o", out, "--pitch-mm", PITCH_MM, "--texels-per-yarn", T,
                 "--swatch-mm", 6, "--json", "-q")
    assert result.exit_code == 0, result.output
    return out, [Path(p) for p in json.loads(result.output)["files"]]


def test_every_format_is_written(exported):
    out, files = exported
    assert all(p.is_file() for p in files)
    names = {p.relative_to(out).as_posix() for p in files}
    for expected in ("twill_2_1.wif", "twill_2_1.glb", "pbr/twill_2_1_base_color.png", "pbr/twill_2_1_material.json",
                     "u3m/twill_2_1.u3m", "u3m/textures/twill_2_1_preview.png", "mitsuba/twill_2_1.xml",
                     "mitsuba/twill_2_1_weavecap.xml", "mitsuba/twill_2_1.json"):
        assert expected in names
    doc = json.loads((out / "pbr" / "twill_2_1_material.json").read_text())
    assert doc["size_mm"] == [pytest.approx(3 * PITCH_MM)] * 2 and doc["texels"] == [3 * T, 3 * T]
    assert 0 < doc["height_mm"] < 3 * PITCH_MM


def _seams(image: np.ndarray, t: int) -> tuple[float, float, float, float]:
    """Mean jump across the tile's vertical and horizontal seams, and the largest mean jump
    across the yarn boundaries inside the tile (columns / rows at multiples of t)."""
    a = image.reshape(image.shape[0], image.shape[1], -1).astype(np.float64)
    seam_x = np.abs(a[:, 0] - a[:, -1]).mean()
    seam_y = np.abs(a[0] - a[-1]).mean()
    inner_x = max(np.abs(a[:, k] - a[:, k - 1]).mean() for k in range(t, a.shape[1], t))
    inner_y = max(np.abs(a[k] - a[k - 1]).mean() for k in range(t, a.shape[0], t))
    return seam_x, inner_x, seam_y, inner_y


@pytest.mark.parametrize("key", ["base_color", "transmission", "normal", "roughness", "opacity", "height"])
def test_every_map_tiles_without_seams(exported, key):
    """Opposite edges continue each other: the jump across a seam is no larger than across
    the yarn boundaries inside the tile (the seams are yarn boundaries too). The base colour and
    transmission are Monte-Carlo fits: over seeds 0-3 their seam jump came out up to 1.17x the
    largest inner one (a seam off by a texel, or an unwrapped filter, gives 2x and more)."""
    out, _ = exported
    image = read_png(out / "pbr" / f"twill_2_1_{key}.png")
    seam_x, inner_x, seam_y, inner_y = _seams(image, T)
    margin = 1.3 if key in ("base_color", "transmission") else 1.1
    assert seam_x <= margin * inner_x + 1e-3 and seam_y <= margin * inner_y + 1e-3, (seam_x, inner_x, seam_y, inner_y)


def test_the_tile_is_one_period_of_the_fabric():
    """A fabric of the same weave drawn twice across bakes to the one-repeat maps side by side:
    the tile's right edge continues into its left."""
    fabric = params.load(FIXTURE / "twill_2_1.json")
    wide = fabric.replace({"pattern": np.tile(fabric.pattern, (1, 2))})
    one = pbr_maps(fabric, pitch_mm=PITCH_MM, texels_per_yarn=T)
    two = pbr_maps(wide, pitch_mm=PITCH_MM, texels_per_yarn=T)
    for key in ("normal", "opacity"):
        np.testing.assert_allclose(getattr(two, key), np.tile(getattr(one, key), (1, 2, 1)[: getattr(one, key).ndim]),
                                   atol=1e-4)
    # the base colour is a Monte-Carlo fit: the same up to its sampling noise
    assert np.abs(two.base_color - np.tile(one.base_color, (1, 2, 1))).mean() < 0.01


def test_repeats_tile_the_maps(tmp_path):
    fabric = params.load(FIXTURE / "plain.json")
    one = pbr_maps(fabric, pitch_mm=PITCH_MM, texels_per_yarn=T)
    three = pbr_maps(fabric, pitch_mm=PITCH_MM, texels_per_yarn=T, repeats=3)
    np.testing.assert_array_equal(three.base_color, np.tile(one.base_color, (3, 3, 1)))
    assert three.size_mm == pytest.approx((6 * PITCH_MM, 6 * PITCH_MM))


def test_the_exported_u3m_validates(exported):
    out, _ = exported
    doc = json.loads((out / "u3m" / "twill_2_1.u3m").read_text())
    errors = list(validator_for(OWN_U3M_SCHEMA).iter_errors(doc))
    assert not errors, errors[0].message
    front = doc["material"]["front"]
    for key in ("basecolor", "normal", "roughness", "alpha", "displacement"):
        assert (out / "u3m" / front[key]["texture"]["image"]["path"]).is_file()
    assert (out / "u3m" / front["preview"]["path"]).is_file()


def test_the_exported_u3m_passes_the_published_schema(exported, shared):
    schema = shared(*PUBLISHED_U3M_SCHEMA)
    doc = json.loads((exported[0] / "u3m" / "twill_2_1.u3m").read_text())
    errors = list(validator_for(schema).iter_errors(doc))
    assert not errors, errors[0].message


def test_the_exported_gltf_passes_the_khronos_validator(exported):
    module = gltf_validator()
    if module is None:
        pytest.skip("node/npm absent or gltf-validator not installable")
    out, _ = exported
    report = validate_gltf(module, out / "twill_2_1.glb")
    assert report["issues"]["numErrors"] == 0, report["issues"]["messages"]


def _mean_lab(image: np.ndarray) -> np.ndarray:
    from skimage.color import rgb2lab

    h, w = image.shape[:2]
    mean = image[h // 8: -h // 8, w // 8: -w // 8].reshape(-1, 3).mean(axis=0)
    return rgb2lab(np.clip(linear_to_srgb(mean), 0.0, 1.0)[None, None])[0, 0]


@pytest.mark.parametrize("name", ["plain", "satin_5", "custom_4x6"])
def test_plain_mitsuba_with_the_maps_looks_like_the_surface_model_from_afar(tmp_path, name):
    """The exported scenes: the maps on plain Mitsuba's principled BSDF against weavecap's
    surface BSDF and path tracer (the reference renderer), a swatch of 20 × 20 tiles at about
    a yarn a pixel, sky and sun: mean colour CIEDE2000 ≤ 1.5 (the issue asks ≤ 3; measured
    0.5–0.9 by scripts/measure_export.py, docs/export.md)."""
    from skimage.color import deltaE_ciede2000

    fabric = params.load(FIXTURE / f"{name}.json")
    tile_mm = fabric.shape[1] * PITCH_MM
    result = run(FIXTURE / f"{name}.json", "-o", tmp_path, "--format", "mitsuba", "--pitch-mm", PITCH_MM,
                 "--swatch-mm", 20 * tile_mm, "-q")
    assert result.exit_code == 0, result.output
    folder = tmp_path / "mitsuba"
    plain = mitsuba.render_scene(folder / f"{name}.xml", spp=32, resx=96, resy=96)
    reference = mitsuba.render_scene(folder / f"{name}_weavecap.xml", spp=32, resx=96, resy=96)
    assert plain.shape == (96, 96, 3)
    assert deltaE_ciede2000(_mean_lab(plain), _mean_lab(reference)) <= 1.5


def test_the_weavecap_scene_reads_its_params_beside_it(exported):
    out, _ = exported
    scene = mitsuba.load_scene(out / "mitsuba" / "twill_2_1_weavecap.xml")
    bsdfs = [str(shape.bsdf()) for shape in scene.shapes()]
    assert any(b.startswith("SurfaceBSDF[3x3 repeat") for b in bsdfs), bsdfs


def test_map_formats_need_a_pitch_and_nothing_is_written_without_one(tmp_path):
    result = run(FIXTURE / "plain.json", "-o", tmp_path / "out", "--format", "wif,pbr")
    assert result.exit_code == 2 and "scale.pitch_mm" in result.output and "--pitch-mm" in result.output
    assert not (tmp_path / "out").exists()


def test_the_params_pitch_is_used_and_an_existing_texture_blocks_everything(tmp_path):
    fabric = dataclasses.replace(params.load(FIXTURE / "plain.json"), scale={"pitch_mm": 0.25})
    params.save(fabric, tmp_path / "plain.json")
    out = tmp_path / "out"
    (out / "u3m" / "textures").mkdir(parents=True)
    (out / "u3m" / "textures" / "plain_normal.png").write_bytes(b"mine")
    result = run(tmp_path / "plain.json", "-o", out, "--format", "pbr,u3m", "--texels-per-yarn", 4)
    assert result.exit_code == 2 and "plain_normal.png" in result.output
    assert not (out / "pbr").exists() and (out / "u3m" / "textures" / "plain_normal.png").read_bytes() == b"mine"
    assert run(tmp_path / "plain.json", "-o", out, "--format", "pbr,u3m", "--texels-per-yarn", 4, "--force",
               "-q").exit_code == 0
    doc = json.loads((out / "pbr" / "plain_material.json").read_text())
    assert doc["size_mm"] == [0.5, 0.5]


def test_16_bit_exr_and_directx_options_reach_the_files(tmp_path):
    out = tmp_path / "out"
    assert run(FIXTURE / "plain.json", "-o", out, "--format", "pbr", "--pitch-mm", 0.3, "--texels-per-yarn", 4,
               "--maps", "exr", "--normal-convention", "directx", "-q").exit_code == 0
    normal = load_photo(out / "pbr" / "plain_normal.exr").rgb * 2.0 - 1.0
    maps = pbr_maps(params.load(FIXTURE / "plain.json"), pitch_mm=0.3, texels_per_yarn=4)
    np.testing.assert_allclose(normal, maps.normal * np.array([1.0, -1.0, 1.0]), atol=1e-5)


@pytest.mark.parametrize("edit", [
    {"specular.roughness": 0.0, "specular.ior": 1.0},  # a mirror lobe with no Fresnel reflection
    {"specular.roughness": 1.0, "specular.ior": 3.0, "specular.reflection": [1.0, 1.0, 1.0]},
    {"warp.body_reflection": [0.0, 0.0, 0.0], "weft.body_reflection": [0.0, 0.0, 0.0]},
    {"warp.body_reflection": [1.0, 1.0, 1.0], "weft.body_reflection": [1.0, 1.0, 1.0], "specular.coefficient": 1.0},
], ids=["roughness-0-ior-1", "roughness-1-ior-3", "black", "white"])
def test_hard_materials_give_finite_maps_in_range(edit):
    fabric = params.load(FIXTURE / "plain.json").replace(edit)
    maps = pbr_maps(fabric, pitch_mm=PITCH_MM, texels_per_yarn=4)
    for key in ("base_color", "normal", "roughness", "opacity", "height"):
        value = getattr(maps, key)
        assert np.isfinite(value).all(), key
    assert 0.0 <= maps.base_color.min() and maps.base_color.max() <= 1.0
    assert 0.0 <= maps.roughness.min() and maps.roughness.max() <= 1.0
    assert np.isfinite(maps.height_mm) and maps.height_mm > 0 and 0.0 <= maps.specular_level <= 1.0


def test_base_colour_follows_the_body_colour():
    """Black yarns give a near-black base colour, white ones a light one, and the warp's and
    the weft's colours land on the warps and the wefts (all light reflected by the body: m_r 1)."""
    fabric = params.load(FIXTURE / "plain.json").replace({"specular.coefficient": 1.0})
    black = pbr_maps(fabric.replace({"warp.body_reflection": [0.0, 0.0, 0.0], "weft.body_reflection": [0.0, 0.0, 0.0]}),
                     pitch_mm=PITCH_MM, texels_per_yarn=8)
    white = pbr_maps(fabric.replace({"warp.body_reflection": [1.0, 1.0, 1.0], "weft.body_reflection": [1.0, 1.0, 1.0]}),
                     pitch_mm=PITCH_MM, texels_per_yarn=8)
    assert black.base_color.mean() < 0.05 < 0.3 < white.base_color.mean()
    red_warp = fabric.replace({"warp.body_reflection": [0.9, 0.05, 0.05], "weft.body_reflection": [0.05, 0.05, 0.9]})
    maps = pbr_maps(red_warp, pitch_mm=PITCH_MM, texels_per_yarn=8)
    from weavecap.render.surface import bake

    on_top = bake(red_warp, texels_per_yarn=8).yarn_id(0)  # 1 warp, 2 weft
    warp_rgb, weft_rgb = maps.base_color[on_top == 1].mean(axis=0), maps.base_color[on_top == 2].mean(axis=0)
    assert warp_rgb[0] > 3 * warp_rgb[2] and weft_rgb[2] > 3 * weft_rgb[0]


def test_the_same_seed_gives_the_same_files(tmp_path):
    args = (FIXTURE / "twill_2_1.json", "--format", "pbr,u3m,gltf", "--pitch-mm", PITCH_MM, "--texels-per-yarn", 4,
            "-q")
    assert run(args[0], "-o", tmp_path / "a", *args[1:]).exit_code == 0
    assert run(args[0], "-o", tmp_path / "b", *args[1:]).exit_code == 0
    assert run(args[0], "-o", tmp_path / "c", *args[1:], "--seed", "7").exit_code == 0
    files = sorted(p.relative_to(tmp_path / "a") for p in (tmp_path / "a").rglob("*") if p.is_file())
    assert files and all((tmp_path / "a" / f).read_bytes() == (tmp_path / "b" / f).read_bytes() for f in files)
    base = "pbr/twill_2_1_base_color.png"
    assert (tmp_path / "a" / base).read_bytes() != (tmp_path / "c" / base).read_bytes()


@pytest.fixture
def maps_mode():
    """Registers (and afterwards removes) a render mode with the exported maps of a fabric."""
    from weavecap.render import modes

    registered = []

    def register(fabric, folder: Path):
        maps = pbr_maps(fabric, pitch_mm=PITCH_MM)
        textures = {key: str(folder / f"{key}.png") for key in mitsuba.TEXTURES}
        mitsuba.write_textures(maps, folder, textures)
        mode = mitsuba.maps_mode(maps, textures)
        modes.register_mode(mode)
        registered.append(mode.name)
        return mode.name

    yield register
    for name in registered:
        modes.MODES.pop(name, None)


def test_the_maps_in_plain_mitsuba_look_like_weavecap_render_reference(tmp_path, maps_mode):
    """The issue's test: ``weavecap render --mode reference`` of the flat swatch mesh (20 cm,
    about four yarns a pixel) under its default studio light, against the same scene with the
    exported maps on plain Mitsuba's BSDFs and ``path``: mean colour CIEDE2000 ≤ 2.5 (the issue
    asks ≤ 3; measured 1.6 on this fabric, docs/export.md)."""
    from skimage.color import deltaE_ciede2000

    from weavecap.fixtures import path as fixture_path
    from weavecap.render.mesh import load_mesh
    from weavecap.render.run import RenderOptions, render_fabric

    fabric = params.load(FIXTURE / "twill_3_1.json")
    exported = maps_mode(fabric, tmp_path)
    mesh = load_mesh(fixture_path("meshes", "swatch.obj"))
    images = [render_fabric(fabric, mesh, RenderOptions(mode=m, light="studio", size=(96, 96), spp=32, margin=0.0,
                                                        pitch_mm=PITCH_MM, noise=False)).image
              for m in ("reference", exported)]
    assert deltaE_ciede2000(_mean_lab(images[1]), _mean_lab(images[0])) <= 2.5


def _colour_class(rgb) -> str:
    """The check fixture's three yarn colours told apart by chroma: red, navy or white."""
    r, _, b = rgb
    return "red" if r > 2 * b else "navy" if b > 2 * r else "white"


def test_the_maps_of_a_yarn_dyed_fabric_cover_its_colour_repeat_thread_by_thread():
    """The check (plain weave; 6-end and 7-pick colour orders of white, navy and red): its tile
    spans the fabric's whole repeat, 14 picks × 6 ends, and the base colour at every cell's
    centre is the colour of the thread on top there, as the forward model counts the threads."""
    fabric = params.load(FIXTURE / "check_plain.json")
    maps = pbr_maps(fabric, pitch_mm=PITCH_MM, texels_per_yarn=T)
    assert maps.shape == (14 * T, 6 * T) and maps.repeats == (7, 3)
    assert maps.size_mm == pytest.approx((6 * PITCH_MM, 14 * PITCH_MM))
    names = {entry.body_reflection: _colour_class(entry.body_reflection) for entry in fabric.threads.warp.palette}
    for i in range(14):
        for j in range(6):
            weft = fabric.pattern[i % 2, j % 2] == 1
            order = fabric.threads.weft if weft else fabric.threads.warp
            want = names[order.palette[order.sequence[(i if weft else j) % order.repeat]].body_reflection]
            assert _colour_class(maps.base_color[i * T + T // 2, j * T + T // 2]) == want, (i, j)
