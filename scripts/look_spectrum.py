#!/usr/bin/env python3
"""Where a photo's texture lies in frequency, in cycles per yarn — and where a fitted fabric's
render puts it. A measurement for docs/capture.md (why no 2/2 herringbone of the
forward model matches Brodatz D16).

    .venv/bin/python scripts/look_spectrum.py ../shared/realdata/images/easy/brodatz_D16_herringbone_000deg.tiff
    .venv/bin/python scripts/look_spectrum.py PHOTO --params OUT/params.json [--pattern twill.txt]

For the photo (rectified and gridded by ``prepare_photo``) and for each fabric's render (one
repeat at 17 px a cell under its report's light and blur, tiled), prints the share of the
luminance's power spectrum (Hann window, mean removed) on the rows fy = k/4 cycles per weft and
the columns fx = k/4 cycles per warp, k = 0..4, each ±1 frequency bin. A 2/2 twill whose warp
and weft floats look different puts power on the 1/4 and 3/4 rows; one whose floats look alike
repeats over 2 yarns and puts it on the 1/2 row, as a plain weave does.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from weavecap import params  # noqa: E402
from weavecap.fit.fidelity import luminance  # noqa: E402
from weavecap.model.render import as_photographed, render_numpy  # noqa: E402
from weavecap.model.scene import View, build_scene, light_rig  # noqa: E402
from weavecap.patterns import load_pattern  # noqa: E402
from weavecap.photo import load_photo  # noqa: E402
from weavecap.prepare import Prepared, prepare_photo  # noqa: E402

QUARTERS = (0.0, 0.25, 0.5, 0.75, 1.0)


def shares(y: np.ndarray, pitch_px: tuple[float, float]) -> tuple[list[float], list[float]]:
    """Power shares of (H, W) luminance ``y`` on the rows fy = k/4 per weft and the columns
    fx = k/4 per warp (``pitch_px`` = (weft, warp) pitch in px), each ±1 bin, k = 0..4."""
    h, w = y.shape
    win = np.hanning(h)[:, None] * np.hanning(w)[None, :]
    power = np.abs(np.fft.fft2((y - y.mean()) * win)) ** 2
    total = power.sum()

    def band(n: int, pitch: float, axis: int) -> list[float]:
        out = []
        for q in QUARTERS:
            centre = int(round(q * n / pitch))
            idx = sorted({(sign * (centre + d)) % n for sign in (1, -1) for d in (-1, 0, 1)})
            out.append(float(np.take(power, idx, axis=axis).sum() / total))
        return out

    return band(h, pitch_px[0], 0), band(w, pitch_px[1], 1)


def render_repeat(fabric, report: dict, c: int = 17, tiles: tuple[int, int] = (8, 2)) -> np.ndarray:
    """(H, W) luminance of ``fabric``'s repeat at ``c`` px a cell under its capture's light and
    blur, tiled ``tiles`` times (rows, columns)."""
    light = report["fit"]["light"]
    rig = light_rig(report["modelled"]["light_rig"]).with_gain(light["gain"])
    fs = build_scene(fabric, View(tiles=(1, 1), size=c * max(fabric.shape), spp=4), light=rig)
    image = as_photographed(render_numpy(fs)[..., :3], float(report["modelled"]["photo_blur_px"]), 1.0)
    return luminance(np.tile(image, (*tiles, 1)))


def line(label: str, rows: list[float], cols: list[float]) -> str:
    fmt = " ".join(f"{100 * v:5.1f}" for v in rows)
    return f"{label:28s} per weft {fmt} | per warp " + " ".join(f"{100 * v:5.1f}" for v in cols)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("photo")
    ap.add_argument("--params", help="a capture's params.json (its report.json beside it)")
    ap.add_argument("--pattern", action="append", default=[], help="also render the capture with this pattern")
    a = ap.parse_args()
    prepared = prepare_photo(load_photo(a.photo).rgb)
    if not isinstance(prepared, Prepared):
        print(f"{a.photo}: rejected: {prepared.reason}")
        return 3
    pitch_x, pitch_y = prepared.grid.pitch_px
    print(f"{'power share (%) at k/4, k=':28s}          " + "     ".join(str(k) for k in range(5)))
    print(line("photo", *shares(luminance(prepared.rectification.image), (pitch_y, pitch_x))))
    if a.params:
        fabric = params.load(a.params)
        report = json.loads((Path(a.params).parent / "report.json").read_text())
        print(line(f"capture {fabric.shape[0]}x{fabric.shape[1]}", *shares(render_repeat(fabric, report), (17, 17))))
        for path in a.pattern:
            held = fabric.replace({"pattern": load_pattern(path)})
            print(line(Path(path).name, *shares(render_repeat(held, report), (17, 17))))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
