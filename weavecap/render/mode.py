"""What a render mode and a fold term are (the entries of :mod:`weavecap.render.modes`'s table).

A mode says how a fabric is shaded and integrated: which Mitsuba BSDF stands for the fabric on
the mesh, and which integrator renders the scene. A fold term adds a fold's local
inter-reflection to a render. The renderers' packages (:mod:`weavecap.render.woven`,
:mod:`weavecap.render.fold`) define theirs with these types and import nothing of the table;
the table imports them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable


@dataclass(frozen=True)
class Mode:
    """One way to render.

    Attributes
    ----------
    name, description : for ``--mode`` and ``--help``
    bsdf : ``(fabric, maps, placement, noise, linear) -> mi.BSDF``: the fabric on the mesh
        (``linear``: whether a texel is big enough in the image to interpolate maps)
    integrator : ``(lighting, options) -> dict``: the Mitsuba integrator (a ``load_dict`` dict)
    fold : whether ``--fold auto`` adds a fold term to this mode's renders
    sampler : the camera's sampler (a ``load_dict`` dict without ``sample_count``), default
        Mitsuba's ``independent``
    spp : samples per pixel when ``--spp`` is not given (None: until the noise is below what
        shows, :func:`weavecap.render.run.adaptive_passes`)
    """

    name: str
    description: str
    bsdf: Callable
    integrator: Callable
    fold: bool = False
    sampler: dict | None = None
    spp: int | None = 64


@dataclass(frozen=True)
class FoldTerm:
    """Local inter-reflection in folds, added to a render.

    Attributes
    ----------
    name : for messages and ``--json``
    has_folds : ``(mesh) -> bool``: whether ``auto`` should apply it to this mesh
    apply : ``(context) -> image`` or ``(image, detail)``: the image with the fold term added,
        given the :class:`weavecap.render.run.RenderContext` of the render (scene, mesh, fabric,
        maps, camera, lighting, options and the image so far, linear (H, W, 3)); ``detail``, a
        dict of what it modelled, goes to the render's info as ``fold_detail``
    """

    name: str
    has_folds: Callable
    apply: Callable


def with_lighting(props: dict, lighting) -> dict:
    """An integrator's ``load_dict`` properties with the capture rigs' ``ambient`` radiance and
    ``background`` (:class:`weavecap.render.scene.Lighting`), where the lights have them."""
    if lighting.ambient:
        props["ambient"] = float(lighting.ambient)
    if lighting.background is not None:
        props["background"] = float(lighting.background)
    return props


def direct_integrator(lighting, options) -> dict:
    """The one-bounce integrator of :mod:`weavecap.render.direct` (``direct`` and ``neural``)."""
    from . import direct as _direct_integrator  # noqa: F401  (registers "fabric_direct")

    return with_lighting({"type": "fabric_direct"}, lighting)
