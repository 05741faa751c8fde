"""The pre-estimation stage (Wu et al. 2025 §5): pattern, colours and parameters from one
regularized photo and its cell grid, as the start of the joint fit (§6).

Order: (1) the pattern by batched annealing (§5.1) against a default fabric whose warps and
wefts share one grey that matches the photo's brightness ("twill and grey", Fig. 6);
(2) the initializer network (§5.3) on the photo and that pattern; then radii (a search over
Table 1's range by the annealing objective, the network's guess among the values tried) and
pattern in turn until the pattern is stable (:func:`.pattern.estimate_pattern`); the
network's other parameters are kept — kept only if its fabric renders
closer to the photo than the Table 1 defaults do, so an input the network never saw falls
back to the defaults (§7.3); (3) colours (§5.2) with those parameters; (4) the pattern again
from (1)'s answer with the now better fabric, then the colours again.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..model.render import white_level
from ..params import Fabric, from_dict
from .cells import CellGrid, cell_canvas
from .colour import Colours, estimate_colours
from .forward import RepeatRenderer
from .initializer import CELL_PX, Predictor, default_values, load_predictor
from .pattern import PatternResult, anneal_pattern, estimate_pattern, twill_start
from .weave_name import weave_name

PATTERN_CELL_PX = 12  # pixels per cell of the canvas the pattern and colours are fitted on


def default_fabric(pattern: np.ndarray) -> Fabric:
    """A fabric with ``pattern`` and the middle of every Table 1 range (§7.3's default start)."""
    doc = {"format": "weavecap.params/1", "pattern": np.asarray(pattern).astype(int).tolist(),
           "warp": {}, "weft": {}, "specular": {}, "shadowing": {}}
    for key, value in default_values().items():
        node = doc
        *parents, leaf = key.split(".")
        for part in parents:
            node = node[part]
        node[leaf] = list(value) if isinstance(value, tuple) else value
    return from_dict(doc)


@dataclass(frozen=True)
class PreEstimate:
    """The result of :func:`pre_estimate`.

    Attributes
    ----------
    fabric : the pre-estimated fabric (pattern, colours, every other parameter).
    pattern : :class:`~.pattern.PatternResult` of the last annealing.
    colours : :class:`~.colour.Colours`.
    source : ``"network"`` or ``"defaults"`` (where the non-colour parameters came from), and
        ``reason`` why.
    weave : the weave's name for people.
    mse : the pre-estimated fabric's render against the photo's canvas at its own pitch
        (linear RGB²).
    timings_s : seconds per step.
    gain : the photo's exposure against the light rig, at least 1: the gain at which a
        first estimate's largest body colour (§5.2, :attr:`~.colour.Colours.exposure`) is 1. Everything
        above was estimated on the photo divided by it (the fit solves its own gain). A
        well exposed white yarn sits at 0.6–0.9 while the rig's white fabric renders at a
        median of 0.18: estimated on the photo as it is, every colour ended at its clamp,
        the radius search went to the corners of its grid and the fit started from there (an
        independent bench twill 2/1 at 0.85 stop over: body colours 1, radii 5 and 1, then
        a gain of 53 and a render blown to white).
    """

    fabric: Fabric
    pattern: PatternResult
    colours: Colours
    source: str
    reason: str
    weave: str
    mse: float
    timings_s: dict = field(default_factory=dict)
    gain: float = 1.0

    def to_json(self) -> dict:
        """The ``pre_estimation`` part of report.json."""
        return {"weave": self.weave, "pattern": self.fabric.pattern.astype(int).tolist(),
                "pattern_sweeps": self.pattern.sweeps, "pattern_renders": self.pattern.renders,
                "weakest_cell_margin": float(self.pattern.margin.min()),
                "colours": {"warp": list(self.colours.warp), "weft": list(self.colours.weft),
                            "specular": list(self.colours.specular),
                            "specular_visible": self.colours.specular_visible},
                "parameters_from": self.source, "reason": self.reason, "mse": self.mse,
                "exposure_gain": round(self.gain, 4),
                "timings_s": {k: round(v, 3) for k, v in self.timings_s.items()}}


def _grey(colours: Colours) -> tuple:
    """One body colour for both yarns: the mean of the two."""
    return tuple(float(v) for v in 0.5 * (np.asarray(colours.warp) + np.asarray(colours.weft)))


def colour_cell_px(grid: CellGrid) -> int:
    """Canvas scale for the colours: the photo's own pitch (in [8, 24] px). Resampling thin,
    bright gaps to another scale biases the cell averages that the colours are solved from."""
    pitch = min(np.diff(grid.rows).mean(), np.diff(grid.cols).mean())
    return int(np.clip(round(pitch), 8, 24))


def _coloured(fabric: Fabric, image: np.ndarray, grid: CellGrid, light: str) -> tuple[Fabric, Colours, RepeatRenderer]:
    """``fabric`` with the colours of §5.2, and a renderer of it at the photo's own pitch."""
    px = colour_cell_px(grid)
    rr = RepeatRenderer(fabric, cell_px=px, light=light)
    colours = estimate_colours(cell_canvas(image, grid, px), fabric, cell_px=px, light=light, renderer=rr)
    return fabric.replace(colours.values()), colours, rr


def _first_colours(canvas: np.ndarray, start: np.ndarray, light: str) -> tuple[RepeatRenderer, Colours]:
    """§5.2's colours of a default fabric woven as ``start`` (the "twill and grey" start,
    Fig. 6) on a :data:`PATTERN_CELL_PX` canvas, and its renderer."""
    rr = RepeatRenderer(default_fabric(start), cell_px=PATTERN_CELL_PX, light=light)
    return rr, estimate_colours(canvas, rr.fabric, cell_px=PATTERN_CELL_PX, renderer=rr)


def photo_exposure(image: np.ndarray, grid: CellGrid, *, light: str = "both") -> float:
    """The photo's exposure against the light rig (a property of the photo, not of the fabric):
    the gain g at which the §5.2 colours of the default twill start are all within reach, the
    largest at 1 (:attr:`~.colour.Colours.exposure`); 1 where no g does.

    Proportional to the photo: the same fabric a stop darker gives half the exposure, so a
    photo divided by it reads the same whatever the camera's exposure (exposure invariance).
    A single photo cannot tell a grey fabric from a white one a stop darker; this puts the
    brightest yarn colour at the rig's reach, and a back light seen through the gaps, which
    the fit's gain solve reads (:func:`weavecap.fit.joint.solve_colours`), fixes the rest.

    image : (H, W, 3) linear RGB, the regularized photo; grid : one repeat's cells in it.
    """
    canvas = cell_canvas(image, grid, PATTERN_CELL_PX)
    exposure = _first_colours(canvas, twill_start(grid.shape), light)[1].exposure
    return float(exposure) if np.isfinite(exposure) and exposure > 0 else 1.0


def pre_estimate(image: np.ndarray, grid: CellGrid, *, light: str = "both", use_network: bool = True,
                 predictor: Predictor | None = None, start: np.ndarray | None = None,
                 pattern: np.ndarray | None = None) -> PreEstimate:
    """Pre-estimate a fabric from a regularized photo and the cells of one repeat (§5).

    Parameters
    ----------
    image : (H, W, 3) linear RGB, the regularized photo (warps vertical).
    grid : the cells of one minimum repeat in ``image``.
    light : the light rig the photo was taken under (§6.4).
    use_network : False bypasses the initializer (§5.3: for inputs it never saw).
    predictor : a loaded initializer; default the shipped weights (defaults if there are none).
    start : (n_e, n_a) the annealing's start (default the 2/1 twill of §5.1, :func:`twill_start`),
        e.g. the pattern decision's (:mod:`.decide`) where it was not sure.
    pattern : (n_e, n_a) a pattern already known (given, or decided from the photo's cells):
        kept, not annealed; the radii, the network and the colours are estimated with it.

    Returns
    -------
    :class:`PreEstimate`, estimated on ``image`` divided by its exposure gain.
    """
    timings: dict[str, float] = {}
    t = time.perf_counter()
    canvas = cell_canvas(image, grid, PATTERN_CELL_PX)
    start = np.asarray(pattern if pattern is not None else twill_start(grid.shape) if start is None else start,
                       dtype=np.uint8)
    if start.shape != grid.shape:
        raise ValueError(f"the start pattern {start.shape} is not the grid's repeat {grid.shape}")
    locked = np.ones(grid.shape, bool) if pattern is not None else None
    rr, first_colours = _first_colours(canvas, start, light)
    # the photo's exposure: a photo brighter than the rig's white fabric is divided by the
    # gain that brings its colours within reach (see PreEstimate.gain)
    gain = max(1.0, first_colours.exposure) if np.isfinite(first_colours.exposure) else 1.0
    if gain > 1.0:
        image, canvas = np.asarray(image, np.float32) / np.float32(gain), canvas / np.float32(gain)
        first_colours = estimate_colours(canvas, rr.fabric, cell_px=PATTERN_CELL_PX, renderer=rr)
    grey = _grey(first_colours)
    rr.set({"warp.body_reflection": grey, "warp.body_subsurface": grey,
            "weft.body_reflection": grey, "weft.body_subsurface": grey})
    rr.white = white_level(image)  # from here on renders are compared as photographed (clipped)
    first = anneal_pattern(canvas, rr, start=start, polish=False, locked=locked)
    timings["pattern"] = time.perf_counter() - t

    t = time.perf_counter()
    values, reason = None, "network bypassed"
    if use_network:
        predictor = predictor or load_predictor()
        if predictor is None:
            reason = "no initializer weights"
        else:
            values = predictor.predict(cell_canvas(image, grid, CELL_PX), first.pattern)
    timings["network"] = time.perf_counter() - t

    t = time.perf_counter()
    radii = None if values is None else (values["warp.radius"], values["weft.radius"])
    first, _ = estimate_pattern(canvas, rr, start=first.pattern, radii=radii, locked=locked)
    timings["pattern"] += time.perf_counter() - t
    t = time.perf_counter()
    geometry = {"pattern": first.pattern, "warp.radius": rr.fabric.warp.radius, "weft.radius": rr.fabric.weft.radius}
    candidates = {"defaults": default_fabric(first.pattern).replace(geometry)}
    if values is not None:
        candidates["network"] = candidates["defaults"].replace(values | geometry)
    scored = {}
    colour_canvas = cell_canvas(image, grid, colour_cell_px(grid))
    for name, fabric in candidates.items():
        fabric, _, crr = _coloured(fabric, image, grid, light)
        scored[name] = (float(np.mean(np.square(crr.render() - colour_canvas))), fabric, crr)
    source = min(scored, key=lambda k: scored[k][0])
    if "network" in scored:
        reason = ("its render fits the photo better than the defaults'" if source == "network"
                  else "its render fits the photo worse than the defaults' (an input it never saw?)")
    fabric = scored[source][1]
    timings["parameters"] = time.perf_counter() - t

    t = time.perf_counter()
    result = anneal_pattern(canvas, RepeatRenderer(fabric, cell_px=PATTERN_CELL_PX, light=light,
                                                   white=white_level(image)), start=first.pattern, locked=locked)
    fabric, colours, crr = _coloured(fabric.replace({"pattern": result.pattern}), image, grid, light)
    if np.isfinite(colours.exposure) and colours.exposure > 1.0:  # this fabric needs a little more
        gain, image = gain * colours.exposure, image / np.float32(colours.exposure)
        colour_canvas = colour_canvas / np.float32(colours.exposure)
        fabric, colours, crr = _coloured(fabric, image, grid, light)
    mse = float(np.mean(np.square(crr.render() - colour_canvas)))
    timings["refine"] = time.perf_counter() - t
    return PreEstimate(fabric=fabric, pattern=result, colours=colours, source=source, reason=reason,
                       weave=weave_name(result.pattern), mse=mse, timings_s=timings, gain=gain)
