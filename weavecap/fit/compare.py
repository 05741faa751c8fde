"""The capture beside its photo at the photo's own scale: the view, the render, compare.png.

The fit works on the photo's median repeat (:mod:`weavecap.fit.target`); a person judges a
capture against what they shot: several repeats, each thread in its colour, the photo's own
irregularities. The view (:mod:`weavecap.fit.photo_view`) is the rectified photo over every
whole cell of the fitted lattice, with the captured fabric rendered over the same cells as
photographed, registered pixel for pixel; the pixel figures
(:func:`weavecap.fit.fidelity.pixel_fidelity`), the thread colours
(:mod:`weavecap.fit.threads`) and compare.png (:func:`compare_image`: photo | fit |
difference, the median repeat beside them, the figures below) are made from them.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..params import Fabric
from .photo_view import PhotoView, photo_view, shown, view_scene

#: compare.png's difference panel: |photo − fit| times this
DIFFERENCE_GAIN = 4.0


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
    (:func:`weavecap.fit.fidelity.pixel_fidelity`) with the highest structure a capture that
    repeats as this one does could reach on the view (:func:`weavecap.fit.fidelity.structure_ceiling`).

    The render is shown with the camera's blur measured on the view itself
    (:func:`weavecap.fit.target.photo_blur`, held to 0.9 of the photo's sharpness as the
    fit's is): the fit's blur (``fitted.blur_px`` at ``c`` px a cell) is that of the median
    repeat, smoother than any one repeat of the photo — a synthetic check fitted at 5.7 ΔE p90
    showed half the photo's sharpness with it. The thread colours are solved with the fit's
    blur scaled to the view (they are read at the yarns' centres, which a blur hardly moves)."""
    from .fidelity import pixel_fidelity, structure_ceiling
    from .threads import capture_threads

    from ..model.render import render_numpy
    from .target import photo_blur

    view = photo_view(image, fitted.cells, fitted.drift)
    fabric, threads = capture_threads(view, fabric, fitted.rig, blur_px=fitted.blur_px * view.c / c, spp=spp)
    fs = view_scene(fabric, fitted.rig, view, spp=spp)
    sharp = render_numpy(fs)
    blur_px, _ = photo_blur(shown(fs, view, 0.0, sharp), view.canvas, view.c)
    render = shown(fs, view, blur_px, sharp)
    figures = dataclasses.replace(pixel_fidelity(view.canvas, render, view.c),
                                  structure_ceiling=structure_ceiling(view.canvas, view.c, fabric.full_repeat, view.first))
    return PhotoScale(fabric=fabric, threads=threads, view=view, render=render, figures=figures, blur_px=blur_px)
