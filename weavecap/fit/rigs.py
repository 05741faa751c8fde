"""Which light rig (§6.4) a photo is fitted under: the choice before the fit and the search
after it (``--light auto`` and ``best``).

Before any fit, ``auto`` takes the rig whose render of the pre-estimate explains the photo best
(:func:`choose_rig`: ``both`` or ``front``). That choice is made on the pre-estimate, where the
loss prefers the flatter rig whatever lit the photo, so a capture under it that is not
:func:`faithful` to the photo is made again under the other rigs of :data:`BEST_RIGS`, and
``best`` makes them all (:func:`search`); one capture is kept (:func:`kept_capture`). Each
capture of a search is a whole one (pre-estimate, fit and end stages under that rig) from the
photo's one preparation, which does not depend on the rig: the runner passes a function that
makes it (:func:`weavecap.pipeline.capture`).

Measured on the fit bench's independent photos (normal): ``auto``'s rig is physically wrong on
6 of the 18; after the whole fit the loss mostly ranks the rigs as their looks do, but it
rewards a blur: on 5 of the 18 the lowest loss was a render under 0.75 of the photo's
sharpness. Sharpness median / worst 0.91 / 0.31 under ``auto`` without a search, 0.94 / 0.82
with it, 0.98 / 0.82 searching every photo; ΔE2000 median / worst 0.9 / 13.3, 0.7 / 8.3 and
0.7 / 6.9 (docs/capture.md).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Generic, TypeVar

from ..params import Fabric
from .config import FitConfig, FitRequest
from .fidelity import LOST_SHARPNESS, faithful_figures
from .rounds import _registered_target

#: the rigs a rig search (``--light best``, or ``auto``'s retry) captures the photo under
#: besides ``auto``'s (one whole capture each)
BEST_RIGS = ("both", "front", "lamp")

Capture = TypeVar("Capture")


@dataclass(frozen=True)
class Weighed:
    """What a rig search weighs of one capture, the figures as report.json gives them (rounded
    as there, so that a reader can check the choice).

    Attributes
    ----------
    rig : the rig it was fitted under (``fit.light.rig``; under ``auto``: :func:`choose_rig`'s)
    loss : the fit's final loss against the photo's repeat registered on its render (``fit.mse``)
    sharpness : the render's gradient energy over the photo's (``fit.fidelity.sharpness``)
    delta_e : family → CIEDE2000 to the photo's colour, None for a family the pattern never shows
        (``fit.fidelity.delta_e``)
    """

    rig: str
    loss: float
    sharpness: float | None
    delta_e: dict


@dataclass
class Searched(Generic[Capture]):
    """The captures made for one photo and the one kept.

    Attributes
    ----------
    kept : the capture kept
    captures : every capture made, by the ``--light`` it was made with (``auto``, or a rig's name)
    note : why it was kept, with every capture's figures (report.json's
        ``modelled.light_rig_from``); None when only one capture was made
    """

    kept: Capture
    captures: dict = field(default_factory=dict)
    note: str | None = None


def faithful(weighed: Weighed, config: FitConfig) -> bool:
    """Whether a capture's render looks like its photo: at least ``config.faithful_sharpness``
    of its gradient energy and each family's colour within ``config.faithful_delta_e`` (a
    family the pattern never shows is not judged)."""
    return faithful_figures(weighed.sharpness, weighed.delta_e, min_sharpness=config.faithful_sharpness,
                            max_delta_e=config.faithful_delta_e)


def search(request: FitRequest, capture: Callable[[str], Capture], weigh: Callable[[Capture], Weighed], *,
           say: Callable[[str], None] = lambda _msg: None) -> Searched[Capture]:
    """The captures ``request.light`` asks for, one kept. ``capture(light)`` makes a whole
    capture under ``light`` (``auto`` or a rig's name); ``weigh`` gives its figures.

    A rig's name: that capture. ``auto``: its capture, and when that is not :func:`faithful`
    and the preset retries (``FitConfig.rig_retry``), one under each rig of :data:`BEST_RIGS`
    auto did not fit under. ``best``: ``auto``'s and those. Of several, :func:`kept_capture`'s.
    """
    config = request.config
    captures: dict[str, Capture] = {}
    if request.light != "best":
        first = capture(request.light)
        if request.light != "auto" or not config.rig_retry or faithful(weigh(first), config):
            return Searched(kept=first, captures={request.light: first})
        captures["auto"] = first
        say("the render is not faithful to the photo: capturing again under the other rigs")
    for light in ("auto", *BEST_RIGS):
        if light in captures or ("auto" in captures and light == weigh(captures["auto"]).rig):
            continue  # made, or auto fitted under it
        say(f"capturing with --light {light} ({len(captures) + 1} of {len(BEST_RIGS)})")
        captures[light] = capture(light)
    weighed = {light: weigh(cap) for light, cap in captures.items()}
    chosen, reason = kept_capture(weighed, config)
    why = ("every rig searched (--light best)" if request.light == "best" else
           f"auto's capture was not faithful to the photo (sharpness under {config.faithful_sharpness} "
           f"or a family's colour beyond ΔE {config.faithful_delta_e}), the other rigs searched")
    each = [f"{light} loss {w.loss:.4g}, sharpness {w.sharpness}, ΔE {w.delta_e}" for light, w in weighed.items()]
    note = f"{why}: {chosen} ({weighed[chosen].rig}) kept, {reason}: " + ", ".join(each)
    return Searched(kept=captures[chosen], captures=captures, note=note)


def kept_capture(weighed: dict[str, Weighed], config: FitConfig) -> tuple[str, str]:
    """Which of a rig search's captures to keep (``weighed``: ``auto``'s and each other rig's
    figures, by ``--light``), and why. Weighed: ``auto``'s, and those whose loss is within
    ``config.rig_loss_slack`` of the lowest loss of a capture that is not blown out or black
    (sharpness at least :data:`weavecap.fit.fidelity.LOST_SHARPNESS`; of any capture where none
    is); of them the lowest loss among the :func:`faithful`, else among those at least
    ``config.faithful_sharpness`` as sharp as the photo, else the sharpest.

    The loss alone rewards a blur (see the module's description); sharpness alone took sharp
    renders that explain the photo far worse: the independent satin 5 a stop darker
    (``--exposure photo``), ``lamp`` at 5.9 times auto's loss, its warp ΔE 21. The captures
    kept on both photo sets were within 1.35 times the lowest loss (docs/capture.md). A flat
    render's loss sets no bar: against the median repeat registered on it, a blurred capture can
    score the lowest loss of all. On KTH 44a (scale 2, image 5) auto's ``front`` capture, at
    0.14 of the photo's sharpness, scored 0.43 of the faithful ``lamp`` capture's loss
    (sharpness 0.81, ΔE under 1), which put ``lamp`` beyond the slack, and the flat one was
    kept."""
    losses = {light: float(w.loss) for light, w in weighed.items()}
    sharpness = {light: w.sharpness or 0.0 for light, w in weighed.items()}
    seen = [light for light in weighed if sharpness[light] >= LOST_SHARPNESS]  # not blown out or black
    lowest = min(losses[light] for light in (seen or weighed))
    considered = [light for light in weighed if light == "auto" or losses[light] <= config.rig_loss_slack * lowest]
    faithful_ones = [light for light in considered if faithful(weighed[light], config)]
    if faithful_ones:
        return min(faithful_ones, key=losses.get), "the lowest loss of the faithful captures"
    sharp = [light for light in considered if sharpness[light] >= config.faithful_sharpness]
    if sharp:
        return min(sharp, key=losses.get), (f"none faithful; the lowest loss of those {config.faithful_sharpness} "
                                            "as sharp as the photo")
    return max(considered, key=sharpness.get), f"none {config.faithful_sharpness} as sharp as the photo; the sharpest"


def choose_rig(prepared, cells, fabric: Fabric, *, c: int, spp: int,
               names: tuple[str, ...] = ("both", "front")) -> tuple[str, dict]:
    """The light rig (§6.4) that explains the photo best for ``--light auto``: ``fabric`` under
    each of ``names``, the photo's median repeat registered on its render, its colours and the
    rig's gain solved in closed form (:func:`weavecap.fit.joint.solve_colours`), and the rig
    with the lower loss wins. A back-lit photo's gaps glow and its yarns let the light through;
    a front-lit one has neither, and a rig with a back light then explains it worse (and the
    other way round). Returns the name and each rig's loss.

    ``lamp`` (one lamp in front, no side lights) is not among the names, nor weighed later:
    the loss does not see what it mends. Scored on the pre-estimate, it came out below ``both``
    on the three own renders tried, which ``both`` had made (fitted under it, the plain lost
    1.3 dB and the twill 2.6, the satin 5 gained 1.5); scored on the first round's fit of seven
    photos, it came out below only on the independent satin 8, and a round fitted under it
    there ended 21% above (docs/capture.md). A rig search weighs it after whole captures
    (:func:`search`)."""
    from ..estimate.forward import BLUR_CELLS, RepeatRenderer
    from ..model.render import blurred_mse, render_numpy, white_level
    from ..model.scene import View, build_scene, light_rig
    from .joint import solve_colours

    losses = {}
    for name in names:
        rig = light_rig(name)
        model = RepeatRenderer(fabric, cell_px=c, light=rig, blur_cells=BLUR_CELLS,
                               white=white_level(prepared.rectification.image)).render()
        target = _registered_target(prepared, cells, model, c)[2]
        fs = build_scene(fabric, View(tiles=(1, 1), size=max(target.shape[:2]), spp=spp), light=rig)

        def measure() -> float:
            return blurred_mse(render_numpy(fs), target, BLUR_CELLS * c)

        solve_colours(fs, target, measure, spp=spp, blur_px=BLUR_CELLS * c, gain=True)
        losses[name] = measure()
    return min(losses, key=losses.get), {k: round(v, 6) for k, v in losses.items()}
