"""Synthetic photos with known answers for the pre-estimation tests (small renders).

(Named apart from ``tests/prepare/synthetic.py``: both folders are on the import path.)
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from weavecap.estimate.cells import CellGrid

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "params"


def photo_of(fabric, *, cell_px: int = 12, tiles=(2, 2), noise: float = 0.003, seed: int = 0):
    """A regularized-looking photo of ``fabric`` (blur σ = pitch / 16, pixel noise) and the grid
    of its repeat starting at the second weft and third warp (a cyclic shift of the truth).

    Returns (photo (H, W, 3), CellGrid, shift) with ``np.roll(fabric.pattern, shift)`` the pattern
    the grid sees from its first cell.
    """
    from weavecap.model.render import render_numpy
    from weavecap.model.scene import View, build_scene

    n_e, n_a = fabric.shape
    fs = build_scene(fabric, View(tiles=tiles, size=cell_px * max(tiles[0] * n_e, tiles[1] * n_a), spp=4))
    img = cv2.GaussianBlur(render_numpy(fs), (0, 0), cell_px / 16)
    img = img + np.random.default_rng(seed).normal(0, noise, img.shape).astype(np.float32)
    start = (1 % n_e, 2 % n_a)
    grid = CellGrid.regular((n_e, n_a), cell_px, origin=(start[0] * cell_px, start[1] * cell_px))
    return img, grid, (-start[0], -start[1])
