"""The stages of a capture (Wu et al. 2025 §4–6), each a function with a typed result.

load → prepare (§4) → cells → decide → pre-estimate (§5) → plan → fit (§6.1–6.2) → finish
(§6.3 and the figures). :func:`weavecap.pipeline.capture` orders them (and runs pre-estimate to finish
once per light rig a search asks for); :mod:`weavecap.report` assembles report.json from their
results. A photo that is not a resolvable woven fabric ends at load or prepare as a
:class:`Rejection`, a value, not an exception.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .errors import PhotoError
from .fit.config import PRESETS, FitConfig, FitRequest, cell_px_for
from .fit.fidelity import LOST_SHARPNESS
from .params import Fabric

if TYPE_CHECKING:  # types only: the stages import their modules when they run
    from .estimate.cells import CellGrid
    from .estimate.decide import PatternDecision
    from .fit.compare import PhotoScale
    from .fit.fidelity import Fidelity
    from .fit.modelled import Plan
    from .fit.rigs import Weighed
    from .fit.rounds import RegisteredFit
    from .photo import Photo
    from .prepare import Prepared


@dataclass(frozen=True)
class CaptureOptions:
    """What the user chose for a capture (``weavecap fit``'s options).

    Attributes
    ----------
    quality : preset name of :data:`weavecap.fit.config.PRESETS`
    light : the light rig the photo was taken under (§6.4), ``auto``: the rig that explains
        the photo best before the fit (:func:`weavecap.fit.rigs.choose_rig`: both or front),
        searched further when that capture is not faithful, or ``best``: whole captures under
        ``auto`` and the rigs of :data:`weavecap.fit.rigs.BEST_RIGS` it did not take, one kept
        (:func:`weavecap.fit.rigs.search`)
    seed : seeds every random choice; the same seed gives the same result
    budget_s : wall-time limit of the joint fit, seconds (None: the preset's iterations)
    start_from : a fabric to start the fit from instead of the pre-estimate (warm start)
    pattern : a known pattern (fixed during the fit), or None
    use_network : False skips the initializer network (defaults, §7.3)
    exposure : ``rig``: colours against the light rig, the photo's gain solved by the fit from
        unit gain (:func:`weavecap.fit.joint.solve_colours`); ``photo``: the photo divided by
        its own exposure first (:func:`weavecap.estimate.preestimate.photo_exposure`), so the
        same fabric shot a stop darker or brighter gets the same colours, its brightest yarn
        at the rig's reach. Not the default: on the fit bench's own renders (taken at the
        rig's exposure) it cost the twill 2/1 10.7 dB (35.0 → 24.3: a fit started above the
        photo's true gain stays there) and the plain 3 dB
    """

    quality: str = "normal"
    light: str = "auto"
    seed: int = 0
    budget_s: float | None = None
    start_from: Fabric | None = None
    pattern: np.ndarray | None = None
    use_network: bool = True
    exposure: str = "rig"

    @property
    def config(self) -> FitConfig:
        return PRESETS[self.quality]

    @property
    def request(self) -> FitRequest:
        """What the fit is asked (:mod:`weavecap.fit` takes this, not the options)."""
        return FitRequest(quality=self.quality, light=self.light, seed=self.seed, budget_s=self.budget_s)


@dataclass(frozen=True)
class Rejection:
    """Why a photo was rejected (report.json's ``reason`` and ``code``, :data:`weavecap.errors.OUTCOMES`).

    Attributes
    ----------
    reason, code : what a user reads, and the machine's word for it
    input : what is known of the file (report.json's ``input``: its hash, even when unreadable)
    checks : preparation's checks that rejected it (report.json's ``checks``), or None
    diagnosis : (H, W, 3) linear RGB, what preparation's grid search saw (diagnosis.png,
        :meth:`weavecap.prepare.Rejected.diagnosis`), or None
    """

    reason: str
    code: str
    input: dict = field(default_factory=dict)
    checks: dict | None = None
    diagnosis: np.ndarray | None = None


@dataclass(frozen=True)
class Loaded:
    """The load stage: the decoded photo, and report.json's ``input`` (hash, size, format,
    the share of clipped pixels per channel)."""

    photo: Photo
    input: dict


def load(photo_path: str | Path) -> Loaded | Rejection:
    """Decode the photo (:func:`weavecap.photo.load_photo`); an unreadable one is a rejection
    that still names the file's hash, so that a resumed batch knows it was done."""
    from .photo import file_sha256, load_photo

    try:
        photo = load_photo(photo_path)
    except PhotoError as exc:
        try:
            known = {"sha256": file_sha256(photo_path), "width": 0, "height": 0}
        except OSError:
            known = {}
        return Rejection(str(exc), "unreadable", input=known)
    clipped = photo.clipped
    return Loaded(photo, {"sha256": photo.sha256, "width": photo.width, "height": photo.height,
                          "format": photo.source_format,
                          "clipped": None if clipped is None else [round(v, 4) for v in clipped]})


def prepare(loaded: Loaded, options: CaptureOptions) -> Prepared | Rejection:
    """Rectify, regularize, measure the repeat and fit the yarn grid (§4,
    :func:`weavecap.prepare.prepare_photo`). A given pattern (or warm start) is the fabric's
    repeat: a photo shows the repeat's look, which can be shorter (a grey 2/2 twill's complement
    looks alike) or, held once, hidden. The same for every light rig."""
    from .prepare import Rejected, prepare_photo

    given = options.pattern if options.pattern is not None else options.start_from
    prepared = prepare_photo(loaded.photo.rgb, repeat=None if given is None else given.shape)
    if isinstance(prepared, Rejected):
        return Rejection(prepared.reason, prepared.code, checks=prepared.to_json()["checks"],
                         diagnosis=prepared.diagnosis(loaded.photo.rgb))
    return prepared


def cells(prepared: Prepared) -> CellGrid:
    """The repeat's cells on the regularized photo (:func:`weavecap.fit.target.repeat_cells`),
    aligned to the photo's own lattice (:func:`weavecap.fit.target.align_cells`)."""
    from .fit.target import align_cells, repeat_cells

    return align_cells(prepared.regularized.image, repeat_cells(prepared, prepared.regularized.box))


@dataclass(frozen=True)
class Decided:
    """The decide stage: the pattern from what the photo's cells show
    (:func:`weavecap.estimate.decide.decide_on_photo`, docs/capture.md).

    Attributes
    ----------
    prepared, grid : the preparation and its repeat's cells, prepared again where the decided
        weave repeats over another number of yarns (``repeat_decided``), on the decision's lattice
    decision : the decision, or None (a given pattern or warm start; nothing decided)
    start : (n_e, n_a) the decided pattern registered on ``grid`` (the pre-estimate's start), or None
    known : the pattern the fit holds: the given one, or the decided one where the evidence
        settles it (:attr:`weavecap.estimate.decide.PatternDecision.decided`) and it is a
        named weave (a custom pattern from the cells' votes is a start only), else None
    repeat_decided : whether the photo was prepared again at the decided repeat
    released : why a held decision was let go (:func:`decision_holds`), or None
    """

    prepared: Prepared
    grid: CellGrid
    decision: PatternDecision | None = None
    start: np.ndarray | None = None
    known: np.ndarray | None = None
    repeat_decided: bool = False
    released: str | None = None

    def release(self, why: str) -> Decided:
        """The same decision as the fit's start only, and why."""
        return dataclasses.replace(self, known=None, released=why)


def decide(loaded: Loaded, prepared: Prepared, grid: CellGrid, options: CaptureOptions) -> Decided:
    """Decide the pattern from the photo's cells (the cell classifier's evidence over the
    lattice, :mod:`weavecap.estimate.decide`), unless a pattern or start is given."""
    from .estimate.decide import decide_on_photo
    from .fit.target import shifted

    if options.pattern is not None or options.start_from is not None:
        return Decided(prepared, grid, known=options.pattern)
    again, grid, decision = decide_on_photo(loaded.photo.rgb, prepared, grid)
    start = (decision.pattern_at(shifted(grid, again.regularized.box))
             if decision is not None and decision.pattern.shape == grid.shape else None)
    return Decided(again, grid, decision, start=start,
                   known=start if decision is not None and decision.decided and _held(start) else None,
                   repeat_decided=again is not prepared)


def decision_holds(decided: Decided, kept: Captured) -> str | None:
    """None where the capture ``kept`` under a held decided pattern looks like its photo; else
    why the decision is let go (the fit then explores from it): its render lost the photo's
    edges (sharpness under :data:`LOST_SHARPNESS`), which the fit's pattern checks, skipped for
    a held pattern, would have caught. A given pattern is always held."""
    if decided.known is None or decided.decision is None:
        return None
    sharpness = kept.weighed().sharpness
    if sharpness is None or sharpness >= LOST_SHARPNESS:
        return None
    return (f"held, the capture rendered sharpness {sharpness:.2f} (under {LOST_SHARPNESS}: blown out or black); "
            "captured again from it as a start")


def _held(pattern: np.ndarray) -> bool:
    """Whether a decided pattern is held through the fit: a named weave (a custom pattern from
    the cells' votes is a start only) other than the plain weave. A plain's two phases are
    each other's every cell flipped, which only the fit's votes between its starts tell apart:
    held at the decision's phase, the bench's plain shot a stop over or under came out in other
    colours (warp L* 27, 34, 71 at -1, 0, +1 stop); fitted from it, the plain is found as
    before (21 of 22 real plains of the weave bench before the decision)."""
    from .estimate.weave_name import weave_name

    name = weave_name(pattern)
    return not name.startswith("custom") and name != "plain"


@dataclass(frozen=True)
class Start:
    """The pre-estimate stage under one ``--light`` (§5): what the fit starts from.

    Attributes
    ----------
    prepared : the photo as fitted: as shot, or under ``--exposure photo`` divided by its own
        exposure (:func:`weavecap.estimate.preestimate.photo_exposure`), and where it shows a
        colour order, each thread's colour divided out (:func:`weavecap.fit.threads.flattened`)
    coloured : the photo at that exposure with its thread colours (the threads' palette is
        solved on it after the fit, :func:`weavecap.fit.compare.at_photo_scale`)
    exposure : that exposure, or None (the photo as shot)
    fabric : the start fabric (the pre-estimate, or the given start; a given pattern set)
    notes : report.json's ``pre_estimation``
    light, light_reason : the rig fitted under and why (``--light auto``:
        :func:`weavecap.fit.rigs.choose_rig`'s losses)
    cell_px : canvas pixels per cell of the fit (:func:`weavecap.fit.config.cell_px_for`)
    """

    prepared: Prepared
    coloured: Prepared
    exposure: float | None
    fabric: Fabric
    notes: dict
    light: str
    light_reason: str
    cell_px: int


def pre_estimate(decided: Decided, options: CaptureOptions, light: str) -> Start:
    """The start of the fit under ``light`` (a rig's name or ``auto``): the photo's exposure
    under ``--exposure photo`` (the same fabric shot a stop darker or brighter is fitted alike;
    the outputs show it as shot), the pre-estimate (pattern, colours, initializer; from the
    decided pattern) or the given start, and under ``auto`` the rig that explains the photo best."""
    from .estimate.preestimate import photo_exposure
    from .estimate.preestimate import pre_estimate as estimate
    from .fit.rigs import choose_rig
    from .fit.threads import flattened

    config = options.config
    prepared, grid = decided.prepared, decided.grid
    c = cell_px_for(config, grid.shape)
    rig, reason = ("both", "auto") if light == "auto" else (light, "given")
    exposure = None
    if options.exposure == "photo":
        exposure = photo_exposure(prepared.regularized.image, grid, light=rig)
        prepared = prepared.exposed(exposure)
    if options.start_from is not None:
        fabric, notes = options.start_from, {"parameters_from": "start_from"}
    else:
        pre = estimate(prepared.regularized.image, grid, light=rig, use_network=options.use_network,
                       pattern=decided.known, start=decided.start)
        fabric, notes = pre.fabric, pre.to_json()
    if decided.decision is not None:
        notes["decision"] = {**decided.decision.to_json(), "held": decided.known is not None}
        if decided.released:
            notes["decision"]["released"] = decided.released
    if options.pattern is not None:
        fabric = fabric.replace({"pattern": options.pattern})
    coloured = prepared
    prepared, notes["thread_colours"] = flattened(prepared, grid, fabric, spp=config.spp)
    if light == "auto":
        rig, losses = choose_rig(prepared, grid, fabric, c=c, spp=config.spp)
        reason = "the rig whose render, colours and gain solved, explains the photo best: " + ", ".join(
            f"{k} {v:.4g}" for k, v in losses.items())
    return Start(prepared=prepared, coloured=coloured, exposure=exposure, fabric=fabric, notes=notes, light=rig, light_reason=reason,
                 cell_px=c)


def plan(start: Start, decided: Decided, options: CaptureOptions) -> Plan:
    """What the fit holds fixed for this photo and why (:func:`weavecap.fit.modelled.photo_plan`):
    a given or decided pattern, and what the start's render under its rig cannot show."""
    from .fit.modelled import photo_plan
    from .model.scene import light_rig

    return photo_plan(start.fabric, rig=light_rig(start.light), cell_px=start.cell_px,
                      side_px=start.cell_px * max(decided.grid.shape), spp=options.config.spp,
                      fixed=frozenset({"pattern"}) if decided.known is not None else frozenset())


def fit(start: Start, decided: Decided, planned: Plan, options: CaptureOptions) -> RegisteredFit:
    """The joint fit, in registration rounds with its starts and end stages
    (:func:`weavecap.fit.rounds.fit_registered`), from the planned start at unit gain: the fit
    solves its own gain (:func:`weavecap.fit.joint.solve_colours`; started at the
    pre-estimate's exposure, found with its guessed specular terms, an own-render twill stayed
    at 2.1 times the truth's gain, 27.6 dB; 34.8 from unit gain)."""
    from .fit.rounds import fit_registered
    from .model.scene import light_rig

    return fit_registered(start.prepared, decided.grid, planned.start, options.request, c=start.cell_px,
                          fixed=planned.fixed, rig=light_rig(start.light),
                          explore_patterns=decided.known is None and options.start_from is None)


@dataclass(frozen=True)
class Finished:
    """The finish stage: the fitted fabric as written, and its figures against the photo.

    Attributes
    ----------
    fabric : the fit's fabric with its noise model (§6.3) and its threads' colours solved at
        the photo's scale
    rendered : (n_e*c, n_a*c, 3) its render as photographed (the fit's blur, clipped)
    confidence : the share of cells whose fitted state explains the photo better than its opposite
    noise : the noise model (:func:`weavecap.noise.fit_noise` of :func:`weavecap.noise.irregularity`)
    errors : key → standard error (a fraction of its range; inf: unseen)
    fidelity : the render against the photo (:func:`weavecap.fit.fidelity.fidelity`)
    at_scale : the fit against the photo at the photo's own scale, every whole cell in view
        (:class:`weavecap.fit.compare.PhotoScale`: the threads' colours, pixel figures, compare.png)
    """

    fabric: Fabric
    rendered: np.ndarray
    confidence: float
    noise: dict
    errors: dict
    fidelity: Fidelity
    at_scale: PhotoScale


def finish(start: Start, planned: Plan, fitted: RegisteredFit, options: CaptureOptions) -> Finished:
    """Render the fit once as photographed, and from that render: how sure the pattern is, the
    threads' colours and the figures at the photo's scale
    (:func:`weavecap.fit.compare.at_photo_scale`), the noise model (§6.3) on what differs
    between the repeats there (:func:`weavecap.noise.irregularity`), each value's standard
    error (:func:`weavecap.fit.uncertainty.standard_errors`) and the fidelity figures."""
    from .estimate.cells import cell_canvas
    from .fit.compare import at_photo_scale
    from .fit.confidence import pattern_confidence
    from .fit.fidelity import fidelity, neutral_light_delta_e
    from .fit.uncertainty import standard_errors
    from .model.render import as_photographed, render_numpy, white_level
    from .model.scene import View, build_scene
    from .noise import fit_noise, irregularity

    spp, c = options.config.spp, start.cell_px
    result, target, blur_px = fitted.result, fitted.target, fitted.blur_px
    fs = build_scene(result.fabric, View(tiles=(1, 1), size=max(target.shape[:2]), spp=spp), light=fitted.rig)
    rendered = as_photographed(render_numpy(fs), blur_px, white_level(target))
    confidence = pattern_confidence(fs, rendered, target, spp, blur_px)
    photo_canvas = cell_canvas(start.prepared.rectification.image, fitted.cells, c)
    at_scale = at_photo_scale(start.coloured.rectification.image, fitted, result.fabric, c=c, spp=spp)
    view = at_scale.view
    noise = fit_noise(irregularity(view.canvas, at_scale.render, cell_px=view.c, repeat=at_scale.fabric.full_repeat,
                                   first=view.first), pitch_px=float(view.c), seed=options.seed)
    if noise["gaussians"]:
        at_scale = dataclasses.replace(at_scale, fabric=dataclasses.replace(at_scale.fabric, noise=noise))
    errors = standard_errors(result.fabric, target, blur_px=blur_px, light=fitted.rig, spp=spp, fixed=planned.fixed,
                             scene=fs, rendered=rendered)
    figures = fidelity(target, rendered, result.fabric.pattern, shot=(start.exposure or 1.0) * photo_canvas)
    figures = dataclasses.replace(figures, neutral_delta_e=neutral_light_delta_e(at_scale.fabric, figures.lab))
    return Finished(fabric=at_scale.fabric, rendered=rendered, confidence=confidence, noise=noise, errors=errors,
                    fidelity=figures, at_scale=at_scale)


@dataclass(frozen=True)
class Captured:
    """One capture under one ``--light``: pre-estimate → plan → fit → finish, and the seconds
    each of those stages took. What a rig search weighs and report.json is made of."""

    start: Start
    plan: Plan
    fitted: RegisteredFit
    finished: Finished
    seconds: dict

    def weighed(self) -> Weighed:
        """Its figures as report.json gives them (:class:`weavecap.fit.rigs.Weighed`)."""
        from .fit.rigs import Weighed

        fidelity = self.finished.fidelity.to_json()
        return Weighed(rig=self.fitted.rig.name, loss=self.fitted.result.loss, sharpness=fidelity["sharpness"],
                       delta_e=fidelity["delta_e"])
