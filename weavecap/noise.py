"""Irregularity post-estimation (§6.3 of Wu et al. 2025): 2D Gaussians over the residual's
frequency spectrum, and synthesis of matching noise for tiles of any size.

The residual (:func:`irregularity`) holds what the procedural model cannot and what differs
from one repeat of the photo to the next: flyaways, uneven yarns, highlights — relative to
the photo's brightness, so that it does not depend on the exposure. Its power spectrum is
modelled as a mixture of 2D Gaussians in frequency measured in *cycles per yarn pitch*, so
the model does not depend on the photo's resolution either. Each Gaussian's ``weight`` is the
variance it carries (of the relative brightness), so the weights sum to the residual's
variance. Synthesis draws random phases under that spectrum and transforms back to the image
domain [GHCG17-style spectral synthesis]; a render is multiplied by one plus it
(:func:`add_noise`, :func:`weavecap.render.surface.noise_map`).

The fit samples frequencies with probability proportional to power and fits scikit-learn's
``GaussianMixture`` to them — a few thousand points, milliseconds.
"""

from __future__ import annotations

import numpy as np

SAMPLES = 4000  # frequency samples drawn from the power spectrum for the mixture fit
MIN_VARIANCE = 1e-10  # below this the residual is treated as noise-free


def _frequencies(shape: tuple[int, int], pitch_px: float) -> tuple[np.ndarray, np.ndarray]:
    """FFT-grid frequencies (fy, fx) in cycles per yarn pitch, each of ``shape``."""
    fy = np.fft.fftfreq(shape[0]) * pitch_px
    fx = np.fft.fftfreq(shape[1]) * pitch_px
    return np.meshgrid(fy, fx, indexing="ij")


def irregularity(photo: np.ndarray, render: np.ndarray, *, cell_px: int, repeat: tuple[int, int],
                 first: tuple[int, int] = (0, 0)) -> np.ndarray:
    """§6.3's residual: what of the photo the capture does not explain and that differs between
    the repeats of the weave, as relative brightness.

    Parameters
    ----------
    photo, render : (Y·c, X·c, 3) linear RGB registered cell for cell — the photo over whole
        cells and the capture rendered over them as photographed
        (:class:`weavecap.fit.compare.PhotoScale`'s ``view.canvas`` and ``render``)
    cell_px : c, pixels a cell side
    repeat : (n_e, n_a), the fabric's repeat in cells (its weave's, or with thread colours the
        full one: :attr:`weavecap.params.Fabric.full_repeat`)
    first : (v0, u0), the repeat's cell that the canvas's first cell shows

    Returns
    -------
    (Y·c, X·c) float64: the photo's grey over its local mean less the render's over its own
    (each local mean a Gaussian of a repeat's size, at least two cells: what varies over more
    than a repeat — light falloff, vignetting, the exposure — is not an irregularity), less the
    part of that which repeats with the weave: its mean over the repeats in view of each cell
    of the repeat, where that cell is seen at least twice (the remainder scaled by
    √(k / (k − 1)) for k views, as a sample's deviations from its own mean are). Zeros where
    the photo is black.

    The part that repeats is the model's misfit, not an irregularity: drawn at random phases, as
    synthesis draws, it is the weave's own frequency at random — the captures of real photos
    fitted on the whole residual of one repeat rendered as black and white blotches.
    """
    from scipy.ndimage import gaussian_filter

    c = int(cell_px)
    n_e, n_a = (int(v) for v in repeat)
    sigma = c * max(n_e, n_a, 2)

    def relative(image) -> np.ndarray:
        grey = np.asarray(image, np.float64).mean(axis=2)
        grey = np.where(np.isfinite(grey), grey, 0.0)
        local = gaussian_filter(grey, sigma=sigma, mode="reflect")
        return np.where(local > 1e-6 * max(float(grey.max()), 1e-300), grey / np.maximum(local, 1e-300), 1.0)

    r = relative(photo) - relative(render)
    if r.size == 0 or not np.any(np.asarray(photo) > 0):
        return np.zeros(r.shape)
    from .estimate.cells import repeat_deviation

    deviation, seen = repeat_deviation(r, c, (n_e, n_a), first)
    out = r.copy()
    out[:seen.shape[0], :seen.shape[1]] = np.where(seen, deviation, r[:seen.shape[0], :seen.shape[1]])
    return out


def fit_noise(residual: np.ndarray, *, pitch_px: float, components: int = 4, seed: int = 0) -> dict:
    """Fit the §6.3 model to a residual.

    Parameters
    ----------
    residual : (H, W) or (H, W, 3) float array (:func:`irregularity`'s relative brightness;
        colour is averaged to grey). Non-finite entries count as 0.
    pitch_px : the yarn pitch in the residual's pixels (sets the frequency unit)
    components : number of Gaussians (fewer when the residual is too small)
    seed : seeds the mixture fit

    Returns
    -------
    ``{"gaussians": [{"weight", "mean": [fy, fx], "cov": [[..], [..]]}, ...]}`` as in
    params.schema.json (mean/cov in cycles per pitch; no Gaussians for a flat residual).
    """
    r = np.asarray(residual, dtype=np.float64)
    if r.ndim == 3:
        r = r.mean(axis=2)
    r = np.where(np.isfinite(r), r, 0.0)
    r = r - r.mean()
    variance = float(np.mean(r**2))
    if r.size < 16 or variance < MIN_VARIANCE or not np.isfinite(pitch_px) or pitch_px <= 0:
        return {"gaussians": []}
    power = np.abs(np.fft.fft2(r)) ** 2
    power[0, 0] = 0.0
    fy, fx = _frequencies(r.shape, pitch_px)
    rng = np.random.default_rng(seed)
    p = power.ravel() / power.sum()
    idx = rng.choice(p.size, size=SAMPLES, p=p)
    # jitter within a frequency bin so that a single strong bin is not a zero-width point
    dy, dx = pitch_px / r.shape[0], pitch_px / r.shape[1]
    pts = np.stack([fy.ravel()[idx] + rng.uniform(-dy / 2, dy / 2, SAMPLES),
                    fx.ravel()[idx] + rng.uniform(-dx / 2, dx / 2, SAMPLES)], axis=1)
    k = int(max(1, min(components, len(np.unique(idx)))))
    from sklearn.mixture import GaussianMixture  # here: importing scikit-learn takes seconds a render would pay

    gmm = GaussianMixture(n_components=k, covariance_type="full", reg_covar=max(dy, dx) ** 2 / 12,
                          random_state=seed).fit(pts)
    gaussians = [{"weight": float(w * variance), "mean": [float(v) for v in m],
                  "cov": [[float(v) for v in row] for row in c]}
                 for w, m, c in zip(gmm.weights_, gmm.means_, gmm.covariances_)]
    return {"gaussians": gaussians}


def spectrum(noise: dict, shape: tuple[int, int], pitch_px: float) -> np.ndarray:
    """The model's power density (variance per unit frequency², cycles per pitch) on the FFT
    grid of ``shape``."""
    fy, fx = _frequencies(shape, pitch_px)
    f = np.stack([fy, fx], axis=-1)
    out = np.zeros(shape)
    for g in noise.get("gaussians", []):
        cov = np.asarray(g["cov"], dtype=np.float64)
        inv, det = np.linalg.inv(cov), np.linalg.det(cov)
        d = f - np.asarray(g["mean"], dtype=np.float64)
        q = np.einsum("...i,ij,...j->...", d, inv, d)
        out += g["weight"] * np.exp(-0.5 * q) / (2 * np.pi * np.sqrt(det))
    return out


def synthesize(noise: dict, shape: tuple[int, int], *, pitch_px: float, seed: int = 0) -> np.ndarray:
    """A (H, W) noise tile with the model's spectrum: random phases, amplitude √density.

    The tile is periodic (it tiles seamlessly) and its variance is the model's variance within
    the frequencies the tile can hold (up to Nyquist), so a coarser tile carries less — and
    never more than the model's whole variance (the sum of the weights): a Gaussian narrower
    than a frequency bin, sampled at its peak, would otherwise count its density as variance
    (a covariance of 1e-12 gave pixel values of 70 000).
    """
    shape = (int(shape[0]), int(shape[1]))
    s = spectrum(noise, shape, pitch_px)
    df = (pitch_px / shape[0]) * (pitch_px / shape[1])
    target_var = min(float(np.sum(s) * df), sum(float(g["weight"]) for g in noise.get("gaussians", [])))
    if target_var <= MIN_VARIANCE or shape[0] * shape[1] < 2:
        return np.zeros(shape)
    rng = np.random.default_rng(seed)
    white = np.fft.fft2(rng.standard_normal(shape))
    tile = np.real(np.fft.ifft2(white * np.sqrt(s)))
    tile -= tile.mean()
    std = tile.std()
    return tile * (np.sqrt(target_var) / std) if std > 0 else tile


def add_noise(image: np.ndarray, noise: dict | None, *, pitch_px: float, seed: int = 0) -> np.ndarray:
    """``image`` (H, W, 3) linear RGB times one plus the synthesized relative noise (the same
    on every channel), clipped at 0."""
    if not noise or not noise.get("gaussians"):
        return image
    tile = synthesize(noise, image.shape[:2], pitch_px=pitch_px, seed=seed)
    return np.clip(image * (1.0 + tile[..., None]), 0.0, None).astype(image.dtype)
