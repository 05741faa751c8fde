"""Regularization (Wu et al. 2025 §4.2): Gaussian denoising, then kernel PCA over repeats.

The rectified photo is smoothed with a Gaussian of σ = yarn pitch / 16 (a yarn holds 10–20
fibres across, so this removes pixel noise but keeps fibre-scale shading), then every
minimum repeat of a box around the centre is projected onto the few leading kernel principal
components of all the repeats and mapped back (scikit-learn ``KernelPCA`` with its learned
pre-image). What all repeats share — the weave — stays; what only some have — a slub, a stray
fibre, a stain, noise — goes.

The cost is bounded whatever the photo's size: the box is at most ``regularize_max_px`` on a
side of the rectified image (whose pitch is at most ``rectified_pitch_px``), a repeat is
resampled to at most ``kpca_max_patch_px`` on a side, and at most ``kpca_max_patches``
repeats are used to fit the components.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from .config import PrepareConfig


@dataclass(frozen=True)
class Regularized:
    """The result of :func:`regularize`.

    Attributes
    ----------
    image : (h, w, 3) float32 linear RGB, the regularized box.
    box : (y0, x0, y1, x1) of that box in rectified pixels (may be fractional at the far
        end: the box holds a whole number of repeats).
    sigma_px : σ of the Gaussian (rectified px).
    method : "kpca" or "gaussian" (kernel PCA skipped, see ``note``).
    components : kernel principal components kept (0 for "gaussian").
    repeats : repeats in the box (all reconstructed); ``fitted``: how many fitted the KPCA.
    note : why kernel PCA was skipped, or "".
    """

    image: np.ndarray
    box: tuple[float, float, float, float]
    sigma_px: float
    method: str
    components: int
    repeats: int
    fitted: int
    note: str = ""

    def to_json(self) -> dict:
        return {"method": self.method, "sigma_px": round(self.sigma_px, 4),
                "box_px": [round(float(v), 2) for v in self.box], "components": self.components,
                "repeats": self.repeats, "fitted": self.fitted, **({"note": self.note} if self.note else {})}


def gaussian(rgb: np.ndarray, sigma_px: float) -> np.ndarray:
    """Gaussian filter of an (H, W[, 3]) image with σ = ``sigma_px`` (no-op below 0.3 px)."""
    if sigma_px < 0.3:
        return rgb.astype(np.float32, copy=True)
    return cv2.GaussianBlur(rgb.astype(np.float32), (0, 0), sigma_px, borderType=cv2.BORDER_REFLECT)


def _kpca_reconstruct(tiles: np.ndarray, *, components: int, max_fit: int, seed: int) -> tuple[np.ndarray, int, int]:
    """Project (N, D) tiles onto the leading kernel principal components and back (§4.2).

    The dense linear algebra (an N×N eigenproblem, a ridge solve) runs on one BLAS thread:
    these problems are small (N ≤ ``kpca_max_patches``), and on a busy machine OpenBLAS's
    threads wait on each other far longer than the work takes (measured: eigh of 300×300,
    2.1 s on two loaded threads, 0.03 s on one).
    """
    from sklearn.decomposition import KernelPCA
    from threadpoolctl import threadpool_limits

    n = len(tiles)
    rng = np.random.default_rng(seed)
    fit_idx = rng.choice(n, size=min(n, max_fit), replace=False) if n > max_fit else np.arange(n)
    fit = tiles[fit_idx].astype(np.float64)
    k = int(min(components, len(fit) - 1))
    out = np.empty_like(tiles, dtype=np.float32)
    with threadpool_limits(limits=1):
        # RBF width from the typical distance between repeats
        sub = fit[: min(len(fit), 200)]
        sq = (sub ** 2).sum(1)
        d2 = np.maximum(sq[:, None] + sq[None] - 2 * sub @ sub.T, 0)
        med = float(np.median(d2[np.triu_indices(len(sub), 1)])) if len(sub) > 1 else 1.0
        kpca = KernelPCA(n_components=k, kernel="rbf", gamma=1.0 / max(med, 1e-12), fit_inverse_transform=True,
                         alpha=0.05, eigen_solver="dense", random_state=seed)
        kpca.fit(fit)
        for s in range(0, n, 512):
            out[s:s + 512] = kpca.inverse_transform(kpca.transform(tiles[s:s + 512].astype(np.float64)))
    return out, k, len(fit)


def regularize(rgb: np.ndarray, *, pitch_px: tuple[float, float], repeat_px: tuple[float | None, float | None],
               origin_px: tuple[float, float] = (0.0, 0.0),
               config: PrepareConfig = PrepareConfig()) -> Regularized:
    """Regularize a rectified weave photo (§4.2).

    Parameters
    ----------
    rgb : (H, W, 3) float32 linear RGB, rectified (warps vertical).
    pitch_px : (warp pitch along x, weft pitch along y) in px.
    repeat_px : (height, width) of the minimum repeat in px; None on an axis where no repeat
        shows (then only the Gaussian is applied).
    origin_px : (y, x) of a repeat corner (a pair of yarn boundaries); the box of repeats
        starts on this lattice.

    Returns
    -------
    :class:`Regularized`.
    """
    h, w = rgb.shape[:2]
    sigma = float(config.gaussian_sigma_pitch * np.mean(pitch_px))
    smooth = gaussian(rgb, sigma)
    side = config.regularize_max_px
    rh, rw = repeat_px

    def centre_box(n_h: float, n_w: float):
        return (h - n_h) / 2, (w - n_w) / 2

    if rh is None or rw is None or not (np.isfinite(rh) and np.isfinite(rw)):
        bh, bw = min(h, side), min(w, side)
        y0, x0 = (h - bh) // 2, (w - bw) // 2
        return Regularized(smooth[y0:y0 + bh, x0:x0 + bw].copy(), (y0, x0, y0 + bh, x0 + bw), sigma,
                           "gaussian", 0, 0, 0, "no repeat along at least one axis: a single repeat")
    ny, nx = int(min(h, side) // rh), int(min(w, side) // rw)
    if ny * nx < config.kpca_min_repeats:
        bh, bw = min(h, side), min(w, side)
        y0, x0 = (h - bh) // 2, (w - bw) // 2
        return Regularized(smooth[y0:y0 + bh, x0:x0 + bw].copy(), (y0, x0, y0 + bh, x0 + bw), sigma,
                           "gaussian", 0, ny * nx, 0, f"only {ny * nx} whole repeats in the photo")
    # box of ny × nx repeats on the lattice of ``origin_px``, as central as possible
    cy, cx = centre_box(ny * rh, nx * rw)
    oy, ox = origin_px
    y0 = oy + rh * np.floor((cy - oy) / rh + 0.5)
    x0 = ox + rw * np.floor((cx - ox) / rw + 0.5)
    y0 = float(np.clip(y0, 0, max(0.0, h - ny * rh)))
    x0 = float(np.clip(x0, 0, max(0.0, w - nx * rw)))
    # resample so that one repeat is exactly th × tw pixels (at most kpca_max_patch_px)
    f = min(1.0, config.kpca_max_patch_px / max(rh, rw))
    th, tw = max(2, int(round(rh * f))), max(2, int(round(rw * f)))
    sy, sx = th / rh, tw / rw
    m = np.array([[sx, 0, -sx * x0 + 0.5 * sx - 0.5], [0, sy, -sy * y0 + 0.5 * sy - 0.5]], np.float64)
    if f < 1:
        pre = cv2.resize(smooth, None, fx=f, fy=f, interpolation=cv2.INTER_AREA)
        ph, pw = pre.shape[:2]
        kx, ky = pw / w, ph / h
        m = m @ np.array([[1 / kx, 0, 0.5 / kx - 0.5], [0, 1 / ky, 0.5 / ky - 0.5], [0, 0, 1]])
        src = pre
    else:
        src = smooth
    work = cv2.warpAffine(src, m, (nx * tw, ny * th), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)
    tiles = work.reshape(ny, th, nx, tw, 3).transpose(0, 2, 1, 3, 4).reshape(ny * nx, th * tw * 3)
    rec, k, fitted = _kpca_reconstruct(tiles, components=config.kpca_components,
                                       max_fit=config.kpca_max_patches, seed=config.kpca_seed)
    rec_img = rec.reshape(ny, nx, th, tw, 3).transpose(0, 2, 1, 3, 4).reshape(ny * th, nx * tw, 3)
    out_h, out_w = int(round(ny * rh)), int(round(nx * rw))
    image = cv2.resize(rec_img, (out_w, out_h), interpolation=cv2.INTER_LINEAR if f == 1 else cv2.INTER_CUBIC)
    image = np.maximum(image, 0).astype(np.float32)
    return Regularized(image, (y0, x0, y0 + ny * rh, x0 + nx * rw), sigma, "kpca", k, ny * nx, fitted)
