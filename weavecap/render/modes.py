"""The table of render modes, and the hook a fold term plugs into.

A mode says how a fabric is shaded and integrated: which Mitsuba BSDF stands for the fabric on
the mesh, and which integrator renders the scene. ``weavecap render --mode NAME`` looks NAME up
here. Two are built in:

- ``reference``: path tracing of the surface model (:mod:`weavecap.render.integrator`,
  ``max_depth`` vertices, Russian roulette) — the ground truth the neural renderers learn;
- ``direct``: one bounce of the same surface model (direct lighting only), the baseline both
  neural papers compare with: :mod:`weavecap.render.direct`, every light at every sample,
  stratified camera samples.

The neural renderer's ``neural`` mode (:data:`weavecap.render.woven.MODE`) and the fold
renderer's term (:data:`weavecap.render.fold.TERM`) join the table when a mode or fold term is
first asked for; benches and tests add theirs with :func:`register_mode` /
:func:`register_fold_term`. The entries' types are in :mod:`weavecap.render.mode`.

A :class:`FoldTerm` adds a fold's local inter-reflection to a render (``--fold auto|on|off``):
``auto`` applies the registered term where the mesh has folds and the mode asks for it
(``Mode.fold``: a one-bounce mode misses that light; path tracing has it already), ``on``
applies it everywhere it is available (an error if none is registered), ``off`` never.
"""

from __future__ import annotations

from ..errors import InputError
from .mode import FoldTerm, Mode, direct_integrator, with_lighting

#: ``weavecap render``'s mode when none is given: the surface model's direct light, adaptive
#: spp — right under every light, where the neural renderer is not yet (docs/render.md, *Modes*)
DEFAULT_MODE = "direct"
#: ``weavecap render --help``'s words on the modes and their samples a pixel
MODE_HELP = ("direct: direct lighting (one bounce) of the surface model, every light at every sample, samples until "
             "the noise is below what shows; reference: path tracing of the surface model; neural: the woven neural "
             "BSDF at each pixel's footprint, direct light (Chen et al. 2024; a few samples a pixel at any distance, "
             "its colours a few percent darker: docs/woven.md).")
SPP_HELP = ("Samples per pixel  [default: direct until the noise is below 1 L*, at most 512; neural 4 (a 2x2 grid of "
            "footprints); reference 64]")
FOLD_CHOICES = ("auto", "on", "off")


MODES: dict[str, Mode] = {}
FOLD_TERMS: list[FoldTerm] = []
_loaded = False


def register_mode(mode: Mode) -> None:
    """Add (or replace) a mode in the table."""
    MODES[mode.name] = mode


def register_fold_term(term: FoldTerm) -> None:
    """Add a fold term (the last registered one is used)."""
    FOLD_TERMS.append(term)


def _add_renderers() -> None:
    """Add the neural mode and the fold term (imported here, on first use: they load their
    networks' code)."""
    global _loaded
    if _loaded:
        return
    _loaded = True
    from .fold import TERM
    from .woven import MODE

    register_mode(MODE)
    register_fold_term(TERM)


def mode(name: str) -> Mode:
    """The mode ``name``; InputError naming the modes there are."""
    _add_renderers()
    if name not in MODES:
        raise InputError(f"--mode {name!r} is unknown; available: {', '.join(sorted(MODES))}")
    return MODES[name]


def mode_names() -> list[str]:
    """Every registered mode, built-ins first."""
    _add_renderers()
    built_in = [n for n in ("reference", "direct") if n in MODES]
    return built_in + sorted(n for n in MODES if n not in built_in)


def fold_term(choice: str, chosen: Mode, mesh) -> FoldTerm | None:
    """The fold term to apply under ``--fold choice`` for this mode and mesh, or None."""
    if choice not in FOLD_CHOICES:
        raise InputError(f"--fold {choice!r}: use one of {', '.join(FOLD_CHOICES)}")
    _add_renderers()
    if choice == "off":
        return None
    term = FOLD_TERMS[-1] if FOLD_TERMS else None
    if choice == "on":
        if term is None:
            raise InputError("--fold on: no fold term is installed (the fold renderer registers one); "
                             "use --fold auto or off")
        return term
    return term if term is not None and chosen.fold and term.has_folds(mesh) else None


def _surface_bsdf(fabric, maps, placement, noise, linear):
    from .bsdf import SurfaceBSDF

    return SurfaceBSDF(fabric, maps, placement, noise, linear=linear)


def _path(max_depth: int | None):
    def integrator(lighting, options) -> dict:
        from . import integrator as _integrator  # noqa: F401  (registers "weavecap_path")

        return with_lighting({"type": "weavecap_path", "max_depth": int(max_depth or options.max_depth), "rr_depth": 5},
                             lighting)
    return integrator


register_mode(Mode("reference", "path tracing of the surface model (max depth, Russian roulette)",
                   bsdf=_surface_bsdf, integrator=_path(None)))

#: stratified camera samples (a jittered grid of sub-pixels a pass): the weave under a pixel
#: is integrated faster than by independent samples
STRATIFIED = {"type": "multijitter"}

register_mode(Mode("direct", "direct lighting only (one bounce) of the surface model, every light at every sample",
                   bsdf=_surface_bsdf, integrator=direct_integrator, fold=True, sampler=STRATIFIED, spp=None))

__all__ = ["Mode", "FoldTerm", "MODES", "FOLD_TERMS", "register_mode", "register_fold_term", "mode", "mode_names",
           "fold_term", "with_lighting", "direct_integrator", "DEFAULT_MODE", "STRATIFIED"]
