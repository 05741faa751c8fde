"""The forward model as the pre-estimators use it: one repeat on a cell canvas (§5).

:class:`RepeatRenderer` renders a fabric's minimum repeat with ``View(tiles=(1, 1))`` so that
the image is a cell canvas (:mod:`.cells`): cell (i, j) covers rows ``i*cell_px ..`` and
columns ``j*cell_px ..``. A new pattern or radius casts the rays again (tens of ms); changing a
colour or any other continuous value only re-shades (a few ms).

Renders are blurred like the regularized photo they are compared with: §4.2 smooths the photo
with a Gaussian of σ = yarn pitch / 16, i.e. ``cell_px / 16`` on the canvas (wrapping around,
as the repeat tiles). Without it the sharp, bright gaps between yarns would dominate the MSE.
"""

from __future__ import annotations

import numpy as np

from ..params import Fabric

BLUR_CELLS = 1.0 / 16.0  # σ of the photo's regularization (§4.2), in cells


class RepeatRenderer:
    """Renders of one repeat of ``fabric`` at ``cell_px`` pixels per cell.

    Parameters
    ----------
    fabric : the fabric (its pattern sets the repeat's shape).
    cell_px : pixels per cell side.
    light : light rig name (``both``, ``front``, ``back``; §6.4).
    spp : samples per pixel.
    blur_cells : σ of the Gaussian applied to every render, in cells (0: none).
    white : renders are clipped at this level before the blur, like the photo they are
        compared with (:func:`weavecap.model.render.as_photographed`); the default (none)
        keeps them linear in the colours, which :mod:`.colour` relies on.
    """

    def __init__(self, fabric: Fabric, *, cell_px: int, light: str = "both", spp: int = 4,
                 blur_cells: float = BLUR_CELLS, white: float = float("inf")):
        from ..model.scene import View, build_scene

        n_e, n_a = fabric.shape
        self.cell_px = cell_px
        self.spp = spp
        self.blur_px = blur_cells * cell_px
        self.white = white
        self.scene = build_scene(fabric, View(tiles=(1, 1), size=cell_px * max(n_e, n_a), spp=spp), light=light)
        if self.scene.frame.shape != (n_e * cell_px, n_a * cell_px):
            raise ValueError(f"render shape {self.scene.frame.shape} is not a cell canvas of {fabric.shape} cells")

    @property
    def fabric(self) -> Fabric:
        return self.scene.fabric

    def set_pattern(self, pattern: np.ndarray) -> None:
        """Replace the pattern (same shape) and rebuild the yarn geometry."""
        self.scene.set("pattern", np.asarray(pattern, dtype=np.uint8))

    def set(self, values: dict) -> None:
        """Set parameters by dotted key (radii rebuild the geometry)."""
        for key, value in values.items():
            self.scene.set(key, value)

    def render(self) -> np.ndarray:
        """(n_e * cell_px, n_a * cell_px, 3) float32 linear RGB, clipped at ``white`` and
        blurred by ``blur_cells``."""
        from ..model.render import as_photographed, render_numpy

        return as_photographed(render_numpy(self.scene), self.blur_px, self.white)

    def coverage(self) -> np.ndarray:
        """(n_e * cell_px, n_a * cell_px) fraction of each pixel's samples that hit a yarn (unblurred)."""
        from ..model.render import gbuffer

        g = gbuffer(self.scene, spp=self.spp, seed=0)
        hit = np.array(g.hit, dtype=np.float32).reshape(*g.shape, self.spp)
        return hit.mean(axis=2)
