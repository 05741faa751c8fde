"""How sure the fit is of its pattern: each cell against its opposite state."""

from __future__ import annotations

import numpy as np


def pattern_confidence(fs, rendered: np.ndarray, target: np.ndarray, spp: int, blur_px: float) -> float:
    """Fraction of cells whose fitted state (``rendered``, blurred) explains the photo better
    than its opposite (one more render, of the complement pattern)."""
    from ..estimate.cells import cell_errors
    from ..model.render import as_photographed, render_numpy, white_level

    pattern = fs.fabric.pattern.copy()
    now = cell_errors(rendered, target, pattern.shape)
    fs.set("pattern", 1 - pattern)
    flipped = cell_errors(as_photographed(render_numpy(fs, spp=spp), blur_px, white_level(target)), target,
                          pattern.shape)
    fs.set("pattern", pattern)
    return float(np.mean(flipped > now))
