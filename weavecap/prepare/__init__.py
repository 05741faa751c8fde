"""Photo preparation (Wu et al. 2025 §4): rectify, regularize, repeat and yarn grid.

:func:`prepare_photo` runs the stages in order and returns :class:`Prepared` or, for a photo
that is not a resolvable woven fabric, :class:`Rejected` with a reason. Each stage is also a
plain function of its own module: :mod:`.rectify` (§4.1), :mod:`.illumination`,
:mod:`.regularize` (§4.2), :mod:`.period` (§4.3), :mod:`.grid` (§4.4).

Angle convention: ``rotation_deg`` is the turn, counter-clockwise positive (image y down, as
seen on screen), that makes the warps run vertically, |rotation_deg| ≤ 45°. A photo of a
fabric that was turned counter-clockwise by θ (e.g. ``weavecap synth --rotate θ``) therefore
gives rotation_deg = −θ.
"""

from .config import PrepareConfig
from .grid import Grid
from .pipeline import Prepared, Rejected, draw_grid, prepare_photo
from .rectify import Rectification, rectify
from .regularize import Regularized, regularize

__all__ = ["PrepareConfig", "Prepared", "Rejected", "Rectification", "Regularized", "Grid", "prepare_photo",
           "rectify", "regularize", "draw_grid"]
