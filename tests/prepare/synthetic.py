"""Procedural photos of woven fabric with known geometry, for testing ``weavecap.prepare``.

Independent of the forward-model renderer: each yarn is a shaded band (rounded cross-section,
over yarn bright, under yarn shadowed in the gaps, dark background between yarns), laid out
from a binary pattern (row i = weft i, column j = warp j, 1 = weft over warp). The fabric is
then seen through a known homography (in-plane turn, camera pitch/yaw), and degraded by
vignetting, blur, noise and JPEG.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

PATTERNS: dict[str, np.ndarray] = {
    "plain": np.array([[1, 0], [0, 1]]),
    "twill_2_1": np.array([[1, 1, 0], [0, 1, 1], [1, 0, 1]]),
    "twill_3_1": np.array([[1, 1, 1, 0], [0, 1, 1, 1], [1, 0, 1, 1], [1, 1, 0, 1]]),
    "twill_2_2": np.array([[1, 1, 0, 0], [0, 1, 1, 0], [0, 0, 1, 1], [1, 0, 0, 1]]),
    "basket_2_2": np.array([[1, 1, 0, 0], [1, 1, 0, 0], [0, 0, 1, 1], [0, 0, 1, 1]]),
}


def satin(n: int, move: int) -> np.ndarray:
    """An ``n``-end satin (weft-faced): warp up once per row, shifted by ``move``."""
    p = np.ones((n, n), int)
    for i in range(n):
        p[i, (i * move) % n] = 0
    return p


PATTERNS["satin_5"] = satin(5, 2)
PATTERNS["satin_8"] = satin(8, 3)
#: a custom, non-square repeat: 6 wefts x 4 warps
PATTERNS["custom_6x4"] = np.array([[1, 0, 0, 1], [0, 1, 1, 0], [1, 1, 0, 0],
                                   [0, 0, 1, 1], [1, 0, 1, 0], [0, 1, 1, 1]])


@dataclass(frozen=True)
class Truth:
    """The geometry a synthetic photo was made with.

    ``homography`` maps fabric pixels (u, v) (warps vertical, pitch ``pitch_px``) to photo
    pixels; ``angle_deg`` is the turn that makes the warps vertical again (CCW positive).
    """

    pattern: np.ndarray
    pitch_px: tuple[float, float]  # (warp pitch along u, weft pitch along v) in fabric px
    angle_deg: float
    homography: np.ndarray

    @property
    def yarns(self) -> tuple[int, int]:
        return self.pattern.shape  # (wefts, warps)


def _camera_homography(size: tuple[int, int], angle_deg: float, pitch_deg: float, yaw_deg: float,
                       focal: float) -> np.ndarray:
    """Fabric plane (centred on the photo) → photo: turn by -angle, then a camera rotation."""
    h, w = size
    c = np.array([[1, 0, -w / 2], [0, 1, -h / 2], [0, 0, 1]], float)
    a = np.deg2rad(-angle_deg)  # the photo is the fabric turned clockwise by angle
    rot = np.array([[np.cos(a), np.sin(a), 0], [-np.sin(a), np.cos(a), 0], [0, 0, 1]])
    p, y = np.deg2rad(pitch_deg), np.deg2rad(yaw_deg)
    rx = np.array([[1, 0, 0], [0, np.cos(p), -np.sin(p)], [0, np.sin(p), np.cos(p)]])
    ry = np.array([[np.cos(y), 0, np.sin(y)], [0, 1, 0], [-np.sin(y), 0, np.cos(y)]])
    k = np.diag([focal, focal, 1.0])
    cam = k @ rx @ ry @ np.linalg.inv(k)
    return np.linalg.inv(c) @ cam @ rot @ c


def render(pattern: str | np.ndarray = "twill_2_1", *, size: tuple[int, int] = (384, 384),
           pitch_px: float | tuple[float, float] = 12.0, yarn_width: float = 0.85,
           warp_rgb=(0.55, 0.35, 0.25), weft_rgb=(0.35, 0.45, 0.6), background=0.03,
           angle_deg: float = 0.0, pitch_deg: float = 0.0, yaw_deg: float = 0.0,
           noise: float = 0.0, blur: float = 0.0, jpeg: int | None = None,
           vignette: float = 0.0, seed: int = 0, supersample: int = 2, warp_stripes=None,
           weft_stripes=None) -> tuple[np.ndarray, Truth]:
    """Render a linear float32 H×W×3 photo of a weave and its ground truth.

    ``pitch_px`` is (warp pitch, weft pitch) in photo pixels at the photo centre;
    ``yarn_width`` the yarn width as a fraction of the pitch; ``noise`` the σ of Gaussian noise
    in linear units; ``blur`` a Gaussian σ in px; ``jpeg`` a JPEG quality; ``vignette`` the
    relative fall-off of brightness at the corners. ``warp_stripes`` / ``weft_stripes``: a
    sequence of RGB colours given to successive warps (wefts) in turn, a yarn-dyed stripe or
    check (instead of ``warp_rgb`` / ``weft_rgb``).
    """
    pat = PATTERNS[pattern] if isinstance(pattern, str) else np.asarray(pattern)
    px, py = (pitch_px, pitch_px) if np.isscalar(pitch_px) else pitch_px
    rng = np.random.default_rng(seed)
    h, w = size
    hmg = _camera_homography(size, angle_deg, pitch_deg, yaw_deg, focal=1.2 * max(h, w))
    s = supersample
    ys, xs = np.mgrid[0:h * s, 0:w * s].astype(np.float64)
    pts = np.stack([(xs + 0.5) / s - 0.5, (ys + 0.5) / s - 0.5, np.ones_like(xs)], -1)
    uvw = pts @ np.linalg.inv(hmg).T
    u, v = uvw[..., 0] / uvw[..., 2], uvw[..., 1] / uvw[..., 2]
    off = rng.uniform(0, 1, 2)
    fu, fv = u / px + off[0], v / py + off[1]
    j, i = np.floor(fu).astype(int), np.floor(fv).astype(int)
    du, dv = fu - j - 0.5, fv - i - 0.5  # position in the cell, [-0.5, 0.5)
    n_w, n_a = pat.shape
    weft_over = pat[i % n_w, j % n_a] == 1
    half = yarn_width / 2

    def profile(d):  # rounded cross-section: 1 at the centre, dark at the edges
        t = np.clip(np.abs(d) / half, 0, 1)
        return np.where(np.abs(d) < half, 0.25 + 0.75 * np.sqrt(1 - t ** 2), 0.0)

    warp_p, weft_p = profile(du), profile(dv)
    # the over yarn dips at the cell ends where it goes under its neighbours
    warp_len = 0.8 + 0.2 * np.cos(np.pi * dv) ** 0.5
    weft_len = 0.8 + 0.2 * np.cos(np.pi * du) ** 0.5
    # per-yarn colour jitter, as real yarns vary a little
    jit_w = 1 + 0.05 * rng.standard_normal(4096)
    jit_e = 1 + 0.05 * rng.standard_normal(4096)
    warp_i = warp_p * warp_len * jit_w[j % 4096]
    weft_i = weft_p * weft_len * jit_e[i % 4096]
    top_warp = np.where(weft_over, 0, warp_i)
    top_weft = np.where(weft_over, weft_i, 0)
    under_warp = np.where(weft_over & (weft_p == 0), 0.45 * warp_i, 0)
    under_weft = np.where(~weft_over & (warp_p == 0), 0.45 * weft_i, 0)
    wa = np.asarray(warp_rgb, float) if warp_stripes is None else np.asarray(warp_stripes, float)[j % len(warp_stripes)]
    we = np.asarray(weft_rgb, float) if weft_stripes is None else np.asarray(weft_stripes, float)[i % len(weft_stripes)]
    img = ((top_warp + under_warp)[..., None] * wa + (top_weft + under_weft)[..., None] * we)
    img = np.maximum(img, background)
    img = cv2.resize(img.astype(np.float32), (w, h), interpolation=cv2.INTER_AREA)
    if vignette:
        yy, xx = np.mgrid[0:h, 0:w]
        r2 = ((xx - w / 2) ** 2 + (yy - h / 2) ** 2) / ((w / 2) ** 2 + (h / 2) ** 2)
        img *= (1 - vignette * r2)[..., None].astype(np.float32)
    if blur:
        img = cv2.GaussianBlur(img, (0, 0), blur)
    if noise:
        img = img + rng.normal(0, noise, img.shape).astype(np.float32)
    img = np.clip(img, 0, 1)
    if jpeg:
        srgb = np.where(img <= 0.0031308, 12.92 * img, 1.055 * img ** (1 / 2.4) - 0.055)
        ok, buf = cv2.imencode(".jpg", (srgb * 255 + 0.5).astype(np.uint8), [cv2.IMWRITE_JPEG_QUALITY, jpeg])
        srgb = cv2.imdecode(buf, cv2.IMREAD_UNCHANGED).astype(np.float32) / 255
        img = np.where(srgb <= 0.04045, srgb / 12.92, ((srgb + 0.055) / 1.055) ** 2.4)
    return img.astype(np.float32), Truth(pat, (float(px), float(py)), float(angle_deg), hmg)


def _jacobian(hmg: np.ndarray, x: float, y: float) -> np.ndarray:
    p = hmg @ np.array([x, y, 1.0])
    return (hmg[:2, :2] - np.outer(p[:2] / p[2], hmg[2, :2])) / p[2]


def residual_geometry(estimated: np.ndarray, truth: Truth, size: tuple[int, int]) -> dict:
    """How far a rectifying homography (photo → rectified) is from the truth.

    The composed map fabric → rectified should be a scaling plus a shift. Returns ``turn_deg``
    (its rotation at the photo centre, wrapped to ±45°), ``skew`` (|cos| of the angle between
    the mapped warp and weft directions: 0.01 is 1 %), ``perspective`` (largest relative change
    of the mapped pitch over the middle half of the photo), and ``scale`` ((sx, sy): rectified px
    per fabric px along the weft and warp directions at the centre).
    """
    h, w = size
    comp = estimated @ truth.homography
    c = np.linalg.inv(truth.homography) @ np.array([(w - 1) / 2, (h - 1) / 2, 1.0])
    u, v = c[0] / c[2], c[1] / c[2]
    jac = _jacobian(comp, u, v)
    ux, uy = jac[:, 0], jac[:, 1]
    uu, s, vt = np.linalg.svd(jac)
    r = uu @ vt
    turn = float(np.rad2deg(np.arctan2(r[0, 1], r[0, 0])))
    turn = (turn + 45) % 90 - 45
    skew = abs(ux @ uy) / (np.linalg.norm(ux) * np.linalg.norm(uy))
    scales = []
    for fx in (-0.25, 0.25):
        for fy in (-0.25, 0.25):
            q = np.linalg.inv(truth.homography) @ np.array([(0.5 + fx) * w, (0.5 + fy) * h, 1.0])
            j = _jacobian(comp, q[0] / q[2], q[1] / q[2])
            scales.append(np.linalg.norm(j, axis=0))
    scales = np.array(scales)
    persp = float(np.max(np.abs(scales / np.linalg.norm(jac, axis=0) - 1)))
    return {"turn_deg": turn, "skew": float(skew), "perspective": persp,
            "scale": (float(np.linalg.norm(ux)), float(np.linalg.norm(uy)))}
