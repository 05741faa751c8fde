"""The photo at its own scale over whole cells, and the captured fabric rendered over them.

:func:`photo_view` takes the rectified photo over every whole cell of the fitted weave's
registered lattice (at about its own pixels: a cell of ``c`` ≈ the yarn pitch, the lattice's
drift followed as the median repeat's is); :func:`view_scene` and :func:`shown` render the
captured fabric over the same cells as photographed (the camera's white level and blur, the
fit's light rig and gain), so the two are registered pixel for pixel. The thread colours
(:mod:`weavecap.fit.threads`) and compare.png (:mod:`weavecap.fit.compare`) are read on them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..estimate.cells import CellGrid
from ..params import Fabric

#: a view's cell side in pixels: the photo's own pitch, held within these bounds
MIN_CELL_PX, MAX_CELL_PX = 8, 40
#: the view spans at most this many pixels a side (whole cells, the middle ones kept): the
#: render of it is one of a few kernels of ~1 s on 2 cores
MAX_VIEW_PX = 640
#: ... and fewer than this many repeats a side (the renderer's limit is 64; the view's cells
#: may start and end inside a repeat)
MAX_VIEW_REPEATS = 63


@dataclass(frozen=True)
class PhotoView:
    """The photo over whole cells of the fitted weave's lattice, at about its own scale.

    Attributes
    ----------
    canvas : (Y·c, X·c, 3) float32 linear RGB, cell (v, u) being pattern cell ((v + v0) mod
        n_e, (u + u0) mod n_a)
    c : pixels a cell side (the photo's mean pitch, within [MIN_CELL_PX, MAX_CELL_PX])
    first : (v0, u0), the canvas's first cell counted from a repeat's first cell
    shape : (n_e, n_a) of the weave repeat
    pitch_px : the photo's yarn pitch in its rectified pixels (mean of both directions)
    white : the camera's white level (:func:`weavecap.model.render.white_level`)
    """

    canvas: np.ndarray
    c: int
    first: tuple[int, int]
    shape: tuple[int, int]
    pitch_px: float
    white: float

    @property
    def cells(self) -> tuple[int, int]:
        """(Y, X) cells of the canvas."""
        return self.canvas.shape[0] // self.c, self.canvas.shape[1] // self.c


def view_cell_px(cells: CellGrid) -> tuple[int, float]:
    """(c, pitch): the cell side of a view of the photo whose repeat has ``cells``: its mean
    pitch (geometric mean of both directions) rounded, within [MIN_CELL_PX, MAX_CELL_PX]."""
    pitch = float(np.sqrt(np.diff(cells.rows).mean() * np.diff(cells.cols).mean()))
    return int(np.clip(round(pitch), MIN_CELL_PX, MAX_CELL_PX)), pitch


def photo_view(image: np.ndarray, cells: CellGrid, drift=None, *, max_px: int = MAX_VIEW_PX) -> PhotoView:
    """The photo ``image`` (rectified, (H, W, 3) linear) over the whole cells of the lattice
    of ``cells`` (the fitted repeat in its pixels), read along ``drift`` — the
    :class:`weavecap.fit.target.Drift` the fit's median repeat was read along, so that every
    cell shows what the fit matched there (:func:`weavecap.fit.target.cells_canvas`) — the
    middle cells kept within ``max_px`` a side.

    Measured again against a render of the fitted fabric instead, the drift could lock half a
    cell away from the fit's: the independent plain weave with dark gaps (its fit's drift half a
    cell off the lattice, the view's own drift rejected as a mismatch) showed its capture half
    a cell off at the photo's scale, structure −0.85 where the median repeat's was 0.92."""
    from ..model.render import white_level
    from .target import cells_canvas

    c, pitch = view_cell_px(cells)
    n_e, n_a = cells.shape
    white = white_level(image)
    canvas, first, _ = cells_canvas(image, cells, c, drift)
    rows, cols = canvas.shape[0] // c, canvas.shape[1] // c
    keep = [max(1, min(k, max_px // c, MAX_VIEW_REPEATS * n)) for k, n in ((rows, n_e), (cols, n_a))]
    y0, x0 = (rows - keep[0]) // 2, (cols - keep[1]) // 2
    canvas = canvas[y0 * c:(y0 + keep[0]) * c, x0 * c:(x0 + keep[1]) * c]
    return PhotoView(canvas=np.ascontiguousarray(canvas, np.float32), c=c,
                     first=((first[0] + y0) % n_e, (first[1] + x0) % n_a), shape=(n_e, n_a), pitch_px=pitch,
                     white=white)


def view_scene(fabric: Fabric, rig, view: PhotoView, *, spp: int):
    """The :class:`weavecap.model.scene.FabricScene` of ``fabric`` under ``rig`` over the
    whole repeats that hold the view's cells (:func:`shown` crops its render to them)."""
    from ..model.scene import View, build_scene

    (rows, cols), (v0, u0), (n_e, n_a) = view.cells, view.first, view.shape
    tiles = (-(-(v0 + rows) // n_e), -(-(u0 + cols) // n_a))
    return build_scene(fabric, View(tiles=tiles, size=view.c * max(tiles[0] * n_e, tiles[1] * n_a), spp=spp),
                       light=rig)


def shown(fs, view: PhotoView, blur_px: float, image: np.ndarray | None = None) -> np.ndarray:
    """A render of a :func:`view_scene` (or ``image``, one already made) as photographed —
    clipped at the view's white level, blurred by ``blur_px`` view pixels — and cropped to the
    view's cells: (Y·c, X·c, 3) float32, registered on ``view.canvas``."""
    from ..model.render import as_photographed, render_numpy

    (rows, cols), (v0, u0), c = view.cells, view.first, view.c
    full = as_photographed(render_numpy(fs) if image is None else image, blur_px, view.white)
    return full[v0 * c:(v0 + rows) * c, u0 * c:(u0 + cols) * c]
