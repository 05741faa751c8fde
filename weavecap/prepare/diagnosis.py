"""The picture of a rejected photo (``diagnosis.png``): what the grid search saw, and why.

A photo that preparation refuses (:class:`~weavecap.prepare.pipeline.Rejected`) gets one
picture a person can read without the report: the photo as the grid search saw it (turned,
where it got that far), its power spectrum (a woven fabric is a lattice of sharp peaks; felt
and paper a smooth blob; yarns under the sampling limit leave a ring near the border or
nothing), the two integral projections along the yarn directions with the pitch found marked
(§4.4: a woven grid makes them periodic), and the reason with what to do, in words.
"""

from __future__ import annotations

import textwrap

import cv2
import numpy as np

from ..photo import linear_to_srgb, srgb_to_linear
from .illumination import flatten_illumination, luminance

PANEL_PX = 300


def _fit(image: np.ndarray, side: int) -> np.ndarray:
    """``image`` (display values 0–1) scaled (area / nearest) so that its larger side is
    ``side`` px, on a grey square: (side, side, 3) uint8 (OpenCV draws text on 8 bits)."""
    h, w = image.shape[:2]
    k = side / max(h, w)
    interp = cv2.INTER_AREA if k < 1 else cv2.INTER_NEAREST
    small = cv2.resize(np.ascontiguousarray(image, np.float32), (max(1, round(w * k)), max(1, round(h * k))),
                       interpolation=interp)
    out = np.full((side, side, 3), 0.45, np.float32)
    sh, sw = small.shape[:2]
    y0, x0 = (side - sh) // 2, (side - sw) // 2
    out[y0:y0 + sh, x0:x0 + sw] = small if small.ndim == 3 else small[..., None]
    return (np.clip(out, 0, 1) * 255 + 0.5).astype(np.uint8)


def _spectrum_panel(grey: np.ndarray, pitches: tuple | None) -> np.ndarray:
    """Log power spectrum of the centre crop (at most 512 px, lighting flattened, Hann window),
    the origin at the centre; circles mark the yarn frequencies found along x and y."""
    h, w = grey.shape
    n = int(min(h, w, 512))
    g = grey[(h - n) // 2:(h - n) // 2 + n, (w - n) // 2:(w - n) // 2 + n].astype(np.float64)
    g, _ = flatten_illumination(g, sigma_px=n / 12)
    g = (g - g.mean()) * np.outer(np.hanning(n), np.hanning(n))
    power = np.log10(np.fft.fftshift(np.abs(np.fft.fft2(g)) ** 2) + 1e-12)
    lo, hi = np.percentile(power, 50), power.max()
    img = np.clip((power - lo) / max(hi - lo, 1e-9), 0, 1).astype(np.float32)
    panel = _fit(np.repeat(img[..., None], 3, axis=2), PANEL_PX)
    if pitches:
        k = PANEL_PX / n
        c = PANEL_PX / 2
        for axis, p in enumerate(pitches):
            if p:
                f = n / p * k  # bins from the centre, scaled to the panel
                for s in (-1, 1):
                    pt = (int(round(c + s * f)), int(round(c))) if axis == 0 else (int(round(c)), int(round(c + s * f)))
                    cv2.circle(panel, pt, 6, (230, 50, 0), 1, cv2.LINE_AA)
    return panel


def _profile_panel(profiles: list | None, pitches: tuple | None, strengths: tuple | None) -> np.ndarray:
    """The two integral projections (x: column means, y: row means) as curves, with ticks
    every pitch found and the periodicity of each."""
    panel = np.full((PANEL_PX, PANEL_PX, 3), 255, np.uint8)
    if not profiles:
        cv2.putText(panel, "no projections", (10, PANEL_PX // 2), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 0, 0), 1,
                    cv2.LINE_AA)
        return panel
    half = PANEL_PX // 2
    for i, prof in enumerate(profiles):
        if prof is None or len(prof) < 2:
            continue
        p = np.asarray(prof, np.float64)
        p = (p - p.min()) / max(float(np.ptp(p)), 1e-12)
        top, height = i * half + 22, half - 34
        xs = np.linspace(4, PANEL_PX - 4, len(p))
        pts = np.stack([xs, top + (1 - p) * height], axis=1).round().astype(np.int32)
        cv2.polylines(panel, [pts], False, (15, 40, 150), 1, cv2.LINE_AA)
        pitch = pitches[i] if pitches else None
        if pitch:
            for x in np.arange(0, len(p), pitch):
                xi = int(round(4 + x / max(len(p) - 1, 1) * (PANEL_PX - 8)))
                cv2.line(panel, (xi, top + height), (xi, top + height + 6), (200, 25, 0), 1)
        label = f"{'x (across warps)' if i == 0 else 'y (across wefts)'}"
        if pitch:
            label += f": pitch {pitch:.1f} px"
        if strengths is not None and strengths[i] is not None:
            label += f", periodicity {strengths[i]:.2f}"
        cv2.putText(panel, label, (6, top - 6), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (0, 0, 0), 1, cv2.LINE_AA)
    return panel


def diagnosis_image(rgb: np.ndarray, reason: str, evidence: dict) -> np.ndarray:
    """The diagnosis picture of a rejected photo (linear RGB, H × 900).

    Parameters
    ----------
    rgb : (H, W, 3) the photo, linear RGB.
    reason : the rejection's sentence (:attr:`Rejected.reason`).
    evidence : what the grid search measured before it gave up, any of ``rectified`` (the
        turned photo), ``profiles`` (the two projections), ``pitches`` and ``strengths``
        (per axis, in rectified px; None where none was found).
    """
    seen = evidence.get("rectified")
    photo = np.asarray(seen if seen is not None else rgb, np.float32)
    if photo.ndim == 2:
        photo = np.repeat(photo[..., None], 3, axis=2)
    top = float(np.percentile(photo, 99)) or 1.0
    pitches = evidence.get("pitches")
    # drawn in 8-bit display (sRGB) values, returned linear (save_png encodes sRGB again)
    panels = [_fit(linear_to_srgb(np.clip(photo / top, 0, 1)), PANEL_PX), _spectrum_panel(luminance(photo), pitches),
              _profile_panel(evidence.get("profiles"), pitches, evidence.get("strengths"))]
    titles = ("the photo as the grid search saw it" if seen is not None else "the photo",
              "its power spectrum (woven: sharp peaks)", "projections along the yarns")
    row = np.concatenate([np.pad(p, ((0, 0), (2, 2), (0, 0)), constant_values=255) for p in panels], axis=1)
    width = row.shape[1]
    head = np.full((22, width, 3), 255, np.uint8)
    for i, t in enumerate(titles):
        cv2.putText(head, t, (i * (PANEL_PX + 4) + 6, 16), cv2.FONT_HERSHEY_SIMPLEX, 0.42, (0, 0, 0), 1, cv2.LINE_AA)
    lines = textwrap.wrap("Rejected: " + reason, width=int(width / 7.2))
    foot = np.full((14 + 18 * len(lines), width, 3), 255, np.uint8)
    for i, line in enumerate(lines):
        cv2.putText(foot, line, (6, 18 + 18 * i), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (150, 0, 0), 1, cv2.LINE_AA)
    return srgb_to_linear(np.concatenate([head, row, foot], axis=0).astype(np.float32) / 255.0).astype(np.float32)
