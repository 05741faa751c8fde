"""The weave pattern from what the photo shows, in named steps (Wu et al. 2025 §5.1's
question; docs/capture.md, "The pattern decision").

1. :func:`photo_lattice` — every whole cell of the photo's yarn lattice, not only one repeat:
   many views of each cell of the repeat are what make the decision robust;
2. :func:`source_canvas` — the cells read from the photo as loaded, 16 px a cell, at each of
   the lattice's half-cell phases (:data:`PHASES`);
3. :func:`classify_cells` — which yarn is on top in each cell, by the cell classifier
   (:mod:`.cell_classifier`): a log-odds per cell; the phase it is surest of is kept
   (:func:`confidence`);
4. :func:`score_patterns` — the log-odds folded over every repeat shape the lattice can show
   (:func:`fold`), then every named weave (:func:`weavecap.estimate.sampling.named_weaves`:
   plain, twills, satins, baskets and hopsacks, ribs, herringbones and point twills, with their
   parameters) at its best phase, and per repeat shape the best free ("custom") pattern, each
   scored by how well it explains the cells less what it costs to describe;
5. :func:`decide` — the best of them, and how sure the photo is of it: the score gap to the
   best *different* weave per cell of the lattice (its evidence, in nats a cell). From
   :data:`DECIDED_NATS` on, the pattern is fixed for the joint fit (the photo prepared again at
   its repeat where preparation found another, :func:`decide_on_photo`); short of it, the fit's
   annealing and its exploration of starts, votes and named weaves
   (:func:`weavecap.fit.rounds.fit_registered`) start from the decided pattern, where its
   repeat is preparation's.

The score is a description length (the minimum description length principle): a pattern's
log-likelihood of the cells' states under the classifier's calibrated probabilities, less
the nats needed to name it — which family (plain, twill, broken twill, satin, basket, rib;
each as likely) and which of its members for a named one (:func:`naming_cost`), one bit per
cell of the repeat (and the repeat's shape) for a custom one. A named weave thus wins unless
the photo shows, cell by cell, that the weave is something else, and a simple one unless it
shows the difference — the prior a weaver has.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from .cells import CellGrid, cell_canvas
from .cell_classifier import CELL_PX, CellClassifier, load_classifier
from .weave_name import cyclic_shifts, equal_up_to_shift, minimal_repeat, weave_family, weave_name

#: the largest repeat side the decision considers (a herringbone's legs of 12: 24 yarns)
MAX_REPEAT = 24
#: the evidence (nats per cell of the lattice) from which the decision fixes the pattern for the
#: joint fit: on the DEV real photos the patterns it names right had 0.58 or more where it was
#: sure, the wrong ones 0.25 or less; on the procedural benches 0.66 or more, and 0.05 or less
#: (docs/capture.md, "The pattern decision")
DECIDED_NATS = 0.4
#: the fewest cells a side for a lattice to be classified at all
MIN_LATTICE = 4


def photo_lattice(image: np.ndarray, cells: CellGrid) -> CellGrid:
    """Every whole cell of the lattice of ``cells`` (one repeat's cells, already on the gaps
    between yarns: :func:`weavecap.fit.target.align_cells`) inside ``image`` (H, W, ...): the
    lattice extended by its mean pitch to the image's borders. The first cell is at a whole
    number of pitches from ``cells``' first, so cell (i, j) of the lattice is cell
    (i − i0, j − j0) of ``cells`` for the returned offsets (:func:`lattice_offset`)."""
    bounds = []
    for b, size in ((cells.rows, image.shape[0]), (cells.cols, image.shape[1])):
        pitch = float(np.diff(b).mean())
        k0 = int(np.ceil((0.0 - b[0]) / pitch))
        k1 = int(np.floor((size - b[0]) / pitch))
        bounds.append(b[0] + pitch * np.arange(k0, k1 + 1))
    return CellGrid(rows=bounds[0], cols=bounds[1])


def lattice_offset(lattice: CellGrid, cells: CellGrid) -> tuple[int, int]:
    """(rows, cols): how many whole cells ``cells``' first cell lies after the lattice's first."""
    return (int(round((cells.rows[0] - lattice.rows[0]) / np.diff(lattice.rows).mean())),
            int(round((cells.cols[0] - lattice.cols[0]) / np.diff(lattice.cols).mean())))


def source_canvas(photo: np.ndarray, homography: np.ndarray, lattice: CellGrid, cell_px: int = CELL_PX) -> np.ndarray:
    """The cell canvas of ``lattice`` (rectified pixels) sampled from the photo as loaded:
    (n_e * cell_px, n_a * cell_px, 3) float32 linear RGB.

    Preparation shrinks the photo to a few pixels a yarn (§4.1's rectification keeps the pitch
    at most 16 px on one axis: 8 px a warp on some of the real photos), and a yarn's fibres and
    plies — which way its fine texture runs — are finer than that. Each canvas pixel is read
    where it lies in the photo: its rectified position (:func:`weavecap.estimate.cells.cell_canvas`'s
    layout) mapped back through the rectification's ``homography`` (photo pixel → rectified
    pixel), the photo first blurred to the canvas's sampling where it is shrunk."""
    import cv2

    from .cells import _axis_map

    ys, xs = _axis_map(lattice.rows, cell_px), _axis_map(lattice.cols, cell_px)
    gx, gy = np.meshgrid(xs, ys)
    inv = np.linalg.inv(np.asarray(homography, np.float64))
    w = inv[2, 0] * gx + inv[2, 1] * gy + inv[2, 2]
    map_x = ((inv[0, 0] * gx + inv[0, 1] * gy + inv[0, 2]) / w).astype(np.float32)
    map_y = ((inv[1, 0] * gx + inv[1, 1] * gy + inv[1, 2]) / w).astype(np.float32)
    # photo pixels per canvas pixel along the finer axis, at the canvas's centre
    step = min(np.abs(np.diff(map_x, axis=1)).mean(), np.abs(np.diff(map_y, axis=0)).mean())
    img = np.asarray(photo, np.float32)
    if step > 1.5:
        img = cv2.GaussianBlur(img, (0, 0), 0.5 * np.sqrt(step * step - 1.0), borderType=cv2.BORDER_REFLECT)
    return cv2.remap(img, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)


def classify_cells(canvas: np.ndarray, lattice: CellGrid, classifier: CellClassifier) -> np.ndarray:
    """The log-odds that the weft is on top in every cell of ``lattice`` ((n_e, n_a), calibrated
    on held-out procedural cells), from its cell canvas (:func:`source_canvas`, or
    :func:`weavecap.estimate.cells.cell_canvas` of the rectified photo)."""
    return classifier.logits(canvas, lattice.shape)


def fold(logits: np.ndarray, shape: tuple[int, int], *, weights: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The cells' log-likelihoods summed over a repeat of ``shape`` (r_e, r_a): (A1, A0), each
    (r_e, r_a), A1[k, l] = Σ log P(weft on top) and A0 the same for the warp, over the lattice's
    cells (i, j) with i ≡ k (mod r_e), j ≡ l (mod r_a) — so that a pattern p tiled from the
    lattice's first cell explains the cells with log-likelihood Σ where(p, A1, A0). ``weights``
    (n_e, n_a) weigh the cells (default 1)."""
    z = np.asarray(logits, np.float64)
    w = np.ones_like(z) if weights is None else np.asarray(weights, np.float64)
    log1 = -np.logaddexp(0.0, -z) * w
    log0 = -np.logaddexp(0.0, z) * w
    r_e, r_a = shape
    a1, a0 = np.zeros(shape), np.zeros(shape)
    for k in range(r_e):
        for l in range(r_a):
            a1[k, l] = log1[k::r_e, l::r_a].sum()
            a0[k, l] = log0[k::r_e, l::r_a].sum()
    return a1, a0


#: the largest twill or satin the library holds (n × n); ribs and baskets group up to half of it
MAX_REGULAR = 12


def named_shapes(max_repeat: int = MAX_REPEAT) -> list[tuple[int, int]]:
    """The repeat shapes the named weaves come in, up to ``max_repeat`` a side: twills and satins
    (n × n, n ≤ :data:`MAX_REGULAR`), ribs and baskets (2a × 2b), herringbones and point twills
    (n × 2k and 2k × n, n ≤ 8)."""
    shapes = {(n, n) for n in range(2, MAX_REGULAR + 1)}
    shapes |= {(2 * a, 2 * b) for a in range(1, MAX_REGULAR // 2 + 1) for b in range(1, MAX_REGULAR // 2 + 1)}
    shapes |= {s for n in range(3, 9) for c in range(4, max_repeat + 1, 2) for s in ((n, c), (c, n))}
    return sorted(s for s in shapes if max(s) <= max_repeat)


@lru_cache(maxsize=None)
def _library(shape: tuple[int, int]) -> tuple[tuple[str, np.ndarray], ...]:
    """The named weaves of a repeat ``shape`` with their prior families (:func:`naming_cost`),
    every cyclic shift of each as a stack: ((family, (shifts, r_e, r_a) uint8), ...)."""
    from .sampling import named_weave_families

    return tuple((family, cyclic_shifts(p)) for family, p in named_weave_families(shape))


@lru_cache(maxsize=None)
def family_sizes(max_repeat: int = MAX_REPEAT) -> dict[str, int]:
    """How many named weaves each prior family (plain, twill, broken twill, satin, basket, rib)
    holds up to ``max_repeat`` a side."""
    sizes: dict[str, int] = {}
    for s in named_shapes(max_repeat):
        for family, _ in _library(s):
            sizes[family] = sizes.get(family, 0) + 1
    return sizes


def naming_cost(family: str, max_repeat: int = MAX_REPEAT) -> float:
    """The nats it takes to name a weave of a prior ``family``: which family (each as likely),
    then which of its members (each as likely) — a plain weave costs log 6, one of a few
    hundred herringbones some 6 nats more."""
    sizes = family_sizes(max_repeat)
    return float(np.log(len(sizes)) + np.log(sizes[family]))


@dataclass(frozen=True)
class Candidate:
    """One pattern the decision weighed: its prior family (:func:`naming_cost`; ``custom``),
    repeat (in the lattice's phase: tiled from the lattice's first cell), log-likelihood and
    score (nats)."""

    family: str
    pattern: np.ndarray
    loglik: float
    score: float

    @property
    def name(self) -> str:
        """The weave's name (:func:`weavecap.estimate.weave_name.weave_name`)."""
        return weave_name(self.pattern)

    def to_json(self) -> dict:
        return {"name": self.name, "family": weave_family(self.name), "loglik": round(self.loglik, 2),
                "score": round(self.score, 2)}


def repeat_shapes(lattice_shape: tuple[int, int], max_repeat: int = MAX_REPEAT,
                  multiple_of: tuple[int, int] = (1, 1)) -> list[tuple[int, int]]:
    """The repeat shapes a lattice can tell: each side from 2 up to ``max_repeat`` and to the
    lattice's side (a named weave is known from one repeat's worth of cells), and a multiple of
    ``multiple_of`` (the photo's own period in yarns, where its pixels show one)."""
    n_e, n_a = lattice_shape
    return [(r_e, r_a) for r_e in range(2, min(max_repeat, n_e) + 1) for r_a in range(2, min(max_repeat, n_a) + 1)
            if r_e % multiple_of[0] == 0 and r_a % multiple_of[1] == 0]


def score_patterns(logits: np.ndarray, *, weights: np.ndarray | None = None, max_repeat: int = MAX_REPEAT,
                   multiple_of: tuple[int, int] = (1, 1)) -> list[Candidate]:
    """Every named weave at its best phase and, per repeat shape seen at least twice each way,
    the best custom pattern (when it is no named weave), scored (module docstring): a named
    weave's score is its log-likelihood less :func:`naming_cost`; a custom r_e × r_a pattern's
    is its log-likelihood less r_e r_a log 2 (one bit a cell) and log of the number of shapes.
    Only repeats that are a multiple of ``multiple_of`` are weighed. Returned best first."""
    n_e, n_a = np.shape(logits)
    shapes = repeat_shapes((n_e, n_a), max_repeat, multiple_of)
    named = set(named_shapes(max_repeat))
    shape_cost = np.log(max(1, len(shapes)))
    out: list[Candidate] = []
    for shape in shapes:
        a1, a0 = fold(logits, shape, weights=weights)
        for family, shifts in (_library(shape) if shape in named else ()):
            ll = np.where(shifts == 1, a1, a0).sum(axis=(1, 2))
            k = int(np.argmax(ll))
            out.append(Candidate(family=family, pattern=shifts[k], loglik=float(ll[k]),
                                 score=float(ll[k]) - naming_cost(family, max_repeat)))
        if 2 * shape[0] <= n_e and 2 * shape[1] <= n_a:
            p = (a1 > a0).astype(np.uint8)
            if minimal_repeat(p).shape == shape and weave_family(weave_name(p)) == "custom":
                ll = float(np.maximum(a1, a0).sum())
                out.append(Candidate(family="custom", pattern=p, loglik=ll,
                                     score=ll - shape[0] * shape[1] * np.log(2.0) - shape_cost))
    out.sort(key=lambda c: -c.score)
    return out


@dataclass(frozen=True)
class PatternDecision:
    """What :func:`decide` found.

    Attributes
    ----------
    pattern : (r_e, r_a) uint8, 1 = weft on top: the chosen weave's minimal repeat, in the
        phase of the lattice's first cell (:meth:`pattern_at` moves it to other cells').
    name, family : its name and family (:func:`weavecap.estimate.weave_name.weave_name`).
    evidence : its score less that of the best different weave, per cell of the lattice (nats;
        ≥ 0): what each cell, on average, says for it.
    decided : evidence ≥ :data:`DECIDED_NATS`: the joint fit keeps the pattern.
    lattice : the photo's lattice the cells were classified on; logits : (n_e, n_a) their log-odds.
    runner_up : the best different weave's name.
    candidates : the best few, for the report.
    phase : (rows, cols) the half cells the lattice was moved from the cells given
        (:data:`PHASES`: the one the classifier is surest on); confidences : each phase's.
    """

    pattern: np.ndarray
    name: str
    family: str
    evidence: float
    decided: bool
    lattice: CellGrid
    logits: np.ndarray
    runner_up: str
    candidates: list = field(default_factory=list)
    phase: tuple = (0.0, 0.0)
    confidences: dict = field(default_factory=dict)

    def pattern_at(self, cells: CellGrid) -> np.ndarray:
        """The pattern in the phase of ``cells`` (a repeat's cells on the same image, whole
        cells away from the lattice's)."""
        i0, j0 = lattice_offset(self.lattice, cells)
        return np.roll(self.pattern, (-i0, -j0), axis=(0, 1))

    def to_json(self) -> dict:
        """``pre_estimation.decision`` in report.json."""
        return {"weave": self.name, "family": self.family, "evidence_nats_per_cell": round(self.evidence, 3),
                "decided": self.decided, "runner_up": self.runner_up, "pattern": self.pattern.astype(int).tolist(),
                "lattice": list(self.lattice.shape), "phase": list(self.phase), "phase_confidence": self.confidences,
                "cells_confident": round(float(np.mean(np.abs(self.logits) > np.log(9.0))), 3),
                "candidates": [c.to_json() for c in self.candidates]}


#: the lattice's phases tried, in cells (rows, cols): as given, and half a cell off each way
PHASES = ((0.0, 0.0), (0.5, 0.0), (0.0, 0.5), (0.5, 0.5))


def moved(cells: CellGrid, phase: tuple[float, float]) -> CellGrid:
    """``cells`` moved by ``phase`` (rows, cols) of their mean pitch."""
    return CellGrid(rows=cells.rows + phase[0] * np.diff(cells.rows).mean(),
                    cols=cells.cols + phase[1] * np.diff(cells.cols).mean())


def confidence(logits: np.ndarray, weights: np.ndarray) -> float:
    """How sure the classifier is of a lattice's cells: the weighted mean of |2 P − 1|. On the
    crossings it is sure; half a cell off, on the gaps or between two crossings, it was trained
    to say so (:mod:`.cell_photos`), which is how :func:`decide` tells the lattice's phase."""
    p = 1.0 / (1.0 + np.exp(-np.asarray(logits, np.float64)))
    return float(np.sum(weights * np.abs(2 * p - 1)) / np.sum(weights))


def edge_weights(shape: tuple[int, int]) -> np.ndarray:
    """Half weight for the lattice's outermost cells (the classifier sees no neighbour beyond
    them), one elsewhere."""
    w = np.ones(shape)
    if min(shape) > 4:
        w[[0, -1], :] = 0.5
        w[:, [0, -1]] = 0.5
    return w


def decide(image: np.ndarray, cells: CellGrid, *, photo: np.ndarray | None = None,
           homography: np.ndarray | None = None, classifier: CellClassifier | None = None,
           max_repeat: int = MAX_REPEAT, multiple_of: tuple[int, int] = (1, 1)) -> PatternDecision | None:
    """The steps in order (module docstring) on the rectified photo ``image`` (H, W, 3) linear
    RGB and one repeat's ``cells`` in it (on the gaps between yarns); the cells are read from
    ``photo`` (as loaded) through ``homography`` (photo → rectified pixels) when both are given
    (:func:`source_canvas`); the repeat a multiple of ``multiple_of`` (wefts, warps). None when
    there is no classifier or the lattice is smaller than :data:`MIN_LATTICE` cells a side."""
    classifier = classifier or load_classifier()
    if classifier is None:
        return None
    readings = {}
    for phase in PHASES:
        lattice = photo_lattice(image, moved(cells, phase))
        if min(lattice.shape) < MIN_LATTICE:
            return None
        canvas = (source_canvas(photo, homography, lattice) if photo is not None and homography is not None
                  else cell_canvas(image, lattice, CELL_PX))
        logits = classify_cells(canvas, lattice, classifier)
        readings[phase] = (lattice, logits, confidence(logits, edge_weights(lattice.shape)))
    phase = max(readings, key=lambda k: readings[k][2])
    lattice, logits, _ = readings[phase]
    ranked = score_patterns(logits, weights=edge_weights(lattice.shape), max_repeat=max_repeat,
                            multiple_of=multiple_of)
    if not ranked:
        return None
    best = ranked[0]
    kept = [best] + [c for c in ranked[1:] if not equal_up_to_shift(c.pattern, best.pattern)][:4]
    cells_seen = float(edge_weights(lattice.shape).sum())
    evidence = (best.score - kept[1].score) / cells_seen if len(kept) > 1 else float("inf")
    return PatternDecision(pattern=minimal_repeat(best.pattern), name=best.name, family=weave_family(best.name),
                           evidence=float(evidence), decided=bool(evidence >= DECIDED_NATS), lattice=lattice,
                           logits=logits, runner_up=kept[1].name if len(kept) > 1 else "", candidates=kept,
                           phase=phase, confidences={f"{k[0]:g},{k[1]:g}": round(v[2], 3) for k, v in readings.items()})


def photo_period(prepared) -> tuple[int, int]:
    """The period (wefts, warps) preparation found in the photo's pixels — a dip of a DMF
    (§4.3), the repeat of a 2/2 twill's complement counted once — along the axes where it found
    one, 1 along the others: any repeat of the fabric is a multiple of it."""
    checks = prepared.checks
    out = []
    for n, source, doubled in zip(prepared.grid.yarns, checks.get("repeat_from", ("", "")),
                                  checks.get("repeat_doubled", (False, False))):
        out.append((n // 2 if doubled else n) if source in ("cells", "pixels") else 1)
    return out[0], out[1]


def decide_on_photo(rgb: np.ndarray, prepared, cells: CellGrid, *, classifier: CellClassifier | None = None):
    """:func:`decide` on a prepared photo, and its preparation at the decided repeat.

    ``prepared`` (:class:`weavecap.prepare.Prepared`) and ``cells`` (one repeat in the
    regularized box, on the gaps: :func:`weavecap.fit.target.align_cells`) as the runner has
    them; ``rgb`` the photo as loaded. The cells are moved onto the decision's lattice (its
    phase). Where the weave decided (:attr:`PatternDecision.decided`) repeats over another
    number of yarns than preparation's repeat (a twill whose 2 × 2 look preparation took for the repeat,
    a satin it read as 3 × 3), the photo is prepared again with that repeat given — the kernel
    PCA of §4.2 averages over repeats, and over the wrong ones it blurs the weave away — unless
    that preparation fails, when the first is kept and the decision dropped.

    The repeats weighed are multiples of the period preparation measured in the photo's pixels
    (:func:`photo_period`). Returns (prepared, cells, decision or None)."""
    from ..errors import ParamsError
    from ..fit.target import align_cells, repeat_cells, shifted
    from ..prepare import Rejected, prepare_photo

    decision = decide(prepared.rectification.image, shifted(cells, prepared.regularized.box), photo=rgb,
                      homography=prepared.rectification.homography, classifier=classifier,
                      multiple_of=photo_period(prepared))
    if decision is None:
        return prepared, cells, decision
    if decision.pattern.shape != cells.shape and not decision.decided:  # a start only where it fits the repeat
        return prepared, cells, decision
    if decision.pattern.shape != cells.shape:
        try:
            again = prepare_photo(rgb, repeat=decision.pattern.shape)
        except ParamsError:  # more yarns than the photo shows
            again = None
        if again is None or isinstance(again, Rejected):
            return prepared, cells, None
        prepared, cells = again, align_cells(again.regularized.image, repeat_cells(again, again.regularized.box))
        # on the decision's lattice: the new repeat's cells a whole number of cells from it
        box = prepared.regularized.box
        here = shifted(cells, box)
        step = (np.diff(here.rows).mean(), np.diff(here.cols).mean())
        off = [((h[0] - l[0]) / d) % 1.0 for h, l, d in ((here.rows, decision.lattice.rows, step[0]),
                                                       (here.cols, decision.lattice.cols, step[1]))]
        return prepared, moved(cells, tuple(-(o if o < 0.5 else o - 1.0) for o in off)), decision
    return prepared, moved(cells, decision.phase), decision
