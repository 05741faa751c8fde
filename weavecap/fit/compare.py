"""The capture beside its photo at the photo's own scale: the view, the render, compare.png.

The fit works on the photo's median repeat (:mod:`weavecap.fit.target`); a person judges a
capture against what they shot: several repeats, each thread in its colour, the photo's own
irregularities. :func:`photo_view` takes the rectified photo over every whole cell of the
fitted weave's registered lattice (at about its own pixels: a cell of ``c`` ≈ the yarn
pitch, the lattice's drift followed as the median repeat's is), :func:`view_scene` and :func:`shown` render
the captured fabric over the same cells as photographed (the camera's white level and blur,
the fit's light rig and gain), so the two are registered pixel for pixel; the pixel figures
(:func:`weavecap.fit.fidelity.pixel_fidelity`), the thread colours
(:mod:`weavecap.fit.threads`) and compare.png (:func:`compare_image`: photo | fit |
difference, the median repeat beside them, the figures below) are made from them.
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
#: compare.png's difference panel: |photo − fit| times this
DIFFERENCE_GAIN = 4.0


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


def photo_view(image: np.ndarray, cells: CellGrid, fabric: Fabric, rig, *, spp: int, held: bool = False,
               max_px: int = MAX_VIEW_PX) -> PhotoView:
    """The photo ``image`` (rectified, (H, W, 3) linear) over the whole cells of the lattice
    of ``cells`` (the fitted repeat in its pixels), read along the lattice's drift measured
    against a render of ``fabric`` under ``rig`` (:func:`weavecap.fit.target.cells_canvas`,
    ``held`` as the fit's target was read), the middle cells kept within ``max_px`` a side."""
    from ..estimate.forward import BLUR_CELLS
    from ..model.render import as_photographed, render_numpy, white_level
    from ..model.scene import View, build_scene
    from .target import cells_canvas

    c, pitch = view_cell_px(cells)
    n_e, n_a = fabric.shape
    white = white_level(image)
    single = fabric.with_threads(None)
    model = as_photographed(render_numpy(build_scene(single, View(tiles=(1, 1), size=c * max(n_e, n_a), spp=spp),
                                                     light=rig)), BLUR_CELLS * c, white)
    canvas, first, _ = cells_canvas(image, cells, c, model, hold_phase=held)
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



def _labelled(image: np.ndarray, text: str) -> np.ndarray:
    """``image`` (linear RGB) with ``text`` written in its top-left corner on a dark band."""
    import cv2

    from ..photo import linear_to_srgb, srgb_to_linear

    srgb = (np.clip(linear_to_srgb(np.clip(image, 0.0, 1.0)), 0.0, 1.0) * 255).astype(np.uint8).copy()
    scale = max(0.35, min(0.6, image.shape[1] / 500))
    (tw, th), _ = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, scale, 1)
    cv2.rectangle(srgb, (0, 0), (min(image.shape[1], tw + 8), th + 8), (0, 0, 0), -1)
    cv2.putText(srgb, text, (4, th + 3), cv2.FONT_HERSHEY_SIMPLEX, scale, (255, 255, 255), 1, cv2.LINE_AA)
    return srgb_to_linear(srgb.astype(np.float32) / 255.0)


def _fit_height(image: np.ndarray, height: int) -> np.ndarray:
    """``image`` scaled (nearest neighbour: pixels stay pixels) to ``height`` rows."""
    import cv2

    width = max(1, round(image.shape[1] * height / image.shape[0]))
    return cv2.resize(np.asarray(image, np.float32), (width, height), interpolation=cv2.INTER_NEAREST)


def compare_image(photo: np.ndarray, render: np.ndarray, repeat_photo: np.ndarray, repeat_render: np.ndarray,
                  captions: list[str], *, min_height: int = 256) -> np.ndarray:
    """compare.png (linear RGB): the photo over several repeats, the fit over the same area and
    their difference (×DIFFERENCE_GAIN) side by side, the median repeat (photo over fit) beside
    them, enlarged to at least ``min_height`` rows (whole pixels), and ``captions`` below, one
    line each."""
    from .fidelity import captioned

    k = max(1, int(np.ceil(min_height / photo.shape[0])))
    panels = [_labelled(np.kron(x, np.ones((k, k, 1), np.float32)), label) for x, label in (
        (photo, "photo"), (render, "fit"), (np.abs(render - photo) * DIFFERENCE_GAIN,
                                            f"|photo - fit| x{DIFFERENCE_GAIN:g}"))]
    height = panels[0].shape[0]
    gap = np.ones((height, max(2, height // 64), 3), np.float32)
    repeat = np.concatenate([repeat_photo, repeat_render], axis=0)
    side = _labelled(_fit_height(repeat, height), "median repeat: photo / fit")
    row = np.concatenate([panels[0], gap, panels[1], gap, panels[2], gap, side], axis=1)
    for text in captions:
        row = captioned(row, text)
    return row


@dataclass
class PhotoScale:
    """The capture judged at the photo's scale (:func:`at_photo_scale`).

    Attributes
    ----------
    fabric : the captured fabric with the thread colours the photo shows
    threads : report.json's ``threads`` (the colour orders found and each thread's ΔE)
    view : the photo over whole cells; render : ``fabric`` rendered over it as photographed
    figures : :class:`weavecap.fit.fidelity.PixelFidelity` of the render against the view
    blur_px : the camera's blur the render was shown with, view pixels
    """

    fabric: Fabric
    threads: dict
    view: PhotoView
    render: np.ndarray
    figures: object
    blur_px: float

    def compare(self, repeat_photo: np.ndarray, repeat_render: np.ndarray, captions: list[str], *,
                exposure: float = 1.0) -> np.ndarray:
        """compare.png (:func:`compare_image`), shown at the photo's own ``exposure``, with the
        pixel figures as the first caption line and ``captions`` (the repeat's figures) after."""
        rows, cols = self.view.cells
        head = f"photo scale, {rows}x{cols} yarns: " + self.figures.caption()
        return compare_image(exposure * self.view.canvas, exposure * self.render, exposure * repeat_photo,
                             exposure * repeat_render, [head, *("median repeat: " + c for c in captions)])


def at_photo_scale(image: np.ndarray, fitted, fabric: Fabric, *, c: int, spp: int) -> PhotoScale:
    """The fitted capture at the photo's own scale: the view of ``image`` (the rectified photo
    the fit saw) over whole cells on ``fitted``'s registration
    (:class:`weavecap.fit.rounds.RegisteredFit`, cells in ``image`` pixels), the thread
    colours it shows (:func:`weavecap.fit.threads.capture_threads`), ``fabric`` with them
    rendered over it under the fitted rig, and the pixel figures
    (:func:`weavecap.fit.fidelity.pixel_fidelity`).

    The render is shown with the camera's blur measured on the view itself
    (:func:`weavecap.fit.target.photo_blur`, held to 0.9 of the photo's sharpness as the
    fit's is): the fit's blur (``fitted.blur_px`` at ``c`` px a cell) is that of the median
    repeat, smoother than any one repeat of the photo — a synthetic check fitted at 5.7 ΔE p90
    showed half the photo's sharpness with it. The thread colours are solved with the fit's
    blur scaled to the view (they are read at the yarns' centres, which a blur hardly moves)."""
    from .fidelity import pixel_fidelity
    from .threads import capture_threads

    from ..model.render import render_numpy
    from .target import photo_blur

    view = photo_view(image, fitted.cells, fabric, fitted.rig, spp=spp, held=fitted.held)
    fabric, threads = capture_threads(view, fabric, fitted.rig, blur_px=fitted.blur_px * view.c / c, spp=spp)
    fs = view_scene(fabric, fitted.rig, view, spp=spp)
    sharp = render_numpy(fs)
    blur_px, _ = photo_blur(shown(fs, view, 0.0, sharp), view.canvas, view.c)
    render = shown(fs, view, blur_px, sharp)
    return PhotoScale(fabric=fabric, threads=threads, view=view, render=render,
                      figures=pixel_fidelity(view.canvas, render, view.c), blur_px=blur_px)
