"""The surface model against the forward model: a flat swatch rendered head-on under the capture
rig must look like ``weavecap synth`` of the same fabric (docs/design.md, "Output renderers").

:func:`compare_with_synth` renders both at the same size and scale — the forward model's
``tiles × tiles`` repeats across ``size`` pixels, and ``weavecap render``'s reference mode of a
swatch of exactly that many repeats (orthographic, margin 0, the rig ``both``) — and measures
the PSNR after a 1-pixel blur (the contract: ≥ 28 dB). ``weavecap bench --render`` reports it
for every fixture at the fixture photos' scale (4×4 repeats, 512 pixels).
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
from scipy.ndimage import gaussian_filter

from ..params import Fabric

BLUR_PX = 1.0
CONTRACT_DB = 28.0


def blurred_psnr(a: np.ndarray, b: np.ndarray, sigma: float = BLUR_PX) -> float:
    """PSNR (dB, peak 1) of two linear images (H, W, 3) clipped to [0, 1] (what a photo
    records) after a Gaussian blur of ``sigma`` pixels."""
    blur = lambda x: gaussian_filter(np.clip(x, 0.0, 1.0), (sigma, sigma, 0))  # noqa: E731
    mse = float(np.mean((blur(a) - blur(b)) ** 2))
    return float("inf") if mse == 0 else float(10 * np.log10(1.0 / mse))


def swatch_size(shape: tuple[int, int], tiles: int, size: int) -> tuple[int, int]:
    """(width, height) in pixels of ``tiles × tiles`` repeats of a pattern of ``shape``,
    ``size`` along the longer side — as the forward model frames them."""
    n_e, n_a = shape
    return (size, max(1, round(size * n_e / n_a))) if n_a >= n_e else (max(1, round(size * n_a / n_e)), size)


def compare_with_synth(fabric: Fabric, *, tiles: int = 4, size: int = 512, spp: int = 64, pitch_mm: float = 1.0,
                       seed: int = 0) -> dict:
    """Render a swatch of ``fabric`` both ways and compare.

    Returns
    -------
    dict: ``psnr_db`` (after a 1-pixel blur), ``size`` (W, H), ``render`` and ``synth`` (the
    two linear images), ``seconds`` of the surface render (bake included)
    """
    from ..model.render import render_numpy
    from ..model.scene import View, build_scene
    from .mesh import load_mesh
    from .run import RenderOptions, render_fabric
    from .shapes import flat_swatch

    n_e, n_a = fabric.shape
    synth = render_numpy(build_scene(fabric, View(tiles=(tiles, tiles), size=size), light="both"), seed=seed)
    width, height = swatch_size(fabric.shape, tiles, size)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "swatch.obj"
        path.write_text(flat_swatch(tiles * n_a * pitch_mm / 1000, tiles * n_e * pitch_mm / 1000).obj_text())
        mesh = load_mesh(path)
    # the swatch's top left at warp 0, weft 0 of the fabric, as synth's image starts: the weave
    # repeats every ``tiles``th of it either way, a colour order (longer) only so aligned
    # (the surface counts weft floor((1 - t) n_e), t = 0 at the swatch's foot)
    options = RenderOptions(mode="reference", spp=spp, size=(width, height), view=(0.0, 0.0), camera="orthographic",
                            margin=0.0, light="both", pitch_mm=pitch_mm, seed=seed, offset=(0.0, 1.0 - tiles))
    result = render_fabric(fabric, mesh, options)
    return {"psnr_db": blurred_psnr(result.image, synth), "size": (width, height), "render": result.image,
            "synth": synth, "seconds": result.info["timings"]["total"],
            "texels_per_yarn": result.info["texels_per_yarn"]}
