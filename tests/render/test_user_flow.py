"""The user's flow end to end: `weavecap fit` of a real photo, then `weavecap render`
of its params.json on the towel (the photo and the towel from ../shared)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from weavecap.cli.main import cli
from weavecap.photo import load_photo



@pytest.mark.slow
def test_fit_a_real_photo_then_render_it_on_the_towel(tmp_path, shared):
    photo = shared("realdata", "images", "easy", "fabricnet_W092_plain.jpg")
    towel = shared("meshes", "towel.obj")
    runner = CliRunner()
    fit = runner.invoke(cli, ["fit", str(photo), "-o", str(tmp_path / "fit"), "--quality", "draft", "-q"])
    assert fit.exit_code == 0, fit.output
    params_file = tmp_path / "fit" / "params.json"
    out = tmp_path / "towel.png"
    render = runner.invoke(cli, ["render", str(params_file), str(towel), "-o", str(out), "--size", "160x90", "--spp",
                                 "4", "--view", "0,30", "--json"])
    assert render.exit_code == 0, render.output
    doc = json.loads(render.stdout)
    assert doc["images"][0]["output"] == str(out) and doc["mesh"]["uv_source"] == "file"
    image = load_photo(out).rgb
    # the towel covers the middle of the frame, in the fitted fabric's colour: the photo is
    # a blue cloth, so the towel's pixels are bluer than they are red
    centre = image[30:60, 60:100].reshape(-1, 3)
    background = image[2, 2]
    assert np.abs(centre.mean(axis=0) - background).max() > 0.02
    assert centre[:, 2].mean() > centre[:, 0].mean()
