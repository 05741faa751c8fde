"""How well one photo determines each continuous parameter of the fitted fabric.

The fit minimises the MSE between a render of one repeat, as photographed, and the photo's
median repeat (§6). Near that minimum a nonlinear least-squares fit has the covariance

    Σ = s² A (JᵀJ)⁻¹,

where J (values × parameters) is the render's Jacobian with respect to the parameters, s² the
residual's variance per value and A its *correlation area* — how many neighbouring values
(pixels and channels) each independent piece of residual spreads over: blur, JPEG blocks and
model mismatch make the residual smooth, and counting every pixel as independent would make
the errors look √A times smaller than they are. A parameter that barely moves the render (the
ior, Table 1's narrow ranges) or whose effect another can take over (a body colour against the
transmission of a back-lit pale yarn) gets a large diagonal entry of (JᵀJ)⁻¹: the photo does
not determine it, however well the fit matches the photo.

Some directions no photo can see. The body lobes weigh R^B by ``specular.coefficient`` m_r
and S^B by 1 − m_r (§3.3), so moving m_r and rescaling both colours to keep m_r R^B and
(1 − m_r) S^B leaves every render unchanged (0.6 → 0.5 with the colours rescaled: renders equal
to 6e-8): the colours and m_r are determined only together. (JᵀJ)⁻¹ is therefore taken by its
eigenvectors: an unseen direction is left out (as a pseudo-inverse would), and every value that
moves along it is reported as undetermined — a pseudo-inverse alone would report such values
with the error of the seen directions only. Such values get an infinite error (``null`` in
report.json). (Two alternatives were tried on the quick bench: a uniform prior over each range
shrank the errors of weakly seen values below their true errors — 56% of the true errors
within 2 SE, against 87–89% without it; a floor on the eigenvalues spilled the unseen
direction's variance onto every value with the smallest loading on it.)

J is taken by forward finite differences of :data:`STEP` of each parameter's range (colours
per channel), on renders made with the same samples, so the differences hold no sampling
noise. A parameter is reported as *determined* when its standard error is at most
:data:`DETERMINED_SE` of its range (two standard errors inside the 10% accuracy
goal). Units: every error is a fraction of the parameter's Table 1 range.
"""

from __future__ import annotations

import numpy as np

from ..model.render import as_photographed, render_numpy, white_level
from ..model.scene import View, build_scene
from ..params import CONTINUOUS_KEYS, FIT_RANGES, Fabric

STEP = 0.02  # finite-difference step, fraction of each range
DETERMINED_SE = 0.05  # standard error (fraction of the range) up to which the photo determines a value
NULL_FLOOR = 1e-10  # eigenvalues of JᵀJ below this fraction of the largest count as unseen
NULL_LOADING = 0.01  # a value moving this much (squared share) along an unseen direction is unseen


def correlation_area(residual: np.ndarray, radius: int) -> float:
    """How many values of ``residual`` (H, W, 3) one independent error spreads over: the sum of
    its normalised autocorrelation over spatial lags within ``radius`` px (the repeat wraps
    around), times the share the three channels have in common (1 when they are unrelated, 3
    when they move together). At least 1."""
    r = residual - residual.mean(axis=(0, 1))
    spectra = np.fft.fft2(r, axes=(0, 1))
    cross = np.einsum("hwc,hwd->cd", r, r)  # channel covariance (unnormalised)
    channels = float(cross.sum() / max(np.trace(cross), 1e-30))
    auto = np.real(np.fft.ifft2(np.sum(np.abs(spectra) ** 2, axis=2)))  # summed over channels
    if auto[0, 0] <= 0:
        return 1.0
    auto /= auto[0, 0]
    lags = np.fft.fftfreq(r.shape[0]) * r.shape[0], np.fft.fftfreq(r.shape[1]) * r.shape[1]
    near = (np.abs(lags[0])[:, None] <= radius) & (np.abs(lags[1])[None, :] <= radius)
    return max(1.0, float(auto[near].sum()) * max(1.0, channels))


def standard_errors(fabric: Fabric, target: np.ndarray, *, blur_px: float, light: str = "both",
                    spp: int = 4, fixed: frozenset = frozenset(), scene=None,
                    rendered: np.ndarray | None = None) -> dict[str, float]:
    """Standard error of every continuous parameter of ``fabric`` fitted to ``target``.

    Parameters
    ----------
    fabric : the fitted fabric; target : (n_e*c, n_a*c, 3) the photo's median repeat (linear RGB)
    blur_px : σ of the blur the renders are compared with (canvas px); light : the rig; spp :
        samples per pixel (the fit's)
    fixed : keys the fit holds fixed: they are no unknowns here (and get no error)
    scene, rendered : the caller's scene of ``fabric`` (one repeat at the target's size, under
        ``light``, at ``spp``) and its render as photographed, when it has them: the render is
        not made again (the scene is left as it was given)

    Returns
    -------
    dict dotted key → standard error as a fraction of the key's Table 1 range (a colour: its
    worst channel); ``inf`` for a value that moves along a direction no render sees. One
    render per scalar value (32 for a fabric without textures).
    """
    target = np.asarray(target, dtype=np.float64)
    h, w = target.shape[:2]
    fs = scene if scene is not None else build_scene(fabric, View(tiles=(1, 1), size=max(h, w), spp=spp), light=light)
    white = white_level(target)

    def shown() -> np.ndarray:
        return as_photographed(render_numpy(fs, spp=spp), blur_px, white).astype(np.float64)

    base = shown() if rendered is None else np.asarray(rendered, dtype=np.float64)
    jac, owners = _jacobian(fs, fabric, shown, base, fixed)
    residual = base - target
    c = h // fabric.shape[0]
    noise = float(np.mean(residual ** 2)) * correlation_area(residual, max(1, c // 2))
    # (JᵀJ)⁻¹ by its eigenvectors; a direction the photo does not see (eigenvalue below
    # NULL_FLOOR of the largest) is left out, as a pseudo-inverse would, but the values that
    # move along it (a loading of at least NULL_LOADING) are marked as not seen at all
    eigval, eigvec, null = _eigen(jac)
    variance = noise * (eigvec[:, ~null] ** 2 @ (1.0 / eigval[~null]))
    variance[_moves_unseen(eigvec, null)] = np.inf
    out: dict[str, float] = {}
    for key, var in zip(owners, variance):
        out[key] = max(out.get(key, 0.0), float(np.sqrt(max(var, 0.0))))
    return out


def unseen(fabric: Fabric, *, size: int, light="both", spp: int = 4, fixed: frozenset = frozenset()) -> dict[str, float]:
    """The continuous values of ``fabric`` that move along a direction no render of its repeat
    sees (one repeat, ``size`` px on its longer side, under ``light``): key → ``inf``, the error
    :func:`standard_errors` gives them against any photo. Only the render's Jacobian decides it:
    one render per scalar value and one of ``fabric``."""
    fs = build_scene(fabric, View(tiles=(1, 1), size=size, spp=spp), light=light)
    image = render_numpy(fs, spp=spp)
    white = white_level(image)

    def shown() -> np.ndarray:
        return as_photographed(render_numpy(fs, spp=spp), 0.0, white).astype(np.float64)

    jac, owners = _jacobian(fs, fabric, shown, as_photographed(image, 0.0, white).astype(np.float64), fixed)
    eigval, eigvec, null = _eigen(jac)
    return {key: np.inf for key, moves in zip(owners, _moves_unseen(eigvec, null)) if moves}


def _jacobian(fs, fabric: Fabric, shown, base: np.ndarray, fixed: frozenset) -> tuple[np.ndarray, list[str]]:
    """(values × parameters) forward differences of :data:`STEP` of each free continuous value's
    range (a colour per channel) of ``shown()`` (the scene's render as compared) from ``base``,
    and the key of each column. Every value is set back afterwards."""
    columns, owners = [], []
    for key in CONTINUOUS_KEYS:
        if key in fs.textures or key in fixed:
            continue
        lo, hi = FIT_RANGES[key]
        value = np.atleast_1d(np.asarray(fabric.get(key), dtype=np.float64))
        for i in range(value.size):
            unit = (value[i] - lo) / (hi - lo)
            step = STEP if unit + STEP <= 1.0 else -STEP
            moved = value.copy()
            moved[i] = lo + (unit + step) * (hi - lo)
            fs.set(key, tuple(moved) if value.size == 3 else float(moved[0]))
            columns.append(((shown() - base) / step).ravel())
            owners.append(key)
        fs.set(key, tuple(value) if value.size == 3 else float(value[0]))
    return np.stack(columns, axis=1), owners


def _eigen(jac: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """JᵀJ's eigenvalues and eigenvectors, and which directions are unseen (an eigenvalue below
    :data:`NULL_FLOOR` of the largest)."""
    eigval, eigvec = np.linalg.eigh(jac.T @ jac)
    return eigval, eigvec, eigval < NULL_FLOOR * max(float(eigval[-1]), 1e-30)


def _moves_unseen(eigvec: np.ndarray, null: np.ndarray) -> np.ndarray:
    """Per column, whether its value moves along an unseen direction (a squared loading of at
    least :data:`NULL_LOADING`)."""
    return (eigvec[:, null] ** 2).sum(axis=1) >= NULL_LOADING
