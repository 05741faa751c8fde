"""Promise: the readers refuse what cannot be rendered. A params file, a mesh or a WIF draft
that would give NaN images, overflow, or a silently different fabric is refused (exit 2)
naming the file, the field and the allowed range — while everything weavecap itself writes
stays valid."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from weavecap import params, wif
from weavecap.errors import InputError, ParamsError
from weavecap.noise import fit_noise
from weavecap.render import mesh as wmesh

from .conftest import PLAIN, files_under, params_with, weavecap


def gaussian(weight=0.01, mean=(0.0, 0.0), cov=((0.01, 0.0), (0.0, 0.01))) -> dict:
    return {"weight": weight, "mean": list(mean), "cov": [list(row) for row in cov]}


BAD_VALUES = [
    # (name, changes, field, words): the cases first
    ("covariance-indefinite", {"noise": {"gaussians": [gaussian(cov=((1, 2), (2, 1)))]}},
     "noise.gaussians[0].cov", ("not positive definite", "-1")),
    ("covariance-singular", {"noise": {"gaussians": [gaussian(cov=((1, 1), (1, 1)))]}},
     "noise.gaussians[0].cov", ("not positive definite",)),
    ("covariance-asymmetric", {"noise": {"gaussians": [gaussian(cov=((1, 0.5), (0, 1)))]}},
     "noise.gaussians[0].cov", ("not symmetric",)),
    ("weight-1e6", {"noise": {"gaussians": [gaussian(weight=1e6)]}}, "noise.gaussians[0].weight", ("[0, 1]",)),
    ("weight-negative", {"noise": {"gaussians": [gaussian(weight=-0.1)]}}, "noise.gaussians[0].weight", ("[0, 1]",)),
    ("weights-sum-over-1", {"noise": {"gaussians": [gaussian(weight=0.6), gaussian(weight=0.6)]}},
     "noise.gaussians", ("sum to 1.2",)),
    ("too-many-gaussians", {"noise": {"gaussians": [gaussian(weight=0.001)] * 65}}, "noise.gaussians", ("at most 64",)),
    ("mean-far", {"noise": {"gaussians": [gaussian(mean=(1e300, 0))]}}, "noise.gaussians[0].mean", ("±10000",)),
    ("radius-1e308", {"warp__radius": 1e308}, "warp.radius", ("[0.1, 10]",)),
    ("radius-1e-300", {"weft__radius": 1e-300}, "weft.radius", ("[0.1, 10]",)),
    ("attenuation-1e300", {"specular__attenuation": 1e300}, "specular.attenuation", ("[0, 1000]",)),
    ("body-attenuation-1e300", {"body_attenuation": 1e300}, "body_attenuation", ("[0, 1000]",)),
    ("pitch-1e-300", {"scale": {"pitch_mm": 1e-300}}, "scale.pitch_mm", ("[0.001, 1000]",)),
]


@pytest.mark.parametrize("name, changes, field, words", BAD_VALUES, ids=[case[0] for case in BAD_VALUES])
def test_values_the_schema_leaves_open_are_refused_naming_field_and_range(sandbox, name, changes, field, words):
    """Each made an all-NaN image, a white one, pixel values of 2981 or a LinAlgError (exit 1)."""
    path = params_with(sandbox / "in", f"{name}.json", **changes)
    result = weavecap("synth", path, "-o", sandbox / "out.png", "--size", "16", "--tiles", "1x1", "--spp", "1")
    assert result.exit_code == 2, result.output
    assert f"{path}: {field}: " in result.output and "Traceback" not in result.output
    for word in words:
        assert word in result.output, (word, result.output)
    assert files_under(sandbox) == {f"in/{name}.json"}


def test_a_fabric_changed_out_of_range_in_memory_is_refused_too():
    fabric = params.load(PLAIN)
    with pytest.raises(ParamsError, match=r"warp.radius: 1e\+308 is out of range"):
        fabric.replace({"warp.radius": 1e308})
    assert fabric.replace({"warp.radius": 2.5}).warp.radius == 2.5


@pytest.mark.parametrize("seed", range(5))
def test_the_noise_weavecap_fits_is_within_the_limits(seed):
    """Fitted on residuals of an image in [0, 1] — the largest variance there is — the noise
    block always reads back."""
    rng = np.random.default_rng(seed)
    residual = rng.choice([-1.0, 1.0], size=(96, 96)) * rng.random() + rng.normal(0, 0.05, (96, 96))
    noise = fit_noise(np.clip(residual, -1, 1), pitch_px=float(rng.uniform(3, 30)), seed=seed)
    assert noise["gaussians"]
    doc = params.to_dict(params.load(PLAIN))
    params.from_dict({**doc, "noise": noise})


def test_json_nested_100000_deep_is_an_invalid_params_file(sandbox):
    """The standard parser recursed until RecursionError (exit 1)."""
    path = sandbox / "in" / "deep.json"
    path.write_text("[" * 100_000 + "]" * 100_000)
    result = weavecap("synth", path, "-o", sandbox / "out.png")
    assert result.exit_code == 2 and "nested more than 64 levels deep" in result.output


def test_a_huge_params_file_is_refused_unread(sandbox):
    path = sandbox / "in" / "huge.json"
    path.write_text(" " * (params.MAX_FILE_BYTES + 1))
    result = weavecap("export", path, "-o", sandbox / "out", "--format", "wif")
    assert result.exit_code == 2 and "too large for a params file" in result.output


def write_obj(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def test_a_mesh_of_1e_30_is_refused_not_rendered_empty(tmp_path):
    """1e-30 coordinates rendered an empty image with exit 0 and scipy's raw warnings."""
    obj = write_obj(tmp_path / "tiny.obj", "v 0 0 0\nv 1e-30 0 0\nv 0 1e-30 0\nv 1e-30 1e-30 0\nvt 0.5 0.5\n"
                    "f 1/1 2/1 4/1\nf 1/1 4/1 3/1\n")
    with pytest.raises(InputError, match=r"1.41e-30 m across .* outside 0.1 mm to 10 km"):
        wmesh.load_mesh(obj)


def test_a_mesh_far_from_the_origin_is_refused(tmp_path):
    obj = write_obj(tmp_path / "far.obj", "v 1e9 0 0\nv 1.0000001e9 0 0\nv 1e9 100 0\nf 1 2 3\n")
    with pytest.raises(InputError, match="from the origin"):
        wmesh.load_mesh(obj)


@pytest.mark.parametrize("uv, why", [
    ("vt 0.5 0.5\nvt 0.5 0.5\nvt 0.5 0.5\nvt 0.5 0.5\n", "have no area on 100% of the surface"),
    ("vt nan 0\nvt 1 0\nvt 0 1\nvt 1 1\n", "are NaN or infinite"),
])
def test_unusable_uvs_are_replaced_saying_why(tmp_path, uv, why):
    """All UVs at one point gave a NaN stretch and raw warnings; NaN UVs were reported as
    "no texture coordinates"."""
    obj = write_obj(tmp_path / "quad.obj", "v 0 0 0\nv 0.5 0 0\nv 0 0.5 0\nv 0.5 0.5 0\n" + uv
                    + "f 1/1 2/2 4/4\nf 1/1 4/4 3/3\n")
    with np.errstate(all="raise"):
        mesh = wmesh.load_mesh(obj)
    assert mesh.uv_source == "xatlas" and any(why in note for note in mesh.notes), mesh.notes
    assert np.isfinite(mesh.uv).all() and mesh.stretch["after"] == pytest.approx(1.0, abs=1e-6)


def six_by_four(tmp_path: Path) -> str:
    """The WIF text of a 6 × 4 pattern that reads back as itself."""
    pattern = np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1], [1, 1, 0, 0], [0, 0, 1, 1]], np.uint8)
    text = wif.wif_text(params.load(PLAIN).replace({"pattern": pattern}))
    path = tmp_path / "good.wif"
    path.write_text(text)
    assert wif.read_wif(path).pattern.shape == (6, 4)
    return text


def section(text: str, name: str, key: str, value: str) -> str:
    """``text`` with ``key=...`` of ``[name]`` set to ``value``."""
    head, rest = text.split(f"[{name}]\n", 1)
    body, tail = (rest.split("\n[", 1) + [""])[:2]
    body = re.sub(rf"(?m)^{key}=.*$", f"{key}={value}", body)
    return f"{head}[{name}]\n{body}" + (f"\n[{tail}" if tail else "")


BAD_WIF = [
    ("threads-0", lambda t: section(t, "WARP", "Threads", "0"), r"\[WARP\]: Threads=0: must be 1 or more"),
    ("threads-negative", lambda t: section(t, "WEFT", "Threads", "-3"), r"\[WEFT\]: Threads=-3: must be 1 or more"),
    ("end-beyond-threads", lambda t: section(t, "WARP", "Threads", "3"), r"\[THREADING\]: line 4=.* beyond \[WARP\]"),
    ("shaft-beyond-shafts", lambda t: section(t, "THREADING", "1", "9"),
     r"\[THREADING\]: line 1=9: shaft 9 is beyond \[WEAVING\] Shafts=4"),
    ("section-twice", lambda t: t + "[THREADING]\n1=2\n", r"\[THREADING\]: appears twice"),
    ("key-twice", lambda t: t.replace("[THREADING]\n1=1\n", "[THREADING]\n1=1\n1=2\n"),
     r"\[THREADING\]: the key '1' appears twice"),
    ("no-color-palette", lambda t: re.sub(r"\[COLOR PALETTE\][^\[]*", "", t), r"\[COLOR PALETTE\]: missing"),
]


@pytest.mark.parametrize("name, edit, message", BAD_WIF, ids=[case[0] for case in BAD_WIF])
def test_a_wif_that_contradicts_itself_is_refused_naming_the_section(tmp_path, name, edit, message):
    """Each was read silently as another pattern (Threads=0 turned 6×4 into 6×2), or ended in
    an UnboundLocalError inside the WIF library (exit 1)."""
    path = tmp_path / f"{name}.wif"
    path.write_text(edit(six_by_four(tmp_path)))
    with pytest.raises(InputError, match=message):
        wif.read_wif(path)
    result = weavecap("synth", PLAIN, "--pattern", path, "-o", tmp_path / "x.png")
    assert result.exit_code == 2 and "Traceback" not in result.output and not (tmp_path / "x.png").exists()


def test_a_texture_that_is_not_an_image_is_an_invalid_params_file(sandbox):
    """It exited 3 ("photo rejected") from inside the render."""
    (sandbox / "in" / "tex.png").write_text("not an image")
    path = params_with(sandbox / "in", "p.json", warp__body_reflection="tex.png")
    result = weavecap("synth", path, "-o", sandbox / "out.png")
    assert result.exit_code == 2, result.output
    assert "warp.body_reflection: the texture cannot be used" in result.output and "not a valid PNG" in result.output
    json.loads(path.read_text())  # the file itself is fine JSON: the message is about the texture


def test_a_narrow_noise_gaussian_adds_no_more_than_its_weight(tmp_path):
    """A covariance of 1e-12 (allowed: positive definite) centred on a frequency bin counted
    its peak density as variance: pixel values of 70 000. The synthesised variance is at most
    the weights' sum."""
    from weavecap.noise import synthesize

    noise = {"gaussians": [gaussian(weight=0.04, mean=(0.125, 0.0), cov=((1e-12, 0), (0, 1e-12)))]}
    params.from_dict({**params.to_dict(params.load(PLAIN)), "noise": noise})  # a valid file
    tile = synthesize(noise, (64, 64), pitch_px=8.0)
    assert tile.var() == pytest.approx(0.04, rel=1e-6)
