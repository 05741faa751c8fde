"""How faithful a capture is to its photo (docs/design.md, "The capture pipeline": a capture is judged by its photo).

PSNR rewards a blur: a fit that averages the photo's structure away scores well against a
noisy photo. These figures compare the photo's repeat with the fit's render of it (both one
repeat on the same cell canvas, :mod:`weavecap.estimate.cells`) the way a person looks at
compare.png:

- **sharpness** — the render's gradient energy (mean squared gradient of the linear
  luminance, the canvas wrapping around) over the photo's: 1 as sharp as the photo, below 1
  blurrier (a Gaussian blur of σ = a sixth of a cell leaves about a third), above 1 sharper;
- **colour difference per yarn family** — CIEDE2000 between the mean colour of the visible
  warp in the photo and in the render (and likewise the weft): the centre of every cell the
  pattern gives to that family (the yarn on top there), its middle ``centre_share`` of each
  side; means are taken in linear RGB (what the eye sees of a yarn from afar), then converted
  to CIELAB (D65, sRGB primaries);
- **structure correlation** — Pearson's correlation of the two luminance images.

A photo compared with itself scores sharpness 1, ΔE 0 and correlation 1.

The family colours are what the fit's colour solve matches exactly, so their ΔE cannot judge
it, and one median repeat hides how the photo varies. :func:`pixel_fidelity` compares the
photo at its own scale over several repeats with the fit rendered over the same area
(:mod:`weavecap.fit.compare`) pixel by pixel, as a person looks at the two side by side:

- **colour difference percentile** — CIEDE2000 per pixel after a light Gaussian blur of
  :data:`PIXEL_BLUR_PITCH` of a yarn pitch (what a person sees of a yarn, not the camera's
  noise or a hair), its 90th percentile (and median): a stripe in the wrong colour, a yarn
  family in the other's colour, a blur or a misplaced edge all raise it;
- **sharpness** and **structure** as above, on the pair as they are (no wrapping: the area is
  no repeat of the photo); the light blur is the colour figure's alone (a blur lowers the
  gradient energy of a sharp render more than a photo's, whose fine texture is partly noise).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

LUMA = np.array([0.2126, 0.7152, 0.0722])  # Rec. 709 / sRGB primaries, linear


@dataclass(frozen=True)
class Fidelity:
    """The fidelity figures of one capture (see the module's description).

    Attributes
    ----------
    sharpness : render's gradient energy / photo's.
    delta_e : {"warp": ΔE2000, "weft": ΔE2000}, NaN for a family the pattern never shows.
    structure : Pearson correlation of the luminances (-1..1).
    lab : {"warp": {"photo": L*a*b*, "render": L*a*b*}, "weft": ...}.
    clipped : {"warp": share, "weft": share} of the photo's pixels at those cell centres that
        the camera clipped (any channel), on one repeat as shot: how bright they were, the photo
        does not say, so the family's colour there is a lower bound (the median repeat the other
        figures are taken on smooths the clip away). NaN for a family the pattern never shows.
    neutral_delta_e : {"warp": ΔE2000, "weft": ΔE2000}: the captured fabric's colour under a
        neutral light against the photo's, at equal lightness (:func:`neutral_light_delta_e`);
        unlike ``delta_e``, not a figure the fit fits.
    """

    sharpness: float
    delta_e: dict
    structure: float
    lab: dict
    clipped: dict = field(default_factory=dict)
    neutral_delta_e: dict = field(default_factory=dict)

    def to_json(self) -> dict:
        """report.json's ``fit.fidelity``."""
        def num(v, nd=3):
            return round(float(v), nd) if np.isfinite(v) else None

        return {"sharpness": num(self.sharpness), "delta_e": {k: num(v, 2) for k, v in self.delta_e.items()},
                "structure": num(self.structure, 4),
                "lab": {fam: {side: [num(x, 2) for x in lab] for side, lab in d.items()} for fam, d in self.lab.items()},
                "clipped": {k: num(v, 4) for k, v in self.clipped.items()},
                "neutral_delta_e": {k: num(v, 2) for k, v in self.neutral_delta_e.items()}}

    def caption(self) -> str:
        """One line for compare.png."""
        de = " ".join(f"{k} {v:.1f}" if np.isfinite(v) else f"{k} -" for k, v in self.delta_e.items())
        return f"sharpness {self.sharpness:.2f}  dE2000 {de}  structure {self.structure:.2f}"


#: σ of the light blur before the pixel figures, in yarn pitches (a few percent of a yarn)
PIXEL_BLUR_PITCH = 0.06
#: the percentile of the per-pixel colour difference :func:`pixel_fidelity` reports
COLOUR_PERCENTILE = 90


@dataclass(frozen=True)
class PixelFidelity:
    """The pixel figures of a render against its photo at the photo's scale (module docstring).

    Attributes
    ----------
    colour_p90 : 90th percentile of the per-pixel CIEDE2000
    colour_median : its median
    sharpness : render's gradient energy / photo's
    structure : Pearson correlation of the luminances
    blur_px : σ of the light blur both were compared after for the colour figures, pixels
    structure_ceiling : the structure a capture that repeats as the fabric does could reach at
        most on this photo (:func:`structure_ceiling`; NaN where not measured)
    """

    colour_p90: float
    colour_median: float
    sharpness: float
    structure: float
    blur_px: float
    structure_ceiling: float = float("nan")

    def to_json(self) -> dict:
        def num(v, nd=3):
            return round(float(v), nd) if np.isfinite(v) else None

        return {"colour_p90": num(self.colour_p90, 2), "colour_median": num(self.colour_median, 2),
                "sharpness": num(self.sharpness), "structure": num(self.structure, 4), "blur_px": num(self.blur_px),
                "structure_ceiling": num(self.structure_ceiling, 4)}

    def caption(self) -> str:
        ceiling = f" (at most {self.structure_ceiling:.2f})" if np.isfinite(self.structure_ceiling) else ""
        return (f"pixel dE2000 p90 {self.colour_p90:.1f} (median {self.colour_median:.1f})  "
                f"sharpness {self.sharpness:.2f}  structure {self.structure:.2f}{ceiling}")


def pixel_fidelity(photo: np.ndarray, render: np.ndarray, pitch_px: float, *,
                   blur_pitch: float = PIXEL_BLUR_PITCH) -> PixelFidelity:
    """The pixel figures of ``render`` against ``photo``, both (H, W, 3) linear RGB of the same
    area (the photo at its own scale over several repeats and the fit rendered over it as
    photographed, :mod:`weavecap.fit.compare`), after a Gaussian blur of ``blur_pitch`` yarn
    pitches (``pitch_px`` pixels a pitch) for the colour figures."""
    from scipy.ndimage import gaussian_filter
    from skimage.color import deltaE_ciede2000

    from ..estimate.colour import linear_to_lab

    photo = np.asarray(photo, np.float64)
    render = np.asarray(render, np.float64)
    if photo.shape != render.shape:
        raise ValueError(f"photo {photo.shape} and render {render.shape} differ in shape")
    sigma = blur_pitch * float(pitch_px)
    a, b = (gaussian_filter(x, (sigma, sigma, 0), mode="nearest") for x in (photo, render))
    de = deltaE_ciede2000(linear_to_lab(np.clip(a, 0.0, 1.0)), linear_to_lab(np.clip(b, 0.0, 1.0)))
    e_photo = gradient_energy(photo, wrap=False)
    return PixelFidelity(colour_p90=float(np.percentile(de, COLOUR_PERCENTILE)), colour_median=float(np.median(de)),
                         sharpness=gradient_energy(render, wrap=False) / e_photo if e_photo > 0 else float("nan"),
                         structure=luminance_correlation(photo, render), blur_px=sigma)


def structure_ceiling(photo: np.ndarray, cell_px: int, repeat: tuple[int, int],
                      first: tuple[int, int] = (0, 0)) -> float:
    """The highest structure (:func:`luminance_correlation`) that any render repeating every
    ``repeat`` = (n_e, n_a) cells can reach against ``photo`` ((Y·c, X·c, 3) linear, whole cells
    of ``cell_px``, its first cell the repeat's cell ``first``): √(1 − irregular / total), the
    share of the photo's luminance variance that repeats with it — the best such render is the
    photo's mean over its repeats. Over the cells seen at least twice; the irregular variance
    from the deviations from those means (:func:`weavecap.estimate.cells.repeat_deviation`,
    unbiased), so a photo of pure noise scores about 0 however few its repeats. NaN where no
    cell is seen twice or the photo is flat."""
    from ..estimate.cells import repeat_deviation

    lum = luminance(photo)
    deviation, seen = repeat_deviation(lum, cell_px, repeat, first)
    if not seen.any():
        return float("nan")
    total = float(np.var(lum[:seen.shape[0], :seen.shape[1]][seen]))
    if total <= 0:
        return float("nan")
    return float(np.sqrt(max(0.0, 1.0 - float(np.mean(deviation[seen] ** 2)) / total)))


def luminance_correlation(a: np.ndarray, b: np.ndarray) -> float:
    """Pearson's correlation of the luminances of two (H, W, 3) linear images (NaN when
    either is flat)."""
    ya, yb = luminance(a).ravel(), luminance(b).ravel()
    sa, sb = ya.std(), yb.std()
    return float(np.mean((ya - ya.mean()) * (yb - yb.mean())) / (sa * sb)) if sa > 0 and sb > 0 else float("nan")


def luminance(image: np.ndarray) -> np.ndarray:
    """(H, W) linear luminance of a (H, W, 3) linear RGB image."""
    return np.asarray(image, np.float64)[..., :3] @ LUMA


def gradient_energy(image: np.ndarray, *, wrap: bool = True) -> float:
    """Mean squared gradient (per pixel², forward differences, wrapping around a repeat unless
    ``wrap`` is False) of the luminance."""
    y = luminance(image)
    if not wrap:
        return float(np.mean(np.diff(y, axis=0)[:, :-1] ** 2 + np.diff(y, axis=1)[:-1] ** 2))
    return float(np.mean((np.roll(y, -1, 0) - y) ** 2 + (np.roll(y, -1, 1) - y) ** 2))


def family_masks(pattern: np.ndarray, shape: tuple[int, int], *, centre_share: float = 0.5) -> dict:
    """Boolean (H, W) masks of the centres of the cells where the warp (pattern 0) and the weft
    (pattern 1) is on top, for a canvas of ``shape`` holding one repeat of ``pattern``."""
    p = np.asarray(pattern)
    n_e, n_a = p.shape
    h, w = shape
    yy = (np.arange(h) + 0.5) / h * n_e
    xx = (np.arange(w) + 0.5) / w * n_a
    cy, cx = np.floor(yy).astype(int), np.floor(xx).astype(int)
    lo, hi = 0.5 - centre_share / 2, 0.5 + centre_share / 2
    in_y = ((yy - cy) >= lo) & ((yy - cy) < hi)
    in_x = ((xx - cx) >= lo) & ((xx - cx) < hi)
    centre = in_y[:, None] & in_x[None, :]
    state = p[cy[:, None], cx[None, :]]
    return {"warp": centre & (state == 0), "weft": centre & (state == 1)}


def mean_lab(image: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """CIELAB (D65) of the mean linear RGB of ``image`` over ``mask``; NaN where it is empty."""
    from ..estimate.colour import linear_to_lab

    if not np.any(mask):
        return np.full(3, np.nan)
    return linear_to_lab(np.clip(np.asarray(image, np.float64)[mask][:, :3].mean(axis=0), 0.0, 1.0))


def rendered_family_lab(fabric, *, rig: str = "both", cell_px: int = 24, spp: int = 4) -> dict[str, np.ndarray]:
    """Each yarn family's colour as ``fabric`` renders under a fixed light: CIELAB of the mean
    linear colour at the centres of the cells the family tops (as :func:`fidelity` reads
    them), one repeat rendered head-on under the ``rig`` light at unit gain. What a capture's
    colours look like, whatever photo they came from: a body reflection alone can trade with
    the subsurface colour, which the photo does not tell apart (report.json's standard errors).
    Returns {"warp": (3,), "weft": (3,)} (NaN for a family the pattern never shows)."""
    from ..model.render import render_numpy
    from ..model.scene import View, build_scene, light_rig

    size = cell_px * max(fabric.pattern.shape)
    image = render_numpy(build_scene(fabric, View(tiles=(1, 1), size=size, spp=spp), light=light_rig(rig)))
    masks = family_masks(fabric.pattern, image.shape[:2])
    return {family: mean_lab(image, mask) for family, mask in masks.items()}


def at_equal_lightness(photo_lab, capture_lab) -> float:
    """CIEDE2000 between two CIELAB colours with the second's luminance set to the first's (in
    linear XYZ): their hue and chroma alone, whatever the exposure. NaN where either is not finite."""
    from skimage.color import deltaE_ciede2000, lab2xyz, xyz2lab

    a, b = np.asarray(photo_lab, np.float64), np.asarray(capture_lab, np.float64)
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        return float("nan")
    xa, xb = lab2xyz(a[None, None]), lab2xyz(b[None, None])
    xb = xb * (xa[..., 1].item() / max(xb[..., 1].item(), 1e-12))
    return float(deltaE_ciede2000(a, xyz2lab(xb)[0, 0]))


def neutral_light_delta_e(fabric, lab: dict) -> dict[str, float]:
    """Per yarn family, how far the captured ``fabric``'s colour under a neutral light
    (:func:`rendered_family_lab`: what a render of it shows) is from the photo's
    (``lab[family]["photo"]``, :attr:`Fidelity.lab`), at equal lightness
    (:func:`at_equal_lightness`). The fit never sees this figure: it fits the photo under the
    fitted light, whose gain may carry a colour (a white balance), and a colour the light took
    is one the fabric lacks — 35 of the real-photo bench's 141 captures were 16 ΔE off in the
    median where the gaps of a front-lit photo coloured the light. NaN for a family not shown."""
    capture = rendered_family_lab(fabric)
    return {fam: at_equal_lightness(lab[fam]["photo"], capture[fam]) if fam in lab else float("nan")
            for fam in ("warp", "weft")}


def with_noise(fabric, *, rig: str, repeats: int = 4, size: int = 256, seed: int = 0) -> dict[str, float]:
    """What the §6.3 noise does to a render of the captured ``fabric``: ``repeats`` × ``repeats``
    repeats, ``size`` pixels a side, under ``rig``, with its noise (as ``synth`` and ``render``
    show it by default, :func:`weavecap.noise.add_noise`) against without. ``brightness``: the
    mean's ratio (a noise that clips at black brightens); ``weave``: the correlation of the two
    luminance images (1: no grain; near 0: the weave lost in it). Empty without noise."""
    from ..model.render import render_numpy
    from ..model.scene import View, build_scene, light_rig
    from ..noise import add_noise

    if not fabric.noise or not fabric.noise.get("gaussians"):
        return {}
    clean = render_numpy(build_scene(fabric, View(tiles=(repeats, repeats), size=size, spp=4), light=light_rig(rig)))
    noisy = add_noise(clean, fabric.noise, pitch_px=size / (repeats * max(fabric.shape)), seed=seed)
    return {"brightness": float(noisy.mean() / max(float(clean.mean()), 1e-12)),
            "weave": luminance_correlation(clean, noisy)}


def fidelity(photo: np.ndarray, render: np.ndarray, pattern: np.ndarray, *, centre_share: float = 0.5,
             shot: np.ndarray | None = None) -> Fidelity:
    """The fidelity figures of ``render`` against ``photo``.

    Parameters
    ----------
    photo, render : (n_e*c, n_a*c, 3) linear RGB canvases of one repeat (the fit's target and
        its render as photographed: clipped at the photo's white level, blurred by its blur).
    pattern : (n_e, n_a) the fitted pattern, 1 = weft over warp: which family each cell shows.
    centre_share : the middle share of each cell side whose colour counts.
    shot : one repeat of the photo as shot on the same canvas (default ``photo``), whose pixels
        at the camera's white (:func:`weavecap.model.render.white_level`) count as clipped.
    """
    from skimage.color import deltaE_ciede2000

    from ..model.render import white_level
    from ..photo import CLIPPED_SHARE

    photo = np.asarray(photo, np.float64)
    render = np.asarray(render, np.float64)
    if photo.shape != render.shape:
        raise ValueError(f"photo {photo.shape} and render {render.shape} differ in shape")
    e_photo = gradient_energy(photo)
    sharp = gradient_energy(render) / e_photo if e_photo > 0 else float("nan")
    masks = family_masks(pattern, photo.shape[:2], centre_share=centre_share)
    shot = photo if shot is None else np.asarray(shot, np.float64)
    at_white = np.any(shot >= CLIPPED_SHARE * white_level(shot), axis=-1)
    lab, de, clipped = {}, {}, {}
    for fam, mask in masks.items():
        clipped[fam] = float(at_white[mask].mean()) if mask.any() else float("nan")
        a, b = mean_lab(photo, mask), mean_lab(render, mask)
        lab[fam] = {"photo": a, "render": b}
        de[fam] = float(deltaE_ciede2000(a, b)) if np.all(np.isfinite(a)) and np.all(np.isfinite(b)) else float("nan")
    return Fidelity(sharpness=float(sharp), delta_e=de, structure=luminance_correlation(photo, render), lab=lab,
                    clipped=clipped)


#: a capture whose render keeps less than this share of its photo's gradient energy is blown
#: out or black (the bench's back-lit twill 0.85 stop over, its decided twill 2/1 held: 0.0,
#: every colour at L* 100; the same decision as a start: 1.16)
LOST_SHARPNESS = 0.5
#: what :func:`more_faithful` lets a capture give up for its colours: sharpness, as
#: ``|log(sharpness)|`` (0.05: about 5% further from the photo's), and structure correlation
#: (by which a render made faithful must also raise it)
SHARPNESS_SLACK = 0.05
STRUCTURE_SLACK = 0.02
#: the worst family's colour difference must fall by at least this (ΔE2000) to count
DELTA_E_GAIN = 1.0


def faithful_figures(sharpness: float, delta_e: dict, *, min_sharpness: float, max_delta_e: float) -> bool:
    """Whether a render with these figures looks like its photo: at least ``min_sharpness`` of
    its gradient energy, each family's colour within ``max_delta_e`` (CIEDE2000; a family the
    pattern never shows, None or NaN, is not judged)."""
    colours = [v for v in delta_e.values() if v is not None and np.isfinite(v)]
    return (sharpness or 0.0) >= min_sharpness and all(v <= max_delta_e for v in colours)


def more_faithful(now: Fidelity, was: Fidelity, *, min_sharpness: float, max_delta_e: float) -> bool:
    """Whether ``now`` looks more like the photo than ``was``, its structure no worse beyond
    :data:`STRUCTURE_SLACK`: either the worse family's colour is closer by at least
    :data:`DELTA_E_GAIN` while the sharpness is no further from the photo's beyond
    :data:`SHARPNESS_SLACK`, or ``now`` is faithful (:func:`faithful_figures` with
    ``min_sharpness`` and ``max_delta_e``) where ``was`` is not and its structure correlation
    is higher by at least :data:`STRUCTURE_SLACK`, at any sharpness (the real satin W108's
    colour match: ΔE 10.9 to 0.03, structure 0.20 to 0.32, sharpness 1.02 to 1.35). The
    structure guards that path: colours matched on cells a whole cell off the photo's yarns
    read as faithful by ΔE (the family masks follow the fitted pattern), but the structure does
    not rise (the independent twill 3/1 03: ΔE 13.3 to 2.9, structure 0.46 to 0.45, its floats
    the risers' colour). A capture's loss can rise while it looks more like the photo (the MSE
    trades the yarns' colour for their edges and gaps)."""
    def worst(f: Fidelity) -> float:
        shown = [v for v in f.delta_e.values() if np.isfinite(v)]
        return max(shown) if shown else float("nan")

    def off(f: Fidelity) -> float:  # how far the sharpness is from the photo's
        return abs(math.log(f.sharpness)) if f.sharpness > 0 and np.isfinite(f.sharpness) else math.inf

    def within(f: Fidelity) -> bool:
        return faithful_figures(f.sharpness, f.delta_e, min_sharpness=min_sharpness, max_delta_e=max_delta_e)

    if not (np.isfinite(worst(now)) and np.isfinite(worst(was))) or now.structure < was.structure - STRUCTURE_SLACK:
        return False
    made_faithful = within(now) and not within(was) and now.structure >= was.structure + STRUCTURE_SLACK
    return made_faithful or (worst(now) <= worst(was) - DELTA_E_GAIN and off(now) <= off(was) + SHARPNESS_SLACK)


def captioned(image: np.ndarray, text: str, *, height: int = 22) -> np.ndarray:
    """``image`` (H, W, 3) linear RGB with a white strip below it holding ``text`` in black
    (for compare.png); the text is scaled to fit the width."""
    import cv2

    from ..photo import srgb_to_linear

    h, w = image.shape[:2]
    strip = np.full((height, w, 3), 255, np.uint8)
    font, thick = cv2.FONT_HERSHEY_SIMPLEX, 1
    (tw, th), _ = cv2.getTextSize(text, font, 1.0, thick)
    scale = min(0.5, 0.95 * w / max(tw, 1), 0.7 * height / max(th, 1))
    cv2.putText(strip, text, (4, int(height * 0.72)), font, scale, (0, 0, 0), thick, cv2.LINE_AA)
    return np.concatenate([np.asarray(image, np.float32), srgb_to_linear(strip.astype(np.float32) / 255.0)], axis=0)
