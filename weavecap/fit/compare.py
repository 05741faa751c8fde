"""The capture beside its photo at the photo's own scale: the view, the render, compare.png.

The fit works on the photo's median repeat (:mod:`weavecap.fit.target`); a person judges a
capture against what they shot: several repeats, each thread in its colour, the photo's own
irregularities. :func:`photo_view` takes the rectified photo over every whole repeat of the
fitted weave on the registered lattice (at about its own pixels: a cell of ``c`` ≈ the yarn
pitch, the lattice's drift followed as the median repeat's is), :func:`render_view` renders
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
#: the view spans at most this many pixels a side (whole repeats, the middle ones kept): the
#: render of it is one of a few kernels of ~1 s on 2 cores
MAX_VIEW_PX = 640
#: ... and at most this many repeats a side (the renderer's limit)
MAX_VIEW_REPEATS = 64
#: compare.png's difference panel: |photo − fit| times this
DIFFERENCE_GAIN = 4.0


@dataclass(frozen=True)
class PhotoView:
    """The photo over whole repeats of the fitted weave, at about its own scale.

    Attributes
    ----------
    canvas : (ky·n_e·c, kx·n_a·c, 3) float32 linear RGB, cell (v, u) being pattern cell
        (v mod n_e, u mod n_a)
    c : pixels a cell side (the photo's mean pitch, within [MIN_CELL_PX, MAX_CELL_PX])
    repeats : (ky, kx) repeats of the weave down and across
    pitch_px : the photo's yarn pitch in its rectified pixels (mean of both directions)
    white : the camera's white level (:func:`weavecap.model.render.white_level`)
    """

    canvas: np.ndarray
    c: int
    repeats: tuple[int, int]
    pitch_px: float
    white: float


def view_cell_px(cells: CellGrid) -> tuple[int, float]:
    """(c, pitch): the cell side of a view of the photo whose repeat has ``cells``: its mean
    pitch (geometric mean of both directions) rounded, within [MIN_CELL_PX, MAX_CELL_PX]."""
    pitch = float(np.sqrt(np.diff(cells.rows).mean() * np.diff(cells.cols).mean()))
    return int(np.clip(round(pitch), MIN_CELL_PX, MAX_CELL_PX)), pitch


def photo_view(image: np.ndarray, cells: CellGrid, fabric: Fabric, rig, *, spp: int, held: bool = False,
               max_px: int = MAX_VIEW_PX) -> PhotoView:
    """The photo ``image`` (rectified, (H, W, 3) linear) over the whole repeats of the lattice
    of ``cells`` (the fitted repeat in its pixels), read along the lattice's drift measured
    against a render of ``fabric`` under ``rig`` (:func:`weavecap.fit.target.repeats_canvas`,
    ``held`` as the fit's target was read), the middle repeats kept within ``max_px`` and
    MAX_VIEW_REPEATS a side."""
    from ..estimate.forward import BLUR_CELLS
    from ..model.render import as_photographed, render_numpy, white_level
    from ..model.scene import View, build_scene
    from .target import repeats_canvas

    c, pitch = view_cell_px(cells)
    n_e, n_a = fabric.shape
    white = white_level(image)
    single = fabric.with_threads(None)
    model = as_photographed(render_numpy(build_scene(single, View(tiles=(1, 1), size=c * max(n_e, n_a), spp=spp),
                                                     light=rig)), BLUR_CELLS * c, white)
    canvas, _, _ = repeats_canvas(image, cells, c, model, hold_phase=held)
    ky, kx = canvas.shape[0] // (n_e * c), canvas.shape[1] // (n_a * c)
    keep_y = max(1, min(ky, MAX_VIEW_REPEATS, max_px // (n_e * c)))
    keep_x = max(1, min(kx, MAX_VIEW_REPEATS, max_px // (n_a * c)))
    y0, x0 = (ky - keep_y) // 2, (kx - keep_x) // 2
    canvas = canvas[y0 * n_e * c:(y0 + keep_y) * n_e * c, x0 * n_a * c:(x0 + keep_x) * n_a * c]
    return PhotoView(canvas=np.ascontiguousarray(canvas, np.float32), c=c, repeats=(keep_y, keep_x), pitch_px=pitch,
                     white=white)


def view_scene(fabric: Fabric, rig, view: PhotoView, *, spp: int):
    """The :class:`weavecap.model.scene.FabricScene` of ``fabric`` under ``rig`` over the
    view's cells (its render is registered on ``view.canvas``)."""
    from ..model.scene import View, build_scene

    h, w = view.canvas.shape[:2]
    return build_scene(fabric, View(tiles=view.repeats, size=max(h, w), spp=spp), light=rig)


def shown(fs, view: PhotoView, blur_px: float) -> np.ndarray:
    """A render of a :func:`view_scene` as photographed: clipped at the view's white level,
    blurred by ``blur_px`` view pixels; (H, W, 3) float32."""
    from ..model.render import as_photographed, render_numpy

    return as_photographed(render_numpy(fs), blur_px, view.white)


def render_view(fabric: Fabric, rig, view: PhotoView, *, blur_px: float, spp: int) -> np.ndarray:
    """``fabric`` under ``rig`` over the view's cells, as photographed (:func:`shown`)."""
    return shown(view_scene(fabric, rig, view, spp=spp), view, blur_px)


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
    view : the photo over whole repeats; render : ``fabric`` rendered over it as photographed
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
        ky, kx = self.view.repeats
        head = f"photo scale, {ky}x{kx} repeats: " + self.figures.caption()
        return compare_image(exposure * self.view.canvas, exposure * self.render, exposure * repeat_photo,
                             exposure * repeat_render, [head, *("median repeat: " + c for c in captions)])


def at_photo_scale(image: np.ndarray, fitted, fabric: Fabric, *, c: int, spp: int) -> PhotoScale:
    """The fitted capture at the photo's own scale: the view of ``image`` (the rectified photo
    the fit saw) over whole repeats on ``fitted``'s registration
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
    blur_px, _ = photo_blur(render_numpy(fs), view.canvas, view.c)
    render = shown(fs, view, blur_px)
    return PhotoScale(fabric=fabric, threads=threads, view=view, render=render,
                      figures=pixel_fidelity(view.canvas, render, view.c), blur_px=blur_px)
