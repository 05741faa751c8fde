"""Promise: nothing escapes ``-o``. Whatever the inputs are called and whatever name is asked
for, every file a command writes lies under its ``-o``; an export refers to nothing outside it."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from weavecap import batch
from weavecap.errors import InputError
from weavecap.io import folder_name, inside
from weavecap.photo import save_png

from .conftest import PLAIN, files_under, noise_photo, params_with, weavecap


def test_photos_named_dot_dot_write_inside_o_even_with_force(sandbox):
    """A photo ``...png`` has the stem ``..`` and ``..png`` the stem ``.``: their folders are
    plain names under -o, and --force touches nothing above it."""
    photos = [noise_photo(sandbox / "in" / name, seed) for seed, name in enumerate(("...png", "..png", "noise.png"))]
    (sandbox / "report.json").write_text("precious")  # what OUT/.. would have overwritten
    for extra in ((), ("--force",)):
        result = weavecap("fit", *photos, "-o", sandbox / "out" / "o1", "-q", *extra)
        assert result.exit_code == 3, result.output  # all three rejected: noise
    assert (sandbox / "report.json").read_text() == "precious"
    assert files_under(sandbox / "out") == {"o1/summary.jsonl"} | {f"o1/{name}/{file}" for name in ("photo", "photo-2", "noise")
                                                                   for file in ("report.json", "diagnosis.png")}
    lines = [json.loads(line) for line in (sandbox / "out" / "o1" / "summary.jsonl").read_text().splitlines()]
    assert [Path(line["folder"]).name for line in lines] == ["photo", "photo-2", "noise"]


def test_batch_folders_are_plain_distinct_names_inside_o(tmp_path):
    """Dots, separators and control characters are dropped, the batch's own files kept free,
    and repeats numbered without colliding with a stem that already ends in -2."""
    sources = [Path(p) for p in ("a/...png", "b/.png", "c/summary.jsonl.png", "d/x.png", "e/x-2.png", "f/x.png",
                                 "g/.hidden.png")]
    got = [p.name for p in batch.folders(sources, tmp_path, fallback="photo")]
    assert got == ["photo", "png", "summary.jsonl_", "x", "x-2", "x-3", "hidden"]
    assert len(set(got)) == len(got)
    names = ["../../etc", "/abs", "ok"]  # names a command gives are made plain the same way
    assert [p.name for p in batch.folders(sources[:3], tmp_path, names)] == ["_.._etc", "_abs", "ok"]
    assert all(p.parent == tmp_path for p in batch.folders(sources[:3], tmp_path, names))
    assert folder_name("\x00\n", fallback="photo") == "__"
    assert len(folder_name("é" * 300, fallback="photo").encode()) == 200  # under the file systems' 255


def test_the_guard_refuses_a_path_outside_its_folder(tmp_path):
    inside(tmp_path, tmp_path / "a" / "b.png")
    for escape in (tmp_path / ".." / "x", Path("/tmp/x"), tmp_path / "a" / ".." / ".." / "x"):
        with pytest.raises(InputError, match="outside the output folder"):
            inside(tmp_path, escape)


@pytest.mark.parametrize("name", ["../../X", "/tmp/X", "..", ".hidden", "a/b", ""])
def test_export_refuses_a_name_that_is_not_a_plain_file_name(sandbox, name):
    result = weavecap("export", PLAIN, "-o", sandbox / "out", "--format", "wif", "--name", name)
    assert result.exit_code == 2 and "--name" in result.output and "plain file name" in result.output, result.output
    assert files_under(sandbox) == set() and not Path("/tmp/X.wif").exists()


def test_export_names_a_params_file_called_dot_dot_plainly(sandbox):
    source = params_with(sandbox / "in", "...json")
    result = weavecap("export", source, "-o", sandbox / "out", "--format", "wif")
    assert result.exit_code == 0, result.output
    assert files_under(sandbox / "out") == {"fabric.wif"}


def test_the_mitsuba_export_carries_its_textures_and_moves_as_a_whole(sandbox):
    """The params file beside the scenes names copies of its body textures inside the export,
    so the folder renders after the source is gone."""
    save_png(sandbox / "in" / "tex.png", np.random.default_rng(0).random((8, 8, 3)).astype(np.float32))
    source = params_with(sandbox / "in", "fab.json", warp__body_reflection="tex.png", scale={"pitch_mm": 0.5})
    result = weavecap("export", source, "-o", sandbox / "out", "--format", "mitsuba", "--texels-per-yarn", "4")
    assert result.exit_code == 0, result.output
    written = json.loads((sandbox / "out" / "mitsuba" / "fab.json").read_text())
    assert written["warp"]["body_reflection"] == "textures/fab_warp_body.png"
    moved = sandbox / "moved"
    shutil.move(sandbox / "out", moved)
    shutil.rmtree(sandbox / "in")
    from weavecap import params

    fabric = params.load(moved / "mitsuba" / "fab.json")
    assert Path(fabric.warp.body_reflection) == (moved / "mitsuba" / "textures" / "fab_warp_body.png").resolve()
