"""What a command tells about what it made, from its records: a fitted photo (``report.json``),
a mesh read and an image rendered (``render.json``), told by a :class:`cli.report.Reporter`."""

from __future__ import annotations

#: the share of a yarn family's cell centres the camera clipped (``fit.fidelity.clipped``) from
#: which the fit's line says so. Measured (draft): 0 on the own renders (their clipped gaps are
#: no yarn) and on the exposure check's satin 5 as shot, 16% a stop brighter (whose colours
#: moved by up to ΔE 6.5 against the as-shot's), 60% and 79% on the independent twill 2/1 and
#: random 4×4, 22% and 12% on the real W027 and W103
CLIPPED_NOTE = 0.05


def clipping_note(record: dict) -> str:
    """A line for the fit's summary when the camera clipped a yarn family's colour (at least
    :data:`CLIPPED_NOTE` of its cell centres): how bright it is, the photo does not show."""
    clipped = {k: v for k, v in record["fit"]["fidelity"].get("clipped", {}).items() if v is not None}
    worst = max(clipped, key=clipped.get, default=None)
    if worst is None or clipped[worst] < CLIPPED_NOTE:
        return ""
    return (f"\n  note: the camera clipped {clipped[worst]:.0%} of the {worst} yarns' centres: their colour is a lower "
            "bound; shoot a stop darker")


def colour_note(record: dict) -> str:
    """A line for the fit's summary when the captured fabric, under a neutral light, is further
    than a faithful capture's ΔE (``FitConfig.faithful_delta_e``) from the photo's colour in a
    yarn family (``fit.fidelity.neutral_delta_e``): renders of it will not have the photo's
    colour, though its compare.png, lit by the fitted light, may."""
    from weavecap.fit.config import FitConfig

    neutral = {k: v for k, v in record["fit"]["fidelity"].get("neutral_delta_e", {}).items() if v is not None}
    worst = max(neutral, key=neutral.get, default=None)
    if worst is None or neutral[worst] <= FitConfig.faithful_delta_e:
        return ""
    gain = record["fit"].get("light", {}).get("gain") or [1.0]
    held = (f" (the fitted light holds the rest: gain {'/'.join(f'{g:.2f}' for g in gain)})"
            if max(gain) > 1.05 * min(gain) else "")
    return (f"\n  note: under a neutral light the {worst} yarns are ΔE {neutral[worst]:.1f} off the photo's "
            f"colour{held}: a render will not match the photo")


def weave_note(record: dict) -> str:
    """A line for the fit's summary when the photo's cells did not settle the weave: the pattern
    decision was not sure (``pre_estimation.decision.decided`` false: under
    :data:`weavecap.estimate.decide.DECIDED_NATS` a cell for its weave over the best different
    one), so the weave is what the fit's starts and checks settled on. On the 59 FabricNET photos
    fitted at normal (docs/capture.md, *The pattern decision*) the family was right on 34 of the
    35 decided and on 2 of the 22 undecided (HELD-OUT fabrics: 14 of 14, 0 of 12). No line where
    the decision was sure, none was made (too few cells) or a pattern was given."""
    from weavecap.estimate.decide import DECIDED_NATS

    decision = (record.get("pre_estimation") or {}).get("decision") or {}
    if not decision or decision.get("decided", True):
        return ""
    return (f"\n  note: the photo's cells did not settle the weave ({decision['evidence_nats_per_cell']:.2f} nats a "
            f"cell for {decision['weave']}; {DECIDED_NATS} would decide it): {record['weave']} is the fit's best guess; "
            "check compare.png, or give the weave with --pattern")


def fitted(record: dict, folder) -> str:
    """A fitted photo: its weave, repeat, PSNR, sharpness, light rig(s), time and folder."""
    fit = record["fit"]
    rigs = len(record["timings_s"].get("captures", {})) or 1
    light = fit["light"]["rig"] + (f" light ({rigs} rigs tried)" if rigs > 1 else " light")
    return (f"{record['weave']}, {record['grid']['yarns'][0]}x{record['grid']['yarns'][1]} repeat, PSNR "
            f"{fit['psnr_db']:.1f} dB, sharpness {fit['fidelity']['sharpness']}, {light}, "
            f"{record['timings_s']['total']:.1f} s -> {folder}{weave_note(record)}{clipping_note(record)}"
            f"{colour_note(record)}")


def tell_mesh(tell, mesh: dict) -> None:
    """A mesh read (:attr:`weavecap.render.job.Rendered.mesh`): triangles, objects, UVs and
    time (``-v``), and its notes."""
    tell.say(f"{mesh['path']}: {mesh['triangles']} triangles, {', '.join(mesh['objects'])}, UVs from the "
             f"{mesh['uv_source']}, stretch {mesh['stretch']['before']:.3f} -> {mesh['stretch']['after']:.3f}, read in "
             f"{mesh['seconds']:.1f} s", level=1)
    for note in mesh["notes"]:
        tell.say(f"{mesh['path']}: {note}")


def tell_render(tell, event, where: str) -> None:
    """A render finished (a :class:`weavecap.batch.Event`): its notes, the fold term (``-v``)
    and the image written."""
    for note in event.record["notes"]:
        tell.say(f"{event.item.source}: {note}")
    if event.record.get("fold_detail"):
        tell.say(f"{where} fold term {event.record['fold']}: {fold_term(event.record['fold_detail'])}", level=1)
    tell.say(f"{where} {rendered(event.record)}")


def rendered(record: dict) -> str:
    """An image written: what, how and how long (with the mesh's reading where the image is
    the command's only one)."""
    w, h = record["size"]
    timings = record["timings_s"]
    mesh = f"mesh {timings['mesh']:.1f} s, " if "mesh" in timings else ""
    return (f"wrote {record['output']} ({w}x{h}, {record['mode']}, {record['spp']} spp, pitch {record['pitch_mm']:g} "
            f"mm, {timings['total']:.1f} s: {mesh}bake {timings['bake']:.1f} s, render {timings['render']:.1f} s)")


def fold_term(detail: dict) -> str:
    """What the fold term modelled (for -v)."""
    vertices = detail["vertices"]
    return (f"r = {detail['radius_m'] * 1000:.1f} mm, computed at {vertices['computed']} of {vertices['of']} vertices "
            f"(valleys: {vertices['valleys']['front']} front, {vertices['valleys']['back']} back), "
            f"{detail['lights']} lights + {detail['sky_directions']} sky directions, "
            f"{detail['neighbours']} neighbour samples a vertex, {sum(detail['timings'].values()):.2f} s"
            + "".join(f"; {note}" for note in detail["notes"]))
