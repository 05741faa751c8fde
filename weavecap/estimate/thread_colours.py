"""Yarn-dyed colour orders from a photo: each thread's colour, the palette and the colour repeat.

Wu et al. 2025 give each yarn family one colour (§5.2); a yarn-dyed fabric (stripes, checks,
plaids, colour-and-weave effects) has a colour per thread, repeating over a *colour repeat*
that need not be the weave's. This stage reads them off the photo, model-free, on the
registered lattice of the fitted weave over every whole cell the photo holds (a canvas of
``c`` px a cell, :func:`weavecap.fit.target.cells_canvas`):

1. **each thread's colour** (:func:`thread_colours`) — the median linear colour of the centres
   of the cells where that warp end (weft pick) lies on top, first per cell, then over the
   cells: a float seen in many cells along the thread, so a hair, a flaw or a highlight in a
   few of them does not move it;
2. **the palette** (:func:`colour_order`) — the threads' colours clustered in CIELAB
   (average linkage, cut at :data:`SPLIT_DELTA_E`; a colour worn by one thread alone joins
   the nearest other): threads of one yarn colour differ by the photo's noise and its uneven
   light, different yarn colours by more. A family whose threads fall in one cluster, or of
   fewer than :data:`MIN_THREADS` threads seen, is plain-dyed and keeps its one colour;
3. **the colour repeat** — the shortest period of the threads' palette entries that the photo
   shows at least twice with no thread disagreeing (a misread thread would otherwise shorten
   it); where none is seen twice, the colour order of every thread the photo shows is the
   repeat.

Shapes: a canvas of Y × X cells at ``c`` px a cell is (Y·c, X·c, 3) linear RGB; threads are
counted from its top-left cell (which is pattern cell ``first``).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

#: threads whose colours (CIELAB, average linkage) are further apart than this are different
#: yarn colours; the one value tried: the bar for a faithful pixel colour (p90 ≤ 12), and
#: about twice how far a thread's cells lie from its colour (median ΔE76 3.8–6.7 on the DEV
#: plain weaves W027–W031, read on their pre-estimate's cells)
SPLIT_DELTA_E = 12.0
#: the middle share of each cell side whose pixels count (as the fidelity figures' family masks)
CENTRE_SHARE = 0.5
#: a family needs at least this many threads seen for a colour order: on fewer, a thread read
#: off its yarn (a cell a fraction of a pitch off at the photo's edge) passes for a stripe
MIN_THREADS = 8


def thread_colours(canvas: np.ndarray, pattern: np.ndarray, c: int, *, first: tuple[int, int] = (0, 0),
                   centre_share: float = CENTRE_SHARE) -> dict[str, np.ndarray]:
    """Each thread's colour on a canvas of whole cells: the median, over the cells where it
    lies on top, of each cell centre's median linear colour.

    Parameters
    ----------
    canvas : (Y·c, X·c, 3) linear RGB, cell (v, u) being pattern cell ((v + v0) mod n_e,
        (u + u0) mod n_a) for ``first`` = (v0, u0).
    pattern : (n_e, n_a), 1 = weft over warp.
    c : canvas px per cell.

    Returns
    -------
    {"warp": (X, 3), "weft": (Y, 3)} float64; NaN rows for a thread never on top.
    """
    p = np.asarray(pattern)
    n_e, n_a = p.shape
    a = np.asarray(canvas, np.float64)
    rows, cols = a.shape[0] // c, a.shape[1] // c
    lo = int(round((0.5 - centre_share / 2) * c))
    hi = max(lo + 1, int(round((0.5 + centre_share / 2) * c)))
    blocks = a[: rows * c, : cols * c].reshape(rows, c, cols, c, 3)[:, lo:hi, :, lo:hi]
    cell = np.median(blocks.transpose(0, 2, 1, 3, 4).reshape(rows, cols, -1, 3), axis=2)  # (rows, cols, 3)
    weft_on_top = p[(np.arange(rows)[:, None] + first[0]) % n_e, (np.arange(cols)[None, :] + first[1]) % n_a] == 1
    out = {}
    for family, shown, axis in (("warp", ~weft_on_top, 0), ("weft", weft_on_top, 1)):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # a thread never on top: NaN
            out[family] = np.nanmedian(np.where(shown[..., None], cell, np.nan), axis=axis)
    return out


@dataclass(frozen=True)
class ColourOrder:
    """One family's colour order as the photo shows it.

    Attributes
    ----------
    labels : (N,) int, the palette entry of each thread the photo shows (-1: never on top)
    repeat : threads in the colour repeat
    sequence : (repeat,) int, the palette entry of each thread of the repeat, thread k of the
        repeat being thread k, k + repeat, ... of the photo
    palette : (P, 3) linear RGB, each entry's median colour in the photo
    seen_twice : whether the photo shows the repeat at least twice (else it is every thread seen)
    """

    labels: np.ndarray
    repeat: int
    sequence: np.ndarray
    palette: np.ndarray
    seen_twice: bool

    def to_json(self) -> dict:
        """report.json's note on it."""
        return {"repeat": int(self.repeat), "colours": int(len(self.palette)), "seen_twice": bool(self.seen_twice),
                "sequence": self.sequence.astype(int).tolist()}


def cluster_colours(lab: np.ndarray, *, split_delta_e: float = SPLIT_DELTA_E) -> np.ndarray:
    """(N,) cluster labels, 0.., of CIELAB colours (N, 3): average linkage of their Euclidean
    distances (ΔE 1976) cut at ``split_delta_e``, a cluster of one thread joined to the nearest
    other (one thread alone is as likely a misread as a stripe), numbered by first appearance."""
    from scipy.cluster.hierarchy import fcluster, linkage

    if len(lab) < 2:
        return np.zeros(len(lab), int)
    raw = fcluster(linkage(lab, method="average"), t=split_delta_e, criterion="distance")
    while True:
        ids, counts = np.unique(raw, return_counts=True)
        if len(ids) < 2 or counts.min() > 1:
            break
        alone = ids[np.argmin(counts)]
        others = ids[ids != alone]
        centres = np.stack([lab[raw == k].mean(axis=0) for k in others])
        raw[raw == alone] = others[np.argmin(np.linalg.norm(centres - lab[raw == alone][0], axis=1))]
    _, first, inverse = np.unique(raw, return_index=True, return_inverse=True)
    rank = np.argsort(np.argsort(first))
    return rank[inverse.ravel()]


def colour_repeat(labels: np.ndarray) -> tuple[int, bool]:
    """The shortest period ``k`` of ``labels`` (N,) (-1 entries: unknown, never disagreeing)
    under which every thread agrees with every other thread ``k`` apart, and that the
    labels hold at least twice (``k <= N / 2``): (k, True); none: (N, False)."""
    n = len(labels)
    known = labels >= 0
    for k in range(1, n // 2 + 1):
        a, b = labels[:-k], labels[k:]
        both = known[:-k] & known[k:]
        if np.all(a[both] == b[both]):
            return k, True
    return n, False


def colour_order(colours: np.ndarray, *, reference: np.ndarray | None = None,
                 split_delta_e: float = SPLIT_DELTA_E) -> ColourOrder | None:
    """The colour order of one family from its threads' colours (N, 3) linear RGB (NaN rows:
    threads never on top), or None when they are one yarn colour (a plain-dyed family).

    ``reference`` (N, 3): the same threads read the same way on a render of the fabric in one
    colour per family. Threads are then told apart by how far their colour is from the
    render's (CIELAB differences), not by their colour: what a thread's cell centres show
    depends on the weave as well as on its yarn — a thin warp's centres show the weft beside
    it, a long float is lit otherwise than a crossing — and a plain-dyed custom 2×3 of the fit
    bench read as a 3-end warp order and a 2-pick weft order (ΔE up to 42 between threads of
    one colour) without it."""
    from .colour import linear_to_lab

    colours = np.asarray(colours, np.float64)
    seen = np.all(np.isfinite(colours), axis=1)
    if reference is not None:
        seen &= np.all(np.isfinite(reference), axis=1)
    if seen.sum() < MIN_THREADS:
        return None
    lab = linear_to_lab(np.clip(colours[seen], 0.0, 1.0))
    if reference is not None:
        lab = lab - linear_to_lab(np.clip(np.asarray(reference, np.float64)[seen], 0.0, 1.0))
    found = cluster_colours(lab, split_delta_e=split_delta_e)
    if found.max() == 0:
        return None
    labels = np.full(len(colours), -1)
    labels[seen] = found
    repeat, twice = colour_repeat(labels)
    sequence = np.empty(repeat, int)
    for k in range(repeat):  # the entry each thread of the repeat wears (the majority where seen)
        votes = labels[k::repeat]
        votes = votes[votes >= 0]
        sequence[k] = np.bincount(votes).argmax() if votes.size else 0
    used = np.unique(sequence)  # entries only unseen threads would wear are dropped
    renumber = {int(e): i for i, e in enumerate(used)}
    sequence = np.array([renumber[int(e)] for e in sequence])
    labels = np.array([renumber.get(int(e), -1) for e in labels])
    palette = np.stack([np.median(colours[labels == i], axis=0) for i in range(len(used))])
    if len(palette) < 2:
        return None
    return ColourOrder(labels=labels, repeat=int(repeat), sequence=sequence, palette=palette, seen_twice=twice)
