"""``weavecap render`` as a user meets it: images written where asked and never clobbered, bad
meshes refused with exit 2 and nothing written, the weave at the pitch asked for, seeds that
reproduce, several fabrics into a folder with a contact sheet, --json that says what was done.

Renders are tiny (tens of pixels, a few samples) so the suite stays quick.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from weavecap import params
from weavecap.cli.main import cli
from weavecap.photo import load_photo
from weavecap.render import shapes

ROOT = Path(__file__).resolve().parents[2]
PARAMS = ROOT / "fixtures" / "params"
MESHES = ROOT / "fixtures" / "meshes"
TINY = ["--size", "48x32", "--spp", "2"]


def run(*args):
    return CliRunner().invoke(cli, ["render", *map(str, args)])


def test_help_has_examples_and_the_command_is_registered():
    result = CliRunner().invoke(cli, ["render", "--help"])
    assert result.exit_code == 0
    assert "Examples:" in result.output and "weavecap render swatch/params.json dress.obj" in result.output
    assert "render" in CliRunner().invoke(cli, ["--help"]).output


def test_renders_a_png_and_never_overwrites_without_force(tmp_path):
    out = tmp_path / "skirt.png"
    result = run(PARAMS / "twill_2_1.json", MESHES / "skirt.obj", "-o", out, *TINY)
    assert result.exit_code == 0, result.output
    image = load_photo(out).rgb
    assert image.shape == (32, 48, 3) and image.max() > 0.05
    before = out.read_bytes()
    again = run(PARAMS / "plain.json", MESHES / "skirt.obj", "-o", out, *TINY)
    assert again.exit_code == 2 and "already exists" in again.output and "--force" in again.output
    assert out.read_bytes() == before
    assert run(PARAMS / "plain.json", MESHES / "skirt.obj", "-o", out, *TINY, "--force").exit_code == 0
    assert out.read_bytes() != before


def test_a_single_render_is_a_batch_of_one_with_its_record_beside_the_image(tmp_path):
    """-o IMAGE writes IMAGE and its record IMAGE.json (as OUT/<name>/render.json of a batch);
    --force replaces both; a failed render's record is redone without --force, another params
    file's record is not."""
    from weavecap.photo import file_sha256

    out = tmp_path / "look.png"
    result = run(PARAMS / "plain.json", MESHES / "swatch.obj", "-o", out, *TINY, "--json", "-q")
    assert result.exit_code == 0, result.output
    record = json.loads((tmp_path / "look.png.json").read_text())
    assert record["status"] == "ok" and record["output"] == str(out) and record["size"] == [48, 32]
    assert record["input"] == {"path": str(PARAMS / "plain.json"), "sha256": file_sha256(PARAMS / "plain.json")}
    assert record["timings_s"]["total"] >= record["timings_s"]["mesh"] + record["timings_s"]["render"]
    line = json.loads(result.stdout)["images"][0]
    assert (line["status"], line["output"], line["spp"]) == ("ok", str(out), 2)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["look.png", "look.png.json"]

    forced = run(PARAMS / "twill_2_1.json", MESHES / "swatch.obj", "-o", out, *TINY, "--force", "-q")
    assert forced.exit_code == 0, forced.output
    assert json.loads((tmp_path / "look.png.json").read_text())["input"]["path"] == str(PARAMS / "twill_2_1.json")

    out.unlink()  # as a render that failed leaves it: its record alone
    failed = {**record, "status": "failed", "reason": "unexpected error: boom"}
    (tmp_path / "look.png.json").write_text(json.dumps(failed))
    assert run(PARAMS / "plain.json", MESHES / "swatch.obj", "-o", out, *TINY, "-q").exit_code == 0
    assert json.loads((tmp_path / "look.png.json").read_text())["status"] == "ok" and out.is_file()
    out.unlink()
    (tmp_path / "look.png.json").write_text(json.dumps(failed))
    other = run(PARAMS / "satin_5.json", MESHES / "swatch.obj", "-o", out, *TINY)
    assert other.exit_code == 2 and "holds results of another run" in other.output and not out.exists()


def test_the_same_seed_gives_the_same_image_bit_for_bit(tmp_path):
    images = []
    for name, seed in (("a.exr", 3), ("b.exr", 3), ("c.exr", 4)):
        result = run(PARAMS / "satin_5.json", MESHES / "sine_high.obj", "-o", tmp_path / name, *TINY, "--seed", seed,
                     "--pitch-mm", 2)
        assert result.exit_code == 0, result.output
        images.append(load_photo(tmp_path / name).rgb)
    assert np.array_equal(images[0], images[1]) and not np.array_equal(images[0], images[2])


@pytest.mark.parametrize("content, words", [
    ("v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "not finite"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 5\n", "out of range"),
    ("", "empty"),
    ("not a mesh at all\n", "nothing that is a mesh"),
])
def test_a_bad_mesh_exits_2_with_its_name_and_problem_and_writes_nothing(tmp_path, content, words):
    mesh = tmp_path / "bad.obj"
    mesh.write_text(content)
    out = tmp_path / "out.png"
    result = run(PARAMS / "plain.json", mesh, "-o", out, *TINY)
    assert result.exit_code == 2, result.output
    assert str(mesh) in result.output and words in result.output
    assert "Traceback" not in result.output
    assert not out.exists() and list(tmp_path.iterdir()) == [mesh]


def test_a_mesh_over_the_size_limit_exits_2(tmp_path, monkeypatch):
    from weavecap.render import mesh as rmesh

    monkeypatch.setattr(rmesh, "MAX_FACES", 100)
    result = run(PARAMS / "plain.json", MESHES / "skirt.obj", "-o", tmp_path / "x.png", *TINY)
    assert result.exit_code == 2 and "over the mesh size limit of 100" in result.output
    assert not (tmp_path / "x.png").exists()


def test_usage_errors_exit_2(tmp_path):
    out = tmp_path / "x.png"
    assert run(MESHES / "skirt.obj", "-o", out).exit_code == 2  # no params
    bad = run(PARAMS / "plain.json", MESHES / "skirt.obj", "-o", tmp_path / "x.jpg", *TINY)
    assert bad.exit_code == 2 and ".jpg" in bad.output
    for option, value, words in [("--mode", "magic", "--mode 'magic' is unknown"), ("--view", "sideways", "--view"),
                                 ("--light", "candle", "--light 'candle'"), ("--light", tmp_path / "no.exr", "not found"),
                                 ("--margin", "-1", "--margin"), ("--fold", "sometimes", "--fold")]:
        result = run(PARAMS / "plain.json", MESHES / "skirt.obj", "-o", out, *TINY, option, value)
        assert result.exit_code == 2 and words in result.output, (option, result.output)
        assert not out.exists()


def test_several_params_render_into_a_folder_with_a_contact_sheet_and_json(tmp_path):
    out = tmp_path / "looks"
    names = ("plain", "twill_3_1")
    result = run(*[PARAMS / f"{n}.json" for n in names], MESHES / "drape.obj", "-o", out, *TINY, "--sheet", "--json",
                 "-q")
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert [i["output"] for i in doc["images"]] == [str(out / n / "render.png") for n in names]
    for name, item in zip(names, doc["images"]):
        assert item["mode"] == "direct" and item["spp"] == 2 and item["pitch_source"] == "default"
        record = json.loads((out / name / "render.json").read_text())
        assert record["timings_s"]["render"] > 0 and any("pitch" in n for n in record["notes"])
        assert Path(item["output"]).is_file()
    assert doc["mesh"]["uv_source"] == "file" and doc["mesh"]["triangles"] == 2048
    assert doc["sheet"] == str(out / "sheet.png")
    sheet = load_photo(out / "sheet.png").rgb
    assert sheet.shape[1] > 2 * 48 and sheet.shape[0] > 32


def test_a_mesh_without_uvs_renders_and_says_so(tmp_path):
    shape = shapes.sine_folds(amplitude=0.01)
    text = "\n".join(line for line in shape.obj_text().splitlines() if not line.startswith("vt"))
    text = text.replace("/", " ").replace("  ", " ")
    mesh = tmp_path / "bare.obj"
    mesh.write_text("\n".join(f"f {' '.join(p.split()[1::2])}" if p.startswith("f ") else p
                              for p in text.splitlines()) + "\n")
    result = run(PARAMS / "plain.json", mesh, "-o", tmp_path / "bare.png", *TINY, "--pitch-mm", 1)
    assert result.exit_code == 0, result.output
    assert "generated UVs with xatlas" in result.output
    assert load_photo(tmp_path / "bare.png").rgb.mean() > 0.02


def _two_colour(tmp_path: Path, pitch_mm: float | None) -> Path:
    """The plain weave with a red warp and a blue weft, wide gaps, and optionally a pitch."""
    fabric = params.load(PARAMS / "plain.json").replace({
        "warp.body_reflection": [0.9, 0.1, 0.1], "warp.body_subsurface": [0.9, 0.1, 0.1],
        "weft.body_reflection": [0.1, 0.1, 0.9], "weft.body_subsurface": [0.1, 0.1, 0.9]})
    path = tmp_path / "two_colour.json"
    params.save(fabric, path)
    if pitch_mm is not None:
        doc = json.loads(path.read_text())
        doc["scale"] = {"pitch_mm": pitch_mm}
        path.write_text(json.dumps(doc))
    return path


def _warps_across(image: np.ndarray) -> int:
    """The number of red warps across the image: the strongest frequency of the red-minus-blue
    profile along x (averaged down the columns, each warp is one period)."""
    profile = (image[..., 0] - image[..., 2]).mean(axis=0)
    spectrum = np.abs(np.fft.rfft(profile - profile.mean()))
    return int(np.argmax(spectrum[1:]) + 1)


@pytest.mark.parametrize("pitch_mm, from_params", [(5.0, True), (2.5, False), (10.0, False)])
def test_the_weave_has_the_pitch_asked_for(tmp_path, pitch_mm, from_params):
    """The 20 cm swatch, framed exactly (orthographic, margin 0): 200 mm / pitch red warps cross
    the image — the pitch from the params' scale.pitch_mm or from --pitch-mm."""
    fabric = _two_colour(tmp_path, pitch_mm if from_params else 1.0)
    extra = [] if from_params else ["--pitch-mm", pitch_mm]
    out = tmp_path / "swatch.exr"
    result = run(fabric, MESHES / "swatch.obj", "-o", out, "--size", "400x400", "--spp", "4", "--camera",
                 "orthographic", "--margin", "0", "--light", "front", *extra)
    assert result.exit_code == 0, result.output
    assert _warps_across(load_photo(out).rgb) == round(200 / pitch_mm)


def test_fabric_angle_turns_the_weave(tmp_path):
    """A warp-faced weave (the red warps always on top, blue wefts seen between them) shows
    vertical stripes: the red varies across the columns, not down the rows; turned by
    --fabric-angle 90 it varies down the rows."""
    fabric = params.load(_two_colour(tmp_path, 5.0)).replace({"pattern": [[0]], "warp.radius": 3.0})
    doc = json.loads(params.dumps(fabric))
    doc["scale"] = {"pitch_mm": 5.0}
    warp_faced = tmp_path / "warp_faced.json"
    warp_faced.write_text(json.dumps(doc))
    spread = {}
    for angle in (0, 90):
        out = tmp_path / f"turned_{angle}.exr"
        result = run(warp_faced, MESHES / "swatch.obj", "-o", out, "--size", "200x200", "--spp", "4", "--camera",
                     "orthographic", "--margin", "0", "--light", "front", "--fabric-angle", angle)
        assert result.exit_code == 0, result.output
        red = load_photo(out).rgb[..., 0]
        spread[angle] = (red.mean(axis=0).std(), red.mean(axis=1).std())  # across columns, down rows
    assert spread[0][0] > 5 * spread[0][1]
    assert spread[90][1] > 5 * spread[90][0]


def test_pattern_replaces_the_params_pattern(tmp_path):
    """--pattern draft: the weave drawn is the file's (a weft-faced [[1]] shows only the weft's
    blue where the plain weave showed red warps too)."""
    fabric = _two_colour(tmp_path, 5.0)
    pattern = tmp_path / "weft_faced.txt"
    pattern.write_text("1\n")
    reds = {}
    for name, extra in (("plain", []), ("weft", ["--pattern", pattern])):
        out = tmp_path / f"{name}.exr"
        result = run(fabric, MESHES / "swatch.obj", "-o", out, "--size", "64x64", "--spp", "4", "--camera",
                     "orthographic", "--margin", "0", "--light", "front", *extra)
        assert result.exit_code == 0, result.output
        image = load_photo(out).rgb
        reds[name] = float((image[..., 0] - image[..., 2]).mean())
    assert reds["plain"] > reds["weft"] + 0.01


def test_fabric_offset_shifts_the_weave(tmp_path):
    """--fabric-offset 0.25,0 moves a plain weave by half a yarn: the warps' profile across the
    image turns into its opposite (correlation < -0.5)."""
    fabric = _two_colour(tmp_path, 5.0)
    profiles = []
    for offset in ("0,0", "0.25,0"):
        out = tmp_path / f"offset_{offset}.exr"
        result = run(fabric, MESHES / "swatch.obj", "-o", out, "--size", "200x200", "--spp", "4", "--camera",
                     "orthographic", "--margin", "0", "--light", "front", "--fabric-offset", offset)
        assert result.exit_code == 0, result.output
        image = load_photo(out).rgb
        profile = (image[..., 0] - image[..., 2]).mean(axis=0)
        profiles.append(profile - profile.mean())
    assert np.corrcoef(*profiles)[0, 1] < -0.5


def test_environment_map_ground_top_view_and_direct_mode(tmp_path):
    """An .exr environment, a floor, the top view, direct lighting: it renders, and the floor
    shows around the drape (it would be the environment's colour without it)."""
    from weavecap.backend import mitsuba

    mi = mitsuba()
    env = tmp_path / "sky.exr"
    mi.util.write_bitmap(str(env), np.full((16, 32, 3), (0.2, 0.3, 0.9), dtype=np.float32), write_async=False)
    images = {}
    for name, extra in (("bare", []), ("floor", ["--ground"])):
        out = tmp_path / f"{name}.exr"
        result = run(PARAMS / "plain.json", MESHES / "drape.obj", "-o", out, "--size", "48x48", "--spp", "8",
                     "--light", env, "--view", "top", "--mode", "direct", "--margin", "0.5", *extra)
        assert result.exit_code == 0, result.output
        images[name] = load_photo(out).rgb
    corner_bare, corner_floor = images["bare"][1, 1], images["floor"][1, 1]
    np.testing.assert_allclose(corner_bare, (0.2, 0.3, 0.9), rtol=0.02)  # the environment seen directly
    assert corner_floor[2] < 0.5 * corner_bare[2]  # a grey floor, lit by a blue sky, is not the sky
