"""Flattening uneven lighting (vignetting, broad highlights, a back-light hot spot).

Not a section of Wu et al. 2025 on its own: §4 assumes "approximately soft and uniform" room
light. Real photos break that, and the Radon, DMF and projection steps assume a stationary
texture, so the slowly varying part of the brightness is divided out first.
"""

from __future__ import annotations

import cv2
import numpy as np


def luminance(rgb: np.ndarray) -> np.ndarray:
    """Linear luminance (Rec. 709) of an H×W×3 linear RGB image, or the image itself if H×W."""
    if rgb.ndim == 2:
        return rgb.astype(np.float32, copy=False)
    return (rgb[..., :3] @ np.array([0.2126, 0.7152, 0.0722], np.float32)).astype(np.float32)


def illumination_field(grey: np.ndarray, *, sigma_px: float) -> np.ndarray:
    """The slowly varying brightness of a photo: a Gaussian low-pass of ``grey``.

    Parameters
    ----------
    grey : (H, W) float array, linear.
    sigma_px : σ of the low-pass in pixels; a few yarn pitches, so that the weave itself
        averages out.

    Returns
    -------
    (H, W) float32 array, strictly positive.
    """
    g = grey.astype(np.float32)
    h, w = g.shape
    # blur a downscaled copy: the field is smooth, and this keeps big photos cheap
    f = max(1.0, sigma_px / 4.0)
    small = cv2.resize(g, (max(1, round(w / f)), max(1, round(h / f))), interpolation=cv2.INTER_AREA)
    small = cv2.GaussianBlur(small, (0, 0), sigma_px / f, borderType=cv2.BORDER_REFLECT)
    field = cv2.resize(small, (w, h), interpolation=cv2.INTER_LINEAR)
    floor = max(1e-4, 0.02 * float(np.mean(g)))
    return np.maximum(field, floor)


def flatten_illumination(image: np.ndarray, *, sigma_px: float) -> tuple[np.ndarray, np.ndarray]:
    """Divide out the lighting of a linear image, keeping its mean brightness.

    Parameters
    ----------
    image : (H, W) or (H, W, 3) float array, linear.
    sigma_px : σ of the lighting low-pass in pixels (see :func:`illumination_field`).

    Returns
    -------
    flat : same shape as ``image``, float32, lit evenly.
    gain : (H, W) float32, the relative lighting (mean 1) that was divided out.
    """
    field = illumination_field(luminance(image), sigma_px=sigma_px)
    gain = (field / float(np.mean(field))).astype(np.float32)
    flat = image / (gain[..., None] if image.ndim == 3 else gain)
    return flat.astype(np.float32), gain


def colour_normalised(image: np.ndarray, *, sigma_px: float) -> np.ndarray:
    """Each channel of a linear photo divided by its own low-pass (:func:`illumination_field`,
    σ ``sigma_px``, about a yarn pitch): (H, W, C) float32, each channel's mean about 1.

    A yarn-dyed stripe or check, a colour block and the lighting all vary slower than the
    yarns; divided out channel by channel they leave what every yarn has whatever its colour:
    its edges, gaps and shading, and its colour relative to its neighbours' (a warp against
    the weft it crosses). The low-pass keeps nothing of the yarn frequency (its gain there is
    exp(−2π²σ²/p²), 3·10⁻⁹ at σ = one pitch p).
    """
    img = np.asarray(image, np.float32)
    if img.ndim == 2:
        img = img[..., None]
    return np.stack([img[..., c] / illumination_field(img[..., c], sigma_px=sigma_px)
                     for c in range(img.shape[2])], axis=2)


def colour_blind(image: np.ndarray, *, sigma_px: float) -> np.ndarray:
    """The texture of a linear photo without its colours: the channels of
    :func:`colour_normalised` averaged, (H, W) float32 of mean about 1 (§4.1's angles and
    §4.4's projections then find the yarns, not the stripes)."""
    return colour_normalised(image, sigma_px=sigma_px).mean(axis=2)
