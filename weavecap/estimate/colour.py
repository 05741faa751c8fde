"""Colour pre-estimation (Wu et al. 2025 §5.2), and CIELAB differences to judge it.

§5.2 takes the warp and weft colours from the photo's cells, averaged with 10% of each edge
dropped, and the specular colour from the brightest 10% of the yarn pixels. Here the cell
averages also leave out the pixels that are not wholly yarn in the model's render (the gaps
between yarns, which under a back light are far brighter than any yarn, and one pixel around
them): a body colour moves those pixels least and a small misfit there would move it most. Those are
radiances; the fabric needs albedos. A render is linear in the body colours and in the
specular colour (all other parameters fixed), so three renders of the current fabric — warps
and wefts black, warps white, wefts white — give, per channel, the linear map from the two
body colours to the two cell averages, which is inverted (a 2 × 2 system per channel); two
more renders do the same for the specular reflection colour R^S over the bright pixels. The
body subsurface colour S^B is set equal to the body colour. Everything is linear RGB.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import binary_erosion

from ..params import Fabric
from .forward import RepeatRenderer

TRIM = 0.1  # §5.2: 10% of each cell edge is ignored
TOP = 0.1  # §5.2: the brightest 10% of the yarn pixels give the specular colour


@dataclass(frozen=True)
class Colours:
    """Pre-estimated colours, linear RGB in [0, 1].

    Attributes
    ----------
    warp, weft : body colours R^B (= S^B) of the warps and the wefts.
    specular : specular reflection colour R^S.
    observed : the photo's raw averages (warp cells, weft cells, bright pixels), radiance.
    specular_visible : False when the bright pixels do not respond to R^S in the model (the
        specular colour is then the fabric's own, unchanged).
    sensitivity : (warp, weft): how much the yarn's own cell average moves per unit of its body
        colour in the model (mean over channels). Small values (a very transparent or very
        specular yarn) mean the photo shows little of that colour, and its estimate is loose.
    exposure : the smallest g for which the photo divided by g needs no body colour above 1
        (the colours are affine in the photo, and the colour-free light stays): above 1 the
        photo is brighter than the light rig can make this fabric (its exposure,
        :attr:`weavecap.estimate.preestimate.PreEstimate.gain`); NaN when no g does.
    """

    warp: tuple[float, float, float]
    weft: tuple[float, float, float]
    specular: tuple[float, float, float]
    observed: dict
    specular_visible: bool
    sensitivity: tuple[float, float] = (float("nan"), float("nan"))
    exposure: float = float("nan")

    def values(self) -> dict:
        """As dotted keys of :class:`weavecap.params.Fabric`."""
        return {"warp.body_reflection": self.warp, "warp.body_subsurface": self.warp,
                "weft.body_reflection": self.weft, "weft.body_subsurface": self.weft,
                "specular.reflection": self.specular}


def _cell_mask(shape: tuple[int, int], cell_px: int, trim: float) -> np.ndarray:
    """(n_e * c, n_a * c) bool: the cells' pixels with ``trim`` of each edge dropped."""
    lo, hi = int(round(trim * cell_px)), cell_px - int(round(trim * cell_px))
    one = np.zeros(cell_px, dtype=bool)
    one[lo:hi] = True
    return np.outer(np.tile(one, shape[0]), np.tile(one, shape[1]))


def _yarn_means(image: np.ndarray, pattern: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """(2, 3): mean of ``image`` over ``mask`` in the cells where the warp (row 0) and the weft
    (row 1) is on top; NaN where there is no such pixel."""
    c = image.shape[0] // pattern.shape[0]
    on_top = np.kron(np.asarray(pattern, dtype=np.uint8), np.ones((c, c), dtype=np.uint8)).astype(bool)
    out = np.full((2, 3), np.nan)
    for row, where in enumerate((mask & ~on_top, mask & on_top)):
        if where.any():
            out[row] = image[where].mean(axis=0)
    return out


def observed_colours(canvas: np.ndarray, pattern: np.ndarray, yarn_mask: np.ndarray, *, trim: float = TRIM,
                     top: float = TOP) -> dict:
    """§5.2's raw averages of a cell canvas.

    Parameters
    ----------
    canvas : (n_e * c, n_a * c, 3) linear RGB; pattern : (n_e, n_a) 0/1 (1 = weft on top).
    yarn_mask : (n_e * c, n_a * c) bool, pixels that show a yarn (not a gap).

    Returns
    -------
    dict with ``warp`` and ``weft`` (3,) means over the yarn pixels of the trimmed cells where
    that yarn is on top (NaN when it never is), ``bright`` (3,) mean of the brightest ``top``
    of the yarn pixels (by luminance), and the masks used: ``body_mask`` and ``bright_mask``
    (n_e * c, n_a * c) bool.
    """
    pattern = np.asarray(pattern, dtype=np.uint8)
    cell_px = canvas.shape[0] // pattern.shape[0]
    body_mask = _cell_mask(pattern.shape, cell_px, trim) & yarn_mask
    if not body_mask.any():
        body_mask = _cell_mask(pattern.shape, cell_px, trim)
    means = _yarn_means(canvas, pattern, body_mask)
    lum = canvas @ np.array([0.2126, 0.7152, 0.0722])
    pool = lum[yarn_mask] if yarn_mask.any() else lum.ravel()
    bright = (lum >= np.quantile(pool, 1.0 - top)) & (yarn_mask if yarn_mask.any() else True)
    return {"warp": means[0], "weft": means[1], "bright": canvas[bright].mean(axis=0),
            "body_mask": body_mask, "bright_mask": bright}


def _observe_render(rr: RepeatRenderer, pattern: np.ndarray, obs: dict) -> np.ndarray:
    """(warp cells, weft cells, bright pixels) × RGB averages of the current render over the
    photo's masks: (3, 3)."""
    img = rr.render()
    return np.concatenate([_yarn_means(img, pattern, obs["body_mask"]), img[obs["bright_mask"]].mean(axis=0)[None]])


def _body(rr: RepeatRenderer, yarn: str, rgb) -> None:
    rr.set({f"{yarn}.body_reflection": rgb, f"{yarn}.body_subsurface": rgb})


def estimate_colours(canvas: np.ndarray, fabric: Fabric, *, cell_px: int, light: str = "both",
                     renderer: RepeatRenderer | None = None, trim: float = TRIM, top: float = TOP) -> Colours:
    """Warp, weft and specular colours of ``fabric``'s pattern seen in ``canvas`` (§5.2).

    Parameters
    ----------
    canvas : (n_e * cell_px, n_a * cell_px, 3) linear RGB cell canvas of the photo's repeat.
    fabric : pattern and every other parameter (its own colours are not used, except the
        specular colour when the photo shows no specular response).
    renderer : a :class:`RepeatRenderer` of ``fabric`` to reuse (its colours are changed).

    Returns
    -------
    :class:`Colours`.
    """
    pattern = fabric.pattern.astype(bool)
    rr = renderer or RepeatRenderer(fabric, cell_px=cell_px, light=light)
    yarn_mask = binary_erosion(rr.coverage() >= 0.999, iterations=1 + int(rr.blur_px), border_value=1)
    obs = observed_colours(canvas, pattern, yarn_mask, trim=trim, top=top)
    rows = ~np.isnan(np.stack([obs["warp"], obs["weft"]])[:, 0])  # which yarns are ever on top

    rr.set({"specular.reflection": fabric.specular.reflection})
    responses = []
    for warp_rgb, weft_rgb in (((0.0,) * 3, (0.0,) * 3), ((1.0,) * 3, (0.0,) * 3), ((0.0,) * 3, (1.0,) * 3)):
        _body(rr, "warp", warp_rgb)
        _body(rr, "weft", weft_rgb)
        responses.append(_observe_render(rr, pattern, obs))
    base, d_warp, d_weft = responses[0], responses[1] - responses[0], responses[2] - responses[0]
    target = np.stack([obs["warp"], obs["weft"]])
    # the body colours are affine in the photo: body = P - Q, P explaining the photo's cell
    # averages, Q the colour-free light (the render with both colours black)
    explain = np.zeros((2, 2, 3))
    for ch in range(3):
        a = np.stack([d_warp[:2, ch], d_weft[:2, ch]], axis=1)[rows]  # (rows, 2 unknowns)
        for k, seen in enumerate((target[:, ch], base[:2, ch])):
            b = seen[rows]
            if rows.all():
                explain[k, :, ch] = np.linalg.lstsq(a, b, rcond=None)[0]
            else:  # one yarn never on top: both get the colour that explains what is seen
                explain[k, :, ch] = (b / np.maximum(a.sum(axis=1), 1e-9)).mean()
    p, q = explain[0][rows], explain[1][rows]
    body = explain[0] - explain[1]
    # the photo divided by g gives body P / g - Q: the smallest g that keeps every one <= 1
    reach = (p > 0) & (1 + q > 0)
    exposure = float(np.max(p[reach] / (1 + q[reach]))) if reach.any() else float("nan")
    body = np.clip(body, 0.0, 1.0)
    _body(rr, "warp", tuple(body[0]))
    _body(rr, "weft", tuple(body[1]))

    rr.set({"specular.reflection": (0.0,) * 3})
    dark = _observe_render(rr, pattern, obs)[2]
    rr.set({"specular.reflection": (1.0,) * 3})
    gain = _observe_render(rr, pattern, obs)[2] - dark
    visible = bool(np.all(gain > 1e-3))
    specular = np.clip((obs["bright"] - dark) / np.maximum(gain, 1e-3), 0.0, 1.0) if visible \
        else np.asarray(fabric.specular.reflection)
    rr.set({"specular.reflection": tuple(specular)})
    return Colours(warp=tuple(map(float, body[0])), weft=tuple(map(float, body[1])),
                   specular=tuple(map(float, specular)),
                   observed={k: [round(float(x), 5) for x in obs[k]] for k in ("warp", "weft", "bright")},
                   specular_visible=visible,
                   sensitivity=(float(np.mean(d_warp[0])), float(np.mean(d_weft[1]))), exposure=exposure)


# ----------------------------------------------------------------------------- CIELAB

_M_XYZ = np.array([[0.4124564, 0.3575761, 0.1804375],
                   [0.2126729, 0.7151522, 0.0721750],
                   [0.0193339, 0.1191920, 0.9503041]])  # linear sRGB → XYZ, D65
_WHITE = _M_XYZ.sum(axis=1)


def linear_to_lab(rgb) -> np.ndarray:
    """CIELAB (D65) of linear sRGB colours: (..., 3) → (..., 3)."""
    xyz = np.asarray(rgb, dtype=np.float64) @ _M_XYZ.T / _WHITE
    d = 6.0 / 29.0
    f = np.where(xyz > d ** 3, np.cbrt(np.maximum(xyz, 0.0)), xyz / (3 * d * d) + 4.0 / 29.0)
    return np.stack([116 * f[..., 1] - 16, 500 * (f[..., 0] - f[..., 1]), 200 * (f[..., 1] - f[..., 2])], axis=-1)


def delta_e(a, b) -> np.ndarray:
    """CIE76 colour difference ΔE*ab between linear sRGB colours (..., 3)."""
    return np.linalg.norm(linear_to_lab(a) - linear_to_lab(b), axis=-1)
