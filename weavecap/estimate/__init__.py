"""Pre-estimation (Wu et al. 2025 §5): the start of the joint fit.

- :mod:`.cells` — a photo's repeat on a canvas of equal cells (the grid of §4.4 in, arrays out);
- :mod:`.forward` — renders of one repeat on that canvas (the forward model of :mod:`weavecap.model`);
- :mod:`.pattern` — §5.1, batched annealing at T = 0 (and the yarn radii it needs);
- :mod:`.colour` — §5.2, warp, weft and specular colours; CIELAB ΔE;
- :mod:`.initializer` — §5.3, the VGG-style network, or Table 1 defaults (§7.3);
- :mod:`.sampling` — random weaves and fabrics over Table 1, which its training data are drawn from
  (:mod:`weavecap.training.initializer`, ``weavecap train-initializer``);
- :mod:`.weave_name` — the weave's name for people;
- :mod:`.orientation`, :mod:`.context` — the pattern read off the photo without the model: the
  edge votes per cell, and the pattern its cells' looks explain best (the fit's end stages);
- :mod:`.preestimate` — all of it in order: :func:`pre_estimate`; the photo's exposure against the rig,
  :func:`photo_exposure`.
"""

from .cells import CellGrid, cell_canvas
from .preestimate import PreEstimate, default_fabric, photo_exposure, pre_estimate
from .weave_name import weave_name

__all__ = ["CellGrid", "cell_canvas", "PreEstimate", "default_fabric", "photo_exposure", "pre_estimate", "weave_name"]
