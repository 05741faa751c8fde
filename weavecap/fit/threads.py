"""Thread colours of a captured fabric: a colour per warp end and weft pick, solved on the photo.

After the joint fit (§6) the fabric has one colour per yarn family, fitted on the photo's
median repeat. A yarn-dyed fabric's threads differ: :mod:`weavecap.estimate.thread_colours`
finds each family's colour order on the photo at its own scale (:mod:`weavecap.fit.compare`'s
view, every whole cell), read against the fitted fabric's render in its family colours, and
this stage solves each palette entry's body colours with
everything else of the fitted fabric held, as :func:`weavecap.fit.joint.match_family_colours`
does for the family colours (§5.2), per entry: the render is linear in the body colours, so
with one render of the view whose ordered families are black (``dark``) and one at the
current colours, each channel of an entry is scaled by the median, over its threads, of
``(photo − dark) / (render − dark)`` at the threads' float centres. The clipping at the
camera's white and the blur across yarn edges make that a step, not the solution: it is
repeated :data:`SOLVE_ROUNDS` times. R^B and S^B scale together (the photo does not tell them
apart, as for the families). A family whose threads are one colour keeps its own.
"""

from __future__ import annotations

import numpy as np

from ..params import Fabric, PaletteEntry, ThreadColours, Threads
from .photo_view import PhotoView, shown, view_scene

#: rounds of the per-entry scaling (the first lands within a few ΔE, the rest take up the
#: clipping and the blur across yarn edges)
SOLVE_ROUNDS = 3
#: an entry's starting colour, per channel, is its family's, at least this (a family colour
#: at 0 could not be scaled to a stripe's colour)
START_FLOOR = 0.05
#: a thread's render must lift its colour above the dark render by this much (linear) for its
#: ratio to count
MIN_SIGNAL = 1e-3
#: the middle share of a cell across a yarn that the yarn fills (:func:`flattening_factor`)
YARN_BAND = 0.7
#: the largest gain (and smallest, inverted) a pixel is flattened by
MAX_FLATTENING = 4.0
#: a palette entry a family may be flattened to is worn by at least this share of its threads
REFERENCE_SHARE = 0.25


def _orders_threads(orders: dict, entries: dict, first: tuple[int, int]) -> Threads:
    """:class:`Threads` with each ordered family's sequence and these entry colours
    (``entries[family]``: (P, 2, 3) R^B and S^B per entry). The orders were read on a canvas
    whose first cell is cell ``first`` (v0, u0) of a repeat: a params file counts threads from
    the repeat's, so each sequence turns by that many threads."""
    def order(family: str, shift: int) -> ThreadColours | None:
        if family not in orders:
            return None
        palette = tuple(PaletteEntry(tuple(float(v) for v in e[0]), tuple(float(v) for v in e[1]))
                        for e in np.clip(entries[family], 0.0, 1.0))
        return ThreadColours(palette=palette, sequence=tuple(int(k) for k in np.roll(orders[family].sequence, shift)))

    return Threads(warp=order("warp", first[1]), weft=order("weft", first[0]))


def thread_delta_e(photo: dict, render: dict) -> dict:
    """Per family, CIEDE2000 between each thread's colour in the photo and in the render
    ({"warp": (N,), ...}, NaN for threads never on top)."""
    from skimage.color import deltaE_ciede2000

    from ..estimate.colour import linear_to_lab

    out = {}
    for family in photo:
        a, b = np.asarray(photo[family]), np.asarray(render[family])
        ok = np.all(np.isfinite(a), axis=1) & np.all(np.isfinite(b), axis=1)
        de = np.full(len(a), np.nan)
        if ok.any():
            de[ok] = deltaE_ciede2000(linear_to_lab(np.clip(a[ok], 0, 1)), linear_to_lab(np.clip(b[ok], 0, 1)))
        out[family] = de
    return out


def capture_threads(view: PhotoView, fabric: Fabric, rig, *, blur_px: float, spp: int,
                    rounds: int = SOLVE_ROUNDS) -> tuple[Fabric, dict]:
    """``fabric`` with the thread colours the photo shows (unchanged where each family is one
    colour), and the report's note: per family its colour order
    (:meth:`weavecap.estimate.thread_colours.ColourOrder.to_json`) and each thread's CIEDE2000
    against the photo's, before (family colours) and after the solve.

    Parameters
    ----------
    view : the photo at its own scale over whole cells (:func:`weavecap.fit.photo_view.photo_view`)
    fabric : the fitted fabric (family colours)
    rig : the fitted light rig (its gain)
    blur_px : the photo's blur in view pixels
    spp : samples per pixel of the renders
    """
    from ..estimate.thread_colours import colour_order, thread_colours

    pattern, c = fabric.pattern, view.c
    photo = thread_colours(view.canvas, pattern, c, first=view.first)
    fs = view_scene(fabric, rig, view, spp=spp)  # one geometry; each render re-shades it
    before = thread_colours(shown(fs, view, blur_px), pattern, c, first=view.first)  # the family colours
    orders = {family: o for family in ("warp", "weft")
              if (o := colour_order(photo[family], reference=before[family])) is not None}
    if not orders:
        return fabric, {"colour_orders": {}}

    def measure(entries: dict) -> dict:
        fs.set_threads(_orders_threads(orders, entries, view.first))
        return thread_colours(shown(fs, view, blur_px), pattern, c, first=view.first)

    family_colour = {f: np.stack([np.asarray(fabric.get(f"{f}.body_reflection"), np.float64),
                                  np.asarray(fabric.get(f"{f}.body_subsurface"), np.float64)]) for f in orders}
    entries = {f: np.repeat(np.maximum(family_colour[f], START_FLOOR)[None], len(orders[f].palette), axis=0)
               for f in orders}
    dark = measure({f: np.zeros_like(e) for f, e in entries.items()})
    for _ in range(rounds):
        measured = measure(entries)
        for f, order in orders.items():
            signal = measured[f] - dark[f]
            wanted = photo[f] - dark[f]
            for q in range(len(order.palette)):
                mine = (order.labels == q)[:, None] & np.isfinite(signal) & np.isfinite(wanted) & (signal > MIN_SIGNAL)
                for ch in range(3):
                    if mine[:, ch].any():
                        scale = float(np.median(wanted[mine[:, ch], ch] / signal[mine[:, ch], ch]))
                        entries[f][q, :, ch] = np.clip(entries[f][q, :, ch] * max(scale, 0.0), 0.0, 1.0)
    measured = measure(entries)
    de_before, de_after = thread_delta_e(photo, before), thread_delta_e(photo, measured)
    note = {}
    for f, order in orders.items():
        note[f] = {**order.to_json(), "delta_e_before": _summary(de_before[f]), "delta_e": _summary(de_after[f])}
    return fabric.with_threads(_orders_threads(orders, entries, view.first)), {"colour_orders": note}


def _summary(values: np.ndarray) -> dict:
    """Median and largest of per-thread ΔE (threads never on top left out)."""
    v = np.asarray(values)[np.isfinite(values)]
    if not v.size:
        return {"median": None, "max": None}
    return {"median": round(float(np.median(v)), 2), "max": round(float(v.max()), 2)}


def flattened(prepared, cells, start: Fabric, *, spp: int) -> tuple[object, dict]:
    """The prepared photo with its thread colours divided out, for the joint fit, and the
    report's note.

    The fit compares one repeat of the fabric with the photo's median repeat (§6): on a
    yarn-dyed fabric that median mixes the colours of whichever threads each repeat holds, and
    the fit explains the mixture with its other parameters (the highlights, the transmission),
    which no thread colour solved afterwards can undo. So where the photo shows a colour order
    (:func:`weavecap.estimate.thread_colours.colour_order`, read on ``cells`` with the weave
    of ``start``, the pre-estimate, against a render of it, and repeating at least twice across
    the photo), each cell of the rectified photo is scaled,
    per channel, by its top thread's palette entry's colour over the family's reference entry's
    (:func:`flattening_references`): the fit then sees one colour per family, and the other
    entries are solved after it (:func:`capture_threads`) on the photo as shot.

    Parameters
    ----------
    prepared : :class:`weavecap.prepare.Prepared`; only its rectified image changes
    cells : the repeat's cells in the regularized box's pixels
    start : the pre-estimated fabric (its weave; its render is the one-colour reference)
    spp : samples per pixel of that render

    Returns
    -------
    (prepared, note): ``prepared`` itself and ``{}`` where no family shows a colour order.

    Only a colour order the photo repeats, over a repeat that is no multiple of the weave's, is
    trusted this early: the pre-estimate's weave is often wrong, and read with a wrong weave a
    plain-dyed family's threads differ by whatever yarns the misread cells hold — the DEV
    twill W103 (black warp, white weft) read a 10-end warp order seen once, was flattened along
    it and fitted as a custom 4×4 at 8.4 dB; the fit bench's plain-dyed custom 2×3, its weave
    read a cell off, a 3-end warp and a 2-pick weft order (the weave's own repeats), and its
    capture came out striped (pixel ΔE p90 32). A misreading repeats with the weave; a colour
    order that does too is left to the solve after the fit.
    """
    import dataclasses

    from ..estimate.thread_colours import colour_order, thread_colours
    from .photo_view import view_cell_px
    from .target import cells_canvas, shifted

    from ..estimate.forward import BLUR_CELLS, RepeatRenderer
    from ..model.render import as_photographed, white_level

    image = np.asarray(prepared.rectification.image, np.float32)
    pattern = start.pattern
    grid = shifted(cells, prepared.regularized.box)
    c, _ = view_cell_px(grid)
    # read on the cells as they are: registered on a render of the one-colour pre-estimate (and
    # its drift followed), a photo whose repeats differ in colour pulls them along its stripes —
    # on the synthetic check a whole cell off, the photo flattened along the wrong threads, and
    # each thread's colour after the fit up to ΔE 26 off (5.5 read as they are)
    canvas, first, lattice = cells_canvas(image, grid, c)
    measured = thread_colours(canvas, pattern, c, first=first)
    n_e, n_a = pattern.shape
    rows, cols = canvas.shape[0] // c, canvas.shape[1] // c
    model = as_photographed(RepeatRenderer(start, cell_px=c, spp=spp, blur_cells=0.0).render(), BLUR_CELLS * c,
                            white_level(image))
    tiled = np.tile(model, (-(-(rows + first[0]) // n_e), -(-(cols + first[1]) // n_a), 1))
    reference = thread_colours(tiled[first[0] * c:(first[0] + rows) * c, first[1] * c:(first[1] + cols) * c],
                               pattern, c, first=first)
    orders = {f: o for f, n in (("warp", n_a), ("weft", n_e))
              if (o := colour_order(measured[f], reference=reference[f])) is not None and o.seen_twice
              and o.repeat % n != 0}
    if not orders:
        return prepared, {}
    references = flattening_references(orders, measured)
    factor = flattening_factor(image.shape[:2], lattice, pattern, orders, references, first=first)
    out = dataclasses.replace(prepared, rectification=dataclasses.replace(prepared.rectification,
                                                                           image=(image * factor).astype(np.float32)))
    return out, {f: {**o.to_json(), "flattened_to": references[f]} for f, o in orders.items()}


def flattening_factor(shape: tuple[int, int], lattice, pattern: np.ndarray, orders: dict,
                      references: dict, *, first: tuple[int, int] = (0, 0)) -> np.ndarray:
    """(H, W, 3) per-pixel gains that give every thread of an ordered family the colour of its
    palette entry ``references[family]`` (:func:`flattening_references`), for an image of
    ``shape`` whose lattice of cells is ``lattice`` (thread 0 of the orders at its first cell,
    which is cell ``first`` of a repeat; the lattice extends beyond the image's border as far as
    it must).

    Model-free, per cell: the yarn on top fills the middle :data:`YARN_BAND` of the cell across
    its own direction (a warp's columns, a weft's rows), which takes its thread's gain; the rest
    (the gaps, which show the backdrop that fixes the rig's gain, and the crossing yarn's edges
    beside them) keeps 1. Gains are held within [1 / :data:`MAX_FLATTENING`,
    :data:`MAX_FLATTENING`]: a highlight on a dark thread is no brighter for being scaled, so a
    stronger gain would make highlights the fit explains away."""
    from scipy.ndimage import gaussian_filter

    n_e, n_a = np.asarray(pattern).shape
    h, w = shape
    pitch_y, pitch_x = float(np.diff(lattice.rows).mean()), float(np.diff(lattice.cols).mean())
    ty = (np.arange(h) + 0.5 - lattice.rows[0]) / pitch_y  # position in wefts
    tx = (np.arange(w) + 0.5 - lattice.cols[0]) / pitch_x  # ... in warps
    row, col = np.floor(ty).astype(int), np.floor(tx).astype(int)
    gain = {}
    for family, index in (("warp", col), ("weft", row)):
        order = orders.get(family)
        if order is None:
            gain[family] = np.ones((index.size, 3), np.float32)
            continue
        ratio = order.palette[references[family]] / np.maximum(order.palette, 1e-4)
        gain[family] = np.clip(ratio, 1 / MAX_FLATTENING, MAX_FLATTENING)[order.sequence[index % order.repeat]]
    in_warp = np.abs(tx - col - 0.5) < YARN_BAND / 2  # (w,): within the middle band of a warp's column
    in_weft = np.abs(ty - row - 0.5) < YARN_BAND / 2  # (h,)
    weft_on_top = np.asarray(pattern)[(row[:, None] + first[0]) % n_e, (col[None, :] + first[1]) % n_a] == 1
    factor = np.ones((h, w, 3), np.float32)
    factor = np.where((~weft_on_top & in_warp[None, :])[..., None], gain["warp"][None, :, :], factor)
    factor = np.where((weft_on_top & in_weft[:, None])[..., None], gain["weft"][:, None, :], factor)
    return gaussian_filter(factor, (1.0, 1.0, 0), mode="nearest")


def flattening_references(orders: dict, measured: dict) -> dict:
    """The palette entry each ordered family is flattened to (:func:`flattened`): of the entries
    worn by at least :data:`REFERENCE_SHARE` of its threads (the commonest at least), the pair
    (or, with one family ordered, the entry) furthest in CIELAB from the other family — its
    entry, or the median of its threads' ``measured`` colours. The fit tells a weave from its
    dual by the families' colours as much as by their shapes: flattened to one colour (a check
    of white, navy and red both ways, flattened to white and white) the synthetic check's fit
    took its dual."""
    from itertools import product

    from ..estimate.colour import linear_to_lab

    options = {}
    for family in ("warp", "weft"):
        order = orders.get(family)
        if order is None:
            colours = np.asarray(measured[family], np.float64)
            options[family] = [(None, np.nanmedian(colours, axis=0))]
            continue
        share = np.bincount(order.sequence, minlength=len(order.palette)) / order.repeat
        keep = [int(k) for k in np.flatnonzero(share >= min(REFERENCE_SHARE, share.max()))]
        options[family] = [(k, order.palette[k]) for k in keep]

    def distance(pair) -> float:
        (_, a), (_, b) = pair
        return float(np.linalg.norm(linear_to_lab(np.clip(a, 0, 1)) - linear_to_lab(np.clip(b, 0, 1))))

    best = max(product(options["warp"], options["weft"]), key=distance)
    return {family: entry for family, (entry, _) in zip(("warp", "weft"), best) if family in orders}
