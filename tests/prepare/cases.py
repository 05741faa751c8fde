"""Synthetic test photos for preparation, drawn reproducibly (shared by tests and the bench).

Each case turns a pattern by up to ±40°, tilts the camera by up to 10° of pitch and yaw,
and adds vignetting, blur, noise and JPEG, as the issue asks.
"""

from __future__ import annotations

import numpy as np
from synthetic import PATTERNS, render, residual_geometry

ISSUE_PATTERNS = ["plain", "twill_2_1", "twill_3_1", "twill_2_2", "satin_5", "satin_8", "basket_2_2", "custom_6x4"]


def draw_cases(n: int, *, seed: int = 0, size: int = 384, pitch=(7.0, 12.0)) -> list[dict]:
    """``n`` keyword sets for :func:`synthetic.render`, cycling over the patterns."""
    rng = np.random.default_rng(seed)
    out = []
    for k in range(n):
        pat = ISSUE_PATTERNS[k % len(ISSUE_PATTERNS)]
        p = float(rng.uniform(*pitch))
        aspect = float(rng.uniform(0.8, 1.25)) if pat.startswith("custom") else 1.0
        out.append(dict(pattern=pat, size=(size, size), pitch_px=(p, p * aspect),
                        angle_deg=float(rng.uniform(-40, 40)), pitch_deg=float(rng.uniform(-10, 10)),
                        yaw_deg=float(rng.uniform(-10, 10)), noise=float(rng.uniform(0, 0.03)),
                        blur=float(rng.uniform(0, 1.0)), jpeg=int(rng.choice([0, 75, 90])) or None,
                        vignette=float(rng.uniform(0, 0.4)), seed=k))
    return out


def measure(prepared, truth, size) -> dict:
    """Errors of one prepared synthetic photo against its truth."""
    g = residual_geometry(prepared.rectification.homography, truth, size)
    true_pitch = (truth.pitch_px[0] * g["scale"][0], truth.pitch_px[1] * g["scale"][1])
    est = prepared.grid.pitch_px
    return {"turn_err": abs(g["turn_deg"]), "skew": g["skew"], "perspective": g["perspective"],
            "pitch_err": max(abs(est[0] / true_pitch[0] - 1), abs(est[1] / true_pitch[1] - 1)),
            "repeat_ok": tuple(prepared.grid.yarns) == tuple(truth.yarns)}


__all__ = ["ISSUE_PATTERNS", "PATTERNS", "draw_cases", "measure", "render"]
