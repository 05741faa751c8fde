"""The surface model agrees with the forward model (docs/design.md, "Output
renderers"): a flat swatch rendered by ``weavecap render --mode reference --light both --view
front --camera orthographic --margin 0`` at the photo's scale matches ``weavecap synth`` of the
same params at the same size: PSNR ≥ 28 dB after a 1-pixel blur, for every fixture.

Here at the fixture photos' scale (4 repeats per 512 pixels) over 2×2 repeats (256 pixels) and
32 spp, to keep the suite short: measured 32.6–36.9 dB. ``weavecap bench --render`` measures
the full 4×4 repeats at 512 pixels, 64 spp (docs/render.md: 33–37 dB). The floor here is
31 dB, so a regression of a few dB fails well before the contract's 28.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from weavecap import params
from weavecap.cli.main import cli
from weavecap.photo import load_photo
from weavecap.render import shapes
from weavecap.render.consistency import CONTRACT_DB, blurred_psnr, compare_with_synth, swatch_size

FIXTURES = sorted((Path(__file__).resolve().parents[2] / "fixtures" / "params").glob("*.json"))
FLOOR_DB = 31.0


@pytest.mark.slow
@pytest.mark.parametrize("path", FIXTURES, ids=[p.stem for p in FIXTURES])
def test_flat_swatch_under_the_capture_rig_matches_synth(path):
    result = compare_with_synth(params.load(path), tiles=2, size=256, spp=32)
    assert result["psnr_db"] >= max(CONTRACT_DB, FLOOR_DB), f"{path.stem}: {result['psnr_db']:.2f} dB"


def test_the_command_lines_of_the_contract_agree(tmp_path):
    """The same comparison through the two commands as a user types them (custom 4×6: the
    non-square pattern, so a transposed or mirrored weave would show)."""
    path = next(p for p in FIXTURES if p.stem == "custom_4x6")
    fabric = params.load(path)
    n_e, n_a = fabric.shape
    mesh = tmp_path / "swatch.obj"
    mesh.write_text(shapes.flat_swatch(2 * n_a * 1e-3, 2 * n_e * 1e-3).obj_text())  # 2×2 repeats, 1 mm a yarn
    width, height = swatch_size(fabric.shape, 2, 256)
    runner = CliRunner()
    synth = runner.invoke(cli, ["synth", str(path), "-o", str(tmp_path / "synth.exr"), "--tiles", "2x2", "--size",
                                "256", "-q"])
    assert synth.exit_code == 0, synth.output
    render = runner.invoke(cli, ["render", str(path), str(mesh), "-o", str(tmp_path / "render.exr"), "--mode",
                                 "reference", "--light", "both", "--view", "front", "--camera", "orthographic",
                                 "--margin", "0", "--size", f"{width}x{height}", "--spp", "32", "--pitch-mm", "1", "-q"])
    assert render.exit_code == 0, render.output
    psnr = blurred_psnr(load_photo(tmp_path / "render.exr").rgb, load_photo(tmp_path / "synth.exr").rgb)
    assert psnr >= max(CONTRACT_DB, FLOOR_DB), f"{psnr:.2f} dB"
