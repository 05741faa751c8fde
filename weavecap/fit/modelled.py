"""What a capture fits and what it holds fixed, decided per photo, with the reasons.

docs/design.md, "The capture pipeline": "What a photo cannot determine is fixed, not fitted, and the report says so." A
fit that spends steps on values the photo does not show lets them drift into whatever absorbs
the model's mismatch, and a report that lists them as fitted claims more than the photo says.
:func:`plan` decides, before the joint fit, from the start fabric and the canvas scale:

- ``specular.coefficient`` m_r: fixed at :data:`COEFFICIENT`. It only splits the body light
  between R^B (weight m_r) and S^B (1 − m_r): moving it with both colours rescaled renders the
  same image (an exact null direction of the model, measured and tested in
  :mod:`weavecap.fit.uncertainty`). The start's colours are rescaled so that its render is
  unchanged (within Table 1's colour range); the fitted colours are then the identifiable
  products over a fixed weight.
- ``fibers``: fixed at the start's count when its grooves are finer than
  :data:`MIN_GROOVE_PX` canvas pixels (a yarn's circumference over the fibre count): the
  render cannot show them, and on forward-model renders the loss over fibres is flat but for
  a spike at the exact count.
- ``plies``: decided in the fit (:func:`weavecap.fit.joint.fit`): the first scan over 1–7
  plies fixes the count at the start's when the loss varies less than
  :data:`weavecap.fit.config.FitConfig.plies_flat` over the whole range.
- every continuous value with no finite standard error at the start
  (:func:`weavecap.fit.uncertainty.standard_errors`: a value that moves along a direction no
  render of this photo's repeat sees, e.g. transmission under a front-only rig).

:func:`describe` turns the decisions and the run's own figures into report.json's
``modelled``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..params import FIT_RANGES, Fabric

COEFFICIENT = 0.5  # m_r held here: the middle of Table 1's range
MIN_GROOVE_PX = 2.0  # fibre grooves closer than this (canvas px) are below what a render can show


@dataclass(frozen=True)
class Plan:
    """What the fit of one photo holds fixed and why.

    Attributes
    ----------
    start : the start fabric, with the fixed values set (m_r, colours rescaled to keep its render).
    fixed : keys not fitted (the fit's ``fixed``).
    reasons : key → why it is fixed, with this photo's figures.
    """

    start: Fabric
    fixed: frozenset
    reasons: dict = field(default_factory=dict)


def fix_coefficient(fabric: Fabric, value: float = COEFFICIENT) -> Fabric:
    """``fabric`` with m_r = ``value`` and the body colours rescaled to keep m_r R^B and
    (1 − m_r) S^B (the render) unchanged, clipped to [0, 1]."""
    m = float(fabric.get("specular.coefficient"))
    out = {"specular.coefficient": value}
    for yarn in ("warp", "weft"):
        for key, w_old, w_new in (("body_reflection", m, value), ("body_subsurface", 1 - m, 1 - value)):
            colour = fabric.get(f"{yarn}.{key}")
            if isinstance(colour, str):  # a texture keeps its colours
                continue
            out[f"{yarn}.{key}"] = tuple(np.clip(np.asarray(colour, float) * w_old / w_new, 0.0, 1.0))
    return fabric.replace(out)


def fibre_groove_px(fabric: Fabric, cell_px: int) -> float:
    """Spacing of the fibre grooves on the render (canvas px): the thicker yarn's circumference
    over the fibre count, at ``cell_px`` px per yarn pitch."""
    from ..model.geometry import PITCH

    r = max(fabric.warp.radius, fabric.weft.radius)
    return 2 * math.pi * r / PITCH * cell_px / max(1, fabric.fibers)


def plan(start: Fabric, *, cell_px: int, fixed: frozenset = frozenset(), unseen: dict | None = None,
         reasons: dict | None = None) -> Plan:
    """Decide what to hold fixed for a photo (see the module's description).

    Parameters
    ----------
    start : the pre-estimate (or a given start).
    cell_px : canvas px per cell of the fit.
    fixed : what the user fixed already (``pattern`` for a given pattern).
    unseen : continuous keys → standard error (inf) at the start, of values no render sees
        (:func:`weavecap.fit.uncertainty.unseen` with the other decisions' ``fixed``).
    reasons : the reasons of an earlier plan whose ``fixed`` is passed in (kept).
    """
    reasons = dict(reasons or {})
    fixed = set(fixed)
    if "specular.coefficient" not in fixed:
        start = fix_coefficient(start)
        fixed.add("specular.coefficient")
        reasons["specular.coefficient"] = (f"held at {COEFFICIENT}: it only splits the body light between R^B and S^B "
                                           "(an exact null direction with them); the colours are fitted as the products")
    groove = fibre_groove_px(start, cell_px)
    if groove < MIN_GROOVE_PX and "fibers" not in fixed:
        fixed.add("fibers")
        reasons["fibers"] = (f"held at {start.fibers}: its grooves are {groove:.2f} px apart on the render "
                             f"(under {MIN_GROOVE_PX:g} px), finer than the render can show")
    for key in sorted(unseen or {}):
        if key not in fixed and key in FIT_RANGES:
            fixed.add(key)
            reasons[key] = "held at the start's value: it moves along a direction no render of this photo sees"
    return Plan(start=start, fixed=frozenset(fixed), reasons=reasons)


def photo_plan(start: Fabric, *, rig, cell_px: int, side_px: int, spp: int, fixed: frozenset = frozenset()) -> Plan:
    """:func:`plan` for one photo: the decisions above, then every value no render of the
    photo's repeat (``side_px`` on its longer side, under ``rig``) sees at the planned start
    held too (:func:`weavecap.fit.uncertainty.unseen`)."""
    from .uncertainty import unseen

    first = plan(start, cell_px=cell_px, fixed=fixed)
    hidden = unseen(first.start, size=side_px, light=rig, spp=spp, fixed=first.fixed)
    return plan(first.start, cell_px=cell_px, fixed=first.fixed, unseen=hidden, reasons=first.reasons)


def light_json(rig, moves: dict, *, exposure: float | None = None) -> dict:
    """report.json's ``fit.light``: the rig and the gain fitted to the photo (its exposure and
    white balance: photo = gain × render at unit gain), and per channel whether the photo
    determined it (the back light through the gaps) or the range rule set it.

    ``exposure`` (``--exposure photo``): what the photo was divided by before the fit
    (:func:`weavecap.estimate.preestimate.photo_exposure`); ``gain`` includes it, ``rig.gain``
    (the fit's own) does not. None (``--exposure rig``): the photo as shot."""
    solve = moves.get("colour_solve", {})
    determined = solve.get("gain_determined")
    how = ("not solved" if determined is None else
           "the back light seen through the gaps" if all(determined) else
           ("" if exposure is None else "the photo's exposure (its brightest yarn colour at the rig's reach) times ")
           + "the smallest gain (>= 1) that keeps every colour within its range: the photo shows no reference"
           if not any(determined) else "the gaps for the channels marked determined, the range rule for the rest")
    gain = (1.0 if exposure is None else exposure) * np.asarray(rig.gain, np.float64)
    out = {"rig": rig.name, "gain": [round(float(v), 4) for v in gain],
           "exposure_stops": round(float(np.log2(max(float(np.mean(gain)), 1e-12))), 3),
           "gain_determined": determined, "gain_from": how}
    if exposure is not None:
        out["photo_exposure"] = round(float(exposure), 4)
    return out


def describe(plan: Plan, result, errors: dict, *, light: str, light_reason: str, spp: int, blur_px: float,
             noise: dict, pitch_px, plies_flat: float) -> dict:
    """report.json's ``modelled``: what this run fitted, what it held fixed and why, with this
    run's own figures (no benchmark claims).

    Parameters
    ----------
    plan : the :class:`Plan` the fit ran with; result : its :class:`~weavecap.fit.joint.FitResult`.
    errors : key → standard error at the fit (:func:`weavecap.fit.uncertainty.standard_errors`).
    """
    from ..params import CONTINUOUS_KEYS

    moves = result.moves
    fixed = dict(plan.reasons)
    scan = moves.get("plies_scan")
    if "plies" in plan.fixed:
        fixed.setdefault("plies", "given")
    elif scan and scan.get("flat"):
        fixed["plies"] = (f"held at {result.fabric.plies}: over 1-7 plies the loss varied by "
                          f"{100 * scan['loss_range']:.1f}% (under the {100 * plies_flat:g}% that would tell them apart)")
    if "pattern" in plan.fixed:
        fixed["pattern"] = "given (--pattern)"
    fitted = [k for k in CONTINUOUS_KEYS if k not in plan.fixed]
    unseen = [k for k in fitted if not np.isfinite(errors.get(k, np.inf))]
    radii = {k: moves[k] for k in ("warp.radius", "weft.radius") if k in moves}
    return {
        "light_rig": light, "light_rig_from": light_reason,
        "transmission": "exit-point rays for the back light" if light in ("both", "back")
        else "none: nothing lights the back",
        "samples_per_pixel": f"{spp}: directional lights are exact at pixel centres",
        "fitted": fitted + [k for k in ("pattern", "plies") if k not in fixed],
        "fixed": fixed,
        "not_determined": {k: "fitted, but no finite standard error at the fit: the photo does not pin it"
                           for k in unseen},
        "radii": {"method": "greedy pattern search", "moves": radii},
        "photo_blur_px": round(blur_px, 3),
        "noise": f"{len(noise['gaussians'])} Gaussians over the residual spectrum",
        "yarn_pitch_px": [round(float(v), 3) for v in pitch_px],
    }

