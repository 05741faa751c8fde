"""Photo preparation (Wu et al. 2025 §4) as one call: :func:`prepare_photo`.

rectify (§4.1) → flatten the lighting → Gaussian (σ = pitch/16) → integral projections give
the yarn pitch along each axis (§4.4) → the DMF of the yarn-grid cells gives the minimum
repeat as a whole number of yarns, the superposed pixel DMFs its size in pixels (§4.3) →
kernel PCA over the repeats (§4.2) → yarn boundaries of the regularized image (§4.4). The
order differs from the paper's list only in that the repeat is found before kernel PCA, whose
patches are repeats. Where the projections' pitch is several times the coarse period that
chose the working resolution (a harmonic of thin yarns with sharp gaps), the photo is
rectified again from that pitch. Where floats hide one family's yarn boundaries (a satin's
flat projection along the floats), that axis's pitch comes from the lattice of spectral peaks
(:func:`~weavecap.prepare.grid.lattice_pitch`) and must be confirmed by a repeat. Where the
photo holds the repeat only once along an axis, the same lattice counts its yarns
(:func:`_lattice_repeats`); a 2-yarn repeat that may be a grey 2/2 twill's half is widened to 4
(:func:`~weavecap.prepare.period.complement_repeats`).

A photo that is not a resolvable woven fabric is not fitted to noise: the result is then a
:class:`Rejected` value with a reason a person can act on.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from typing import Callable

import cv2
import numpy as np

from ..errors import ParamsError
from .config import PrepareConfig
from .grid import (AxisGrid, Grid, axis_pitch, boundaries, cell_features, crossing_pitches, folded_strength, lattice_pitch,
                   lattice_yarns, power_spectrum, projection, refine_pitch, refine_repeat, repeat_along, spectrum_peaks)
from .colours import ColourRepeat, colour_repeat
from .diagnosis import diagnosis_image
from .illumination import colour_blind, colour_normalised, flatten_illumination, luminance
from .lattice import Lattice, weave_lattice
from .period import cell_repeat, complement_repeats, orientation_features, superposed_dmf
from .rectify import Rectification, rectify
from .regularize import Regularized, gaussian, regularize


@dataclass(frozen=True)
class Rejected:
    """A photo that is not a resolvable woven fabric.

    Attributes
    ----------
    reason : one sentence for a person: what was found and what to do.
    code : a short machine-readable kind: ``uniform``, ``no_texture``, ``too_fine``,
        ``no_grid``, ``few_yarns``.
    details : the measurements behind the decision.
    evidence : what the grid search saw before it gave up, for :meth:`diagnosis`: any of
        ``rectified`` (the turned photo), ``profiles`` (the two projections), ``pitches`` and
        ``strengths`` (per axis, rectified px).
    """

    reason: str
    code: str
    details: dict = field(default_factory=dict)
    evidence: dict = field(default_factory=dict, repr=False, compare=False)

    def to_json(self) -> dict:
        return {"status": "rejected", "reason": self.reason, "code": self.code, "checks": _plain(self.details)}

    def diagnosis(self, rgb: np.ndarray) -> np.ndarray:
        """The picture of what the grid search saw and why it gave up (``diagnosis.png``,
        linear RGB): :func:`~weavecap.prepare.diagnosis.diagnosis_image` of the photo ``rgb``."""
        return diagnosis_image(rgb, self.reason, self.evidence)


@dataclass(frozen=True)
class Prepared:
    """A prepared photo: rectification, regularized repeats, yarn grid and colour repeat.

    Three periods are kept apart (Wu et al. 2025 §4.3–4.4):

    - the **yarn pitch** ``grid.pitch_px`` = (warp pitch along x, weft pitch along y),
      rectified px: one yarn, as a yarn counts (a plied yarn is one; two yarns that work as a
      pair count as one unless the holes between them show, :func:`lattice_checked`);
    - the **weave repeat** ``grid.yarns`` = (wefts, warps) and ``grid.repeat_px`` =
      (height, width): the fewest yarns after which the interlacing repeats (the cell DMF);
    - the **colour repeat** ``colour_repeat.yarns`` = (wefts, warps): the fewest yarns after
      which the yarns' colours repeat (a stripe's or check's), with one colour per yarn
      (:class:`~weavecap.prepare.colours.ColourRepeat`).

    Attributes
    ----------
    rectification : :class:`~weavecap.prepare.rectify.Rectification` (``image`` is the
        rectified photo, linear RGB; warps run along y).
    regularized : :class:`~weavecap.prepare.regularize.Regularized`.
    grid : :class:`~weavecap.prepare.grid.Grid` in rectified pixels (pitch, yarn boundaries,
        weave repeat and its origin).
    checks : the measurements the rejection tests looked at (``lattice``: the
        autocorrelation's lattice and cell, ``pitch_from``: which measurement gave each pitch).
    timings_s : seconds per stage and ``total``.
    colour_repeat : the colour repeat on the grid (None only for a value built by hand).
    """

    rectification: Rectification
    regularized: Regularized
    grid: Grid
    checks: dict
    timings_s: dict
    colour_repeat: ColourRepeat | None = None

    def to_json(self) -> dict:
        """``rectification`` and ``grid`` as in report.schema.json (``grid.colour_repeat``: the
        colour repeat), plus regularization/checks."""
        r = self.rectification
        h, w = r.image.shape[:2]
        return {
            "status": "ok",
            "rectification": {
                "rotation_deg": round(r.rotation_deg, 4),
                "homography": [[float(v) for v in row] for row in r.homography],
                "size_px": [int(h), int(w)],
                "scale": round(r.scale, 6),
                "perspective": round(r.perspective, 5),
                "skew_deg": round(r.skew_deg, 3),
                "coarse_pitch_px": round(r.coarse_pitch_px, 3),
            },
            "grid": {**self.grid.to_json(),
                     "colour_repeat": None if self.colour_repeat is None else self.colour_repeat.to_json()},
            "regularization": self.regularized.to_json(),
            "checks": _plain(self.checks),
            "timings_s": {k: round(v, 4) for k, v in self.timings_s.items()},
        }

    def exposed(self, exposure: float) -> "Prepared":
        """This photo as if taken at ``exposure`` times less light: the rectified and the
        regularized images and the colour repeat's colours divided by it, the geometry unchanged."""
        def scaled(image: np.ndarray) -> np.ndarray:
            return (np.asarray(image, np.float32) / np.float32(exposure)).astype(np.float32)

        cr = self.colour_repeat
        return replace(self, rectification=replace(self.rectification, image=scaled(self.rectification.image)),
                       regularized=replace(self.regularized, image=scaled(self.regularized.image)),
                       colour_repeat=None if cr is None else replace(cr, weft_colours=cr.weft_colours / exposure,
                                                                     warp_colours=cr.warp_colours / exposure))

    def grid_overlay(self, *, min_side: int = 512) -> np.ndarray:
        """The rectified photo with the yarn grid drawn over it (linear RGB, for grid.png).

        Yarn boundaries are thin cyan lines; one minimum repeat is outlined in magenta and the
        regularized box in yellow. Small images are enlarged (nearest neighbour, at most 4×)
        so that the lines stay legible.
        """
        return draw_grid(self.rectification.image, self.grid, self.regularized.box, min_side=min_side)


def _plain(d):
    """JSON-ready copy: numpy scalars to Python, floats rounded."""
    if isinstance(d, dict):
        return {k: _plain(v) for k, v in d.items()}
    if isinstance(d, (list, tuple)):
        return [_plain(v) for v in d]
    if isinstance(d, (bool, np.bool_)):
        return bool(d)
    if isinstance(d, (int, np.integer)):
        return int(d)
    if isinstance(d, (float, np.floating)):
        return round(float(d), 5) if np.isfinite(d) else None
    return d


def draw_grid(image: np.ndarray, grid: Grid, box=None, *, min_side: int = 512) -> np.ndarray:
    """Draw ``grid`` over a rectified linear RGB image; see :meth:`Prepared.grid_overlay`."""
    h, w = image.shape[:2]
    k = int(np.clip(np.ceil(min_side / max(1, min(h, w))), 1, 4))
    img = image.astype(np.float32)
    if k > 1:
        img = cv2.resize(img, (w * k, h * k), interpolation=cv2.INTER_NEAREST)
    top = float(np.percentile(img, 99)) or 1.0
    img = np.clip(img / top, 0, 1) * 0.85  # expose the photo so that the lines show

    def line_v(x, colour, width=1):
        xi = int(round((x + 0.5) * k - 0.5))
        if 0 <= xi < img.shape[1]:
            img[:, max(0, xi - width // 2): xi + (width + 1) // 2] = colour

    def line_h(y, colour, width=1):
        yi = int(round((y + 0.5) * k - 0.5))
        if 0 <= yi < img.shape[0]:
            img[max(0, yi - width // 2): yi + (width + 1) // 2, :] = colour

    cyan, magenta, yellow = (0.0, 0.8, 0.8), (0.9, 0.0, 0.9), (0.9, 0.8, 0.0)
    for x in grid.x.bounds_px:
        line_v(x, cyan)
    for y in grid.y.bounds_px:
        line_h(y, cyan)
    if box is not None:
        y0, x0, y1, x1 = box
        pts = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], float)
        cv2.polylines(img, [np.round((pts + 0.5) * k - 0.5).astype(np.int32)], True, yellow, 1)
    ys, xs = grid.cells()
    oy, ox = ys[0], xs[0]
    pts = np.array([[xs[0], ys[0]], [xs[-1], ys[0]], [xs[-1], ys[-1]], [xs[0], ys[-1]]], float)
    cv2.polylines(img, [np.round((pts + 0.5) * k - 0.5).astype(np.int32)], True, magenta, max(1, k))
    del oy, ox
    return img


def _dedupe(b: np.ndarray, gap: float) -> np.ndarray:
    """Drop boundaries closer than ``gap`` to the one kept before them (ascending input)."""
    keep: list[float] = []
    for v in b:
        if not keep or v - keep[-1] >= gap:
            keep.append(float(v))
    return np.asarray(keep)


def _lattice_pitches(smooth: np.ndarray, pitches: list, strengths: list,
                     config: PrepareConfig) -> list[float | None]:
    """Per axis (x, y), the yarn pitch the spectral lattice gives when only the other axis's
    projection is periodic (:func:`~weavecap.prepare.grid.lattice_pitch`, §4.3–4.4); else None.

    The lattice scales with the other axis's pitch, so that one must be well measured
    (strength at least ``lattice_min_known_strength``).
    """
    weak = [s < config.min_grid_strength for s in strengths]
    if weak[0] == weak[1] or max(strengths) < config.lattice_min_known_strength:
        return [None, None]
    peaks, tol = _spectral_lattice(smooth, config)
    out: list[float | None] = [None, None]
    i = 0 if weak[0] else 1
    out[i], _ = lattice_pitch(peaks, known_pitch=pitches[1 - i], axis=i, max_yarns=config.lattice_max_yarns,
                              tol=tol, min_share=config.lattice_min_share)
    return out


def _spectral_lattice(smooth: np.ndarray, config: PrepareConfig) -> tuple[np.ndarray, float]:
    """The spectral peaks of the smoothed rectified image's centre crop (at most
    ``lattice_max_px``) and the distance (cycles/px) within which a peak lies on a lattice line
    (:func:`~weavecap.prepare.grid.spectrum_peaks`)."""
    n = min(smooth.shape[0], smooth.shape[1], config.lattice_max_px)
    return spectrum_peaks(smooth, max_side=config.lattice_max_px), 0.75 / n


def _lattice_repeats(smooth: np.ndarray, pitches: tuple[float, float], lengths: tuple[int, int],
                     dmf_yarns: list[int | None], config: PrepareConfig) -> list[int | None]:
    """Per axis (y: wefts, then x: warps), the repeat in yarns that the lattice of interlacings
    gives where the DMFs show none because the photo cannot hold it twice; else None (§4.3).

    A DMF dips only at a shift the photo shows twice; the spectral lattice of the interlacings
    (:func:`~weavecap.prepare.grid.lattice_yarns`) needs only about one repeat, its basis being
    the short steps between neighbouring interlacings. A microscope close-up of a 7-end satin
    of wide warps holds 12 warps: a repeat that shows once. The lattice is believed only where
    it gives, along the other axis, the repeat that the DMF found there (the same lattice
    describes both axes of one weave), and only for a repeat longer than half the photo (a
    shorter one the DMF would have seen).

    Parameters
    ----------
    smooth : the smoothed grey rectified image (:func:`_projections`).
    pitches : (weft pitch along y, warp pitch along x), rectified px; lengths : (height, width).
    dmf_yarns : the DMFs' repeat per axis (None: none shown).
    """
    if all(n is None for n in dmf_yarns) or all(n is not None for n in dmf_yarns):
        return [None, None]
    peaks, tol = _spectral_lattice(smooth, config)
    out: list[int | None] = [None, None]
    for i in (0, 1):  # i = 0: along y (spectral axis 1), i = 1: along x (spectral axis 0)
        j = 1 - i
        if dmf_yarns[i] is not None:
            continue
        kw = dict(max_yarns=config.lattice_max_yarns, tol=tol, min_share=config.lattice_min_share)
        # the spectrum's axis 0 is x: this axis is spectral axis 1 - i, the other one i
        other = lattice_yarns(peaks, pitch=pitches[j], axis=i, **kw)
        n = lattice_yarns(peaks, pitch=pitches[i], axis=1 - i, **kw)
        if other == dmf_yarns[j] and n is not None and n >= 2 and n * pitches[i] > lengths[i] / 2:
            out[i] = n
    return out


def _light_sigma(pitch_px: float, config: PrepareConfig) -> float:
    """σ (rectified px) of the low-pass that estimates the lighting of the rectified photo."""
    return config.illumination_sigma_pitches * max(pitch_px, 2.0) * 2


def _projections(rect: Rectification, config: PrepareConfig) -> tuple[np.ndarray, list, list, list, list, tuple, dict]:
    """Flatten the lighting of the rectified photo, smooth it (σ = pitch/16, §4.2) and measure
    the yarn pitch of its integral projections along x and y (§4.4).

    Where the lattice of yarn crossings shows the projections' period to be a whole number of
    yarns (:func:`~weavecap.prepare.grid.crossing_pitches`: a basket's pairs, a random weave's
    columns of floats), the pitch is divided; the periodicity stays that of the projection's
    own period, which is what shows a regular grid.

    Returns
    -------
    (smooth, pitches, strengths, contrasts, profiles, split, notes): the smoothed grey image and, per
    axis (x: warps, then y: wefts), the pitch (px, None when no period), the periodicity of the
    projection at its period (:func:`~weavecap.prepare.grid.folded_strength`), its share of the
    image's structure, and the projection itself; then ((dx, dy), ratio, share), the divisors
    taken, the crossing power the best ones gained and its share of the strongest peak.
    """
    r_img = rect.image
    rh_, rw_ = r_img.shape[:2]
    p_guess = rect.coarse_pitch_px * rect.scale
    if config.colour_blind:
        r_flat = colour_blind(r_img, sigma_px=config.colour_sigma_pitches * p_guess)
    else:
        r_flat, _ = flatten_illumination(luminance(r_img), sigma_px=_light_sigma(p_guess, config))
        r_flat = r_flat / max(float(r_flat.mean()), 1e-12)
    smooth = gaussian(r_flat, config.gaussian_sigma_pitch * p_guess)
    sd_img = float(smooth.std()) or 1.0
    pitches, strengths, contrasts, profiles = [], [], [], []
    for axis, length in ((0, rw_), (1, rh_)):  # axis 0: column means → warps along x
        prof = projection(smooth, axis=axis)
        per, s = axis_pitch(prof, min_period=2.0, max_period=max(2.5, length / config.min_yarns_in_photo),
                            octave_gain=config.grid_octave_gain)
        if per is not None:
            per = refine_pitch(prof, per)
            s = folded_strength(prof, per)
        pitches.append(per)
        strengths.append(s)
        contrasts.append(float(prof.std()) / sd_img)
        profiles.append(prof)
    # the lattice's window and tolerance scale with the yarns the projections found (the
    # coarse period can be a harmonic of them)
    found = [p for p in pitches if p is not None]
    lattice = weave_lattice(r_img, float(np.sqrt(np.prod(found))) if len(found) == 2 else p_guess, min_unit_px=max(config.crossing_min_pitch_px, config.min_pitch_px * rect.scale),
                            max_side=config.lattice_max_px, max_multiple=config.lattice_max_multiple)
    pitches, from_lattice = lattice_checked(pitches, strengths, lattice, config)
    split = ((1, 1), 1.0, 0.0)
    if None not in pitches:  # a projection that repeats over several yarns (grid.crossing_pitches)
        split = crossing_pitches(power_spectrum(smooth, max_side=config.lattice_max_px), (pitches[0], pitches[1]),
                                 divisors=config.crossing_divisors, gain=config.crossing_gain,
                                 min_share=config.crossing_min_share,
                                 min_pitch=max(config.crossing_min_pitch_px, config.min_pitch_px * rect.scale))
        pitches = [p / d for p, d in zip(pitches, split[0])]
    notes = {"pitch_from": from_lattice, "lattice": lattice}
    return smooth, pitches, strengths, contrasts, profiles, split, notes


def lattice_checked(pitches: list, strengths: list, lattice: Lattice | None,
                    config: PrepareConfig) -> tuple[list, list[str]]:
    """The projections' pitches checked against the weave's lattice (:mod:`.lattice`), per axis.

    Only an oblique lattice (:attr:`~weavecap.prepare.lattice.Lattice.oblique`: the photo
    matches itself a yarn across and a yarn along) that shows a woven grid (score ≥
    ``lattice_woven_score``) is used.

    - a projection that repeats over two cells of the lattice (alternate yarns of two colours,
      a colour-and-weave effect, the octave rule's doubling of a yarn with a dark centre) is
      halved: the two then agree on the yarns (three or more cells were, on the DEV photos,
      a lattice cell too fine, not a projection too coarse);
    - where the lattice fits well (score ≥ ``lattice_min_score``), a projection that repeats
      over a whole fraction of a cell takes the cell (a half-yarn harmonic; grouped yarns are
      then one unless the yarn crossings split them: :func:`~weavecap.prepare.grid.crossing_pitches`).

    An axis without a periodic projection is left to the spectral lattice
    (:func:`_lattice_pitches`).

    Returns
    -------
    (pitches, sources): per axis ``projection``, ``projection/2`` or ``lattice``.
    """
    out, sources = list(pitches), ["projection", "projection"]
    if lattice is None or lattice.score < config.lattice_woven_score or not lattice.oblique:
        return out, sources
    for i, (p, s, g) in enumerate(zip(pitches, strengths, lattice.cell)):
        if g is None or p is None or s < config.min_grid_strength:
            continue
        k = p / g
        if round(k) == 2 and abs(k - 2) <= 0.2:
            out[i], sources[i] = p / 2, "projection/2"
        elif (lattice.score >= config.lattice_min_score and round(1 / k) >= 2
              and abs(1 / k - round(1 / k)) <= 0.1 * round(1 / k)):
            out[i], sources[i] = g, "lattice"
    return out, sources


def _on_cells(pitch: float | None, cell: float | None) -> bool:
    """Whether ``pitch`` is a whole number of lattice cells (within a tenth of a cell each)."""
    if pitch is None or cell is None:
        return False
    k = round(pitch / cell)
    return k >= 1 and abs(pitch / cell - k) <= 0.1 * k


def no_grid_reason(pitches: list, strengths: list, periodic: list[bool], lattice: Lattice | None,
                   config: PrepareConfig) -> str:
    """The sentence of a ``no_grid`` rejection: which test of a woven grid failed, with its
    measure and its bound, and what to do.

    A grid is woven when the projections across the warps and across the wefts (x, y) are both
    periodic, or one is and the autocorrelation's lattice fits the photo (score at least
    ``lattice_woven_score``) and has cells the other axis's period is a whole number of.
    ``pitches``, ``strengths``, ``periodic``: per axis, the projection's period (px, None where
    it has none), its periodicity and whether it counts as periodic."""
    axes = ("across the warps", "across the wefts")
    flat = [a for a, ok in zip(axes, periodic) if not ok]
    weakest = min((s for s, ok in zip(strengths, periodic) if not ok), default=min(strengths))
    head = (f"no regular yarn grid: the yarn spacing is not periodic {' nor '.join(flat) or axes[0]} "
            f"(periodicity {weakest:.2f}, at least {config.min_grid_strength} needed)")
    if not any(periodic):
        why = ""
    elif lattice is None:
        why = ", and the photo matches itself at no lattice of shifts that could place those yarns"
    elif lattice.score < config.lattice_woven_score:
        why = (f", and the lattice the photo best matches itself at fits only {lattice.score:.3f} "
               f"(at least {config.lattice_woven_score} needed)")
    else:
        i = 0 if not periodic[0] else 1
        cell = lattice.cell[i]
        period = "no period" if pitches[i] is None else f"a period of {pitches[i]:.1f} px"
        on = "it has no cell along that axis" if cell is None else f"its cell there is {cell:.1f} px"
        why = (f", and the photo's lattice (fit {lattice.score:.3f}) does not place them: the projection "
               f"{axes[i]} has {period}, {on}")
    return (f"{head}{why}: this does not look like a woven fabric (knit, felt, straw, paper, noise?), "
            "or its yarns are not sharp; take a sharper photo, closer")


def _cells(r_img: np.ndarray, pitch_px: tuple[float, float], origin_px: tuple[float, float], p_guess: float,
           config: PrepareConfig) -> np.ndarray:
    """Features of the yarn-grid cells of the rectified photo's centre crop (at most
    ``period_max_px``; lighting flattened, or each channel divided by its own local mean when
    ``config.colour_blind``; Gaussian of §4.2) for the cell DMF of §4.3:
    :func:`~weavecap.prepare.grid.cell_features`."""
    h, w = r_img.shape[:2]
    y0, x0 = (h - min(h, config.period_max_px)) // 2, (w - min(w, config.period_max_px)) // 2
    crop = _central(r_img, config.period_max_px)
    if config.colour_blind:
        flat = colour_normalised(crop, sigma_px=config.colour_sigma_pitches * p_guess)
    else:
        flat, _ = flatten_illumination(crop, sigma_px=_light_sigma(p_guess, config))
    flat = gaussian(flat, config.gaussian_sigma_pitch * p_guess)
    return cell_features(flat, pitch_px, (origin_px[0] - y0, origin_px[1] - x0), sub=config.cell_blocks)


def _central(img: np.ndarray, side: int) -> np.ndarray:
    h, w = img.shape[:2]
    bh, bw = min(h, side), min(w, side)
    y0, x0 = (h - bh) // 2, (w - bw) // 2
    return img[y0:y0 + bh, x0:x0 + bw]


def prepare_photo(rgb: np.ndarray, config: PrepareConfig = PrepareConfig(), *, repeat: tuple[int, int] | None = None,
                  progress: Callable[[str], None] | None = None) -> Prepared | Rejected:
    """Rectify a weave photo, regularize it and find its yarn grid and minimum repeat (§4).

    A photo whose grid was found from one periodic projection and a lattice that does not fit
    well (an oblique lattice of score ``lattice_min_score``), the other projection not
    periodic, is prepared once more colour-blind (``PrepareConfig.colour_blind``): a yarn-dyed
    stripe or check, or a block of another colour, can hide the yarns' periodicity from the
    brightness, not from each channel's texture relative to its own local mean. The
    colour-blind look is kept where its projections are more periodic
    (``checks["colour_blind"]``). A rejected photo is not looked at again: noise, felt or a
    knit seen colour-blind can show a chance period.

    Parameters
    ----------
    rgb : (H, W, 3) or (H, W) float32 linear image (as :func:`weavecap.photo.load_photo`
        gives).
    config : every hyper-parameter (:class:`~weavecap.prepare.config.PrepareConfig`).
    repeat : (wefts, warps) of a repeat known from elsewhere (a given pattern's): used in
        place of the one the photo shows, which ``checks["repeat_in_photo"]`` still records;
        :class:`~weavecap.errors.ParamsError` (field ``pattern``) when the photo cannot hold it,
        or when it shows a repeat (a DMF's dip) that does not divide it.
        A photo shows a repeat's look, not always the pattern: a grey 2/2 twill's complement
        looks alike, and a repeat the photo holds once only shows in its lattice (§4.3; the
        real W127 and D16, docs/preparation.md).
    progress : called with the name of each stage as it starts (for a progress display).

    Returns
    -------
    :class:`Prepared`, or :class:`Rejected` with a reason when the photo is not a resolvable
    woven fabric (uniform or noise, no periodic yarn grid, yarns under ``min_pitch_px``, too
    few yarns); its :meth:`Rejected.diagnosis` draws what the grid search saw.
    """
    def strength(p: Prepared) -> float:  # how periodic the weaker projection is
        return min(p.checks["grid_strength"])

    first = _prepare(rgb, config, repeat=repeat, progress=progress)
    if config.colour_blind or isinstance(first, Rejected):
        return first
    lattice = first.checks["lattice"] or {}
    if strength(first) >= config.min_grid_strength or (
            lattice.get("oblique") and lattice.get("score", 0.0) >= config.lattice_min_score):
        return first
    again = _prepare(rgb, replace(config, colour_blind=True), repeat=repeat, progress=progress)
    return again if isinstance(again, Prepared) and strength(again) > strength(first) else first


def _prepare(rgb: np.ndarray, config: PrepareConfig, *, repeat: tuple[int, int] | None,
             progress: Callable[[str], None] | None) -> Prepared | Rejected:
    """:func:`prepare_photo` with one look (``config.colour_blind`` or not)."""
    say = progress or (lambda stage: None)
    t_all = time.perf_counter()
    timings: dict[str, float] = {}
    checks: dict = {"colour_blind": config.colour_blind}
    rgb = np.asarray(rgb, np.float32)
    if rgb.ndim == 2:
        rgb = np.repeat(rgb[..., None], 3, axis=2)

    # --- is there any texture at all? ------------------------------------------------------
    say("checking")
    t = time.perf_counter()
    grey = luminance(rgb)
    small = _central(grey, 1024)
    mean = float(small.mean())
    flat, _ = flatten_illumination(small, sigma_px=max(small.shape) / 16)
    contrast = float(flat.std() / mean) if mean > 0 else 0.0
    checks["contrast"] = contrast
    timings["check"] = time.perf_counter() - t
    if not mean > 0 or contrast < config.min_contrast:
        return Rejected(f"the photo is nearly uniform (contrast {contrast:.3f}, at least {config.min_contrast} "
                        "needed): no yarns to see; take a sharp close-up of the fabric", "uniform", checks)

    # --- §4.1 rectification -----------------------------------------------------------------
    say("rectifying")
    t = time.perf_counter()
    rect = rectify(rgb, config=config)
    timings["rectify"] = time.perf_counter() - t
    if rect is None:
        return Rejected("no texture period was found: this does not look like a woven fabric",
                        "no_texture", checks)
    checks.update(skew_deg=rect.skew_deg, radon_contrast=rect.notes["radon"]["contrast"],
                  perspective=rect.perspective)

    # --- lighting, Gaussian, projections → pitch (§4.4) -------------------------------------
    say("measuring the yarn grid")
    t = time.perf_counter()
    smooth, pitches, strengths, contrasts, profiles, split, notes = _projections(rect, config)
    # the coarse period was a harmonic of the yarns (thin yarns, sharp gaps): the working
    # resolution and the perspective were chosen for yarns that are not there; do it again
    known = [p / rect.scale for p in pitches if p is not None]
    if known and min(known) > config.recoarse_ratio * rect.coarse_pitch_px:
        checks.update(first_coarse_pitch_px=rect.coarse_pitch_px)
        t_again = time.perf_counter()
        rect = rectify(rgb, config=config, pitch_px=min(known)) or rect
        timings["rectify"] += time.perf_counter() - t_again
        checks.update(skew_deg=rect.skew_deg, radon_contrast=rect.notes["radon"]["contrast"],
                      perspective=rect.perspective)
        smooth, pitches, strengths, contrasts, profiles, split, notes = _projections(rect, config)
    r_img = rect.image
    rh_, rw_ = r_img.shape[:2]
    p_guess = rect.coarse_pitch_px * rect.scale
    lattice = notes.pop("lattice")
    checks.update(notes, lattice=None if lattice is None else lattice.to_json())
    checks.update(grid_strength=strengths, grid_contrast=contrasts, pitch_divisors=list(split[0]),
                  crossing_gain=split[1], crossing_share=split[2])
    evidence = {"rectified": r_img, "profiles": profiles, "pitches": tuple(pitches), "strengths": tuple(strengths)}
    # an axis whose projection is flat (floats hide its yarn boundaries) takes its pitch from the
    # lattice of interlacings built from the other axis (the projection's own where the two
    # agree); the superposed DMFs must then show a repeat at whole numbers of those yarns
    spectral = _lattice_pitches(smooth, pitches, strengths, config) if None not in pitches else [None, None]
    checks.update(lattice_pitch_px=spectral)
    from_lattice = [lp is not None for lp in spectral]
    pitches = [p if lp is None or abs(lp / p - 1) <= config.lattice_pitch_tol else lp
               for p, lp in zip(pitches, spectral)]
    # a woven grid shows as periodic projections along both yarn directions (or one, and the
    # spectral lattice), or as one periodic projection and a lattice the autocorrelation fits,
    # on whose cells the other axis's pitch lies (floats, a check's colours, hairy or plied
    # yarns blur that projection)
    periodic = [s >= config.min_grid_strength or fl for s, fl in zip(strengths, from_lattice)]
    woven_lattice = (any(periodic) and lattice is not None and lattice.score >= config.lattice_woven_score
                     and all(ok or _on_cells(p, c) for ok, p, c in zip(periodic, pitches, lattice.cell)))
    reject = None
    if any(p is None for p in pitches) or not (all(periodic) or woven_lattice):
        reject = Rejected(no_grid_reason(pitches, strengths, periodic, lattice, config), "no_grid", checks, evidence)
    else:
        px, py = pitches
        in_px = (px / rect.scale, py / rect.scale)
        yarns_photo = (rw_ / px, rh_ / py)
        checks.update(pitch_input_px=list(in_px), yarns_in_photo=list(yarns_photo))
        if min(in_px) < config.min_pitch_px:
            reject = Rejected(f"the yarns are only {min(in_px):.1f} px apart in the photo (at least "
                              f"{config.min_pitch_px} px needed to resolve them): take a closer or sharper photo",
                              "too_fine", checks, evidence)
        elif min(yarns_photo) < config.min_yarns_in_photo:
            reject = Rejected(f"the photo shows only {min(yarns_photo):.1f} yarns across (at least "
                              f"{config.min_yarns_in_photo} needed): take the photo from further away",
                              "few_yarns", checks, evidence)
    if reject is not None:
        timings["grid"] = time.perf_counter() - t
        return reject

    # --- §4.3 minimum repeat: DMF of the yarn-grid cells, refined by the pixel DMFs ----------
    say("finding the repeat")
    xb = boundaries(profiles[0], px)
    yb = boundaries(profiles[1], py)
    origin = (float(yb[0]) if len(yb) else 0.0, float(xb[0]) if len(xb) else 0.0)
    cells = _cells(r_img, (px, py), origin, p_guess, config)
    # a colour-blind look (stripes, checks): the cells would repeat with the colours; the weave's
    # repeat is found from what the colours do not set, the direction of each block's edges
    if config.colour_blind:
        cells = orientation_features(cells, sub=config.cell_blocks)
    crop = _central(smooth, config.period_max_px).astype(np.float64)
    ns, dmfs, depths, sources, cell_ns, cell_dmfs = [], [], [], [], [], []
    for axis, pitch in ((0, py), (1, px)):  # axis 0: shifts along y → wefts
        n, depth, cd = cell_repeat(cells, axis=axis, max_yarns=config.max_repeat_yarns, tol=config.cell_tol,
                                   z=config.cell_z, min_depth=config.cell_min_depth)
        cell_ns.append(n)
        cell_dmfs.append(cd)
        # what varies along the shift axis alone (yarn to yarn brightness, the yarn profile)
        # says nothing about the repeat; without it a satin's rare interlacings stand out
        dmf = superposed_dmf(crop - crop.mean(axis=1 - axis, keepdims=True), axis=axis)
        source = "cells"
        if n is None:  # the cells do not follow the yarns: the pixel DMF at whole numbers of yarns
            n, depth = repeat_along(dmf, pitch, max_yarns=config.max_repeat_yarns, rel_tol=config.period_rel_tol,
                                    abs_tol=config.period_abs_tol, min_depth=config.period_min_depth)
            source = "pixels" if n is not None else "none"
        ns.append(n)
        dmfs.append(dmf)
        sources.append(source)
        depths.append(depth)
    # a grey 2/2 twill's complement looks alike: its 2-yarn cell repeat may be 4 (period.py)
    doubled = complement_repeats(cell_ns, cell_dmfs, tol=config.cell_tol)
    ns = [m if c is not None else n for n, c, m in zip(ns, cell_ns, doubled)]
    checks.update(repeat_doubled=[m != c for c, m in zip(cell_ns, doubled)])
    found = [n is not None for n in ns]  # shown by a DMF: what confirms a pitch from the lattice
    lattice_n = _lattice_repeats(smooth, (py, px), (rh_, rw_), ns, config)
    reps = []
    for i, (pitch, length) in enumerate(((py, rh_), (px, rw_))):
        n = ns[i] if ns[i] is not None else lattice_n[i]
        if lattice_n[i] is not None:
            sources[i] = "lattice"
        if n is None:  # a single repeat along this axis: all whole yarns of the photo
            n = int(np.floor(length / pitch))
            reps.append((n, n * pitch))
        else:
            reps.append((n, refine_repeat(dmfs[i], pitch, n)))
    shown = [f or n is not None for f, n in zip(found, lattice_n)]
    if repeat is not None:  # a repeat known from elsewhere: the regularized box must hold it once
        # what the photo shows: a 2-yarn repeat doubled as a grey 2/2 twill's is still 2
        seen = [c if wide else n for (n, _), c, wide in zip(reps, cell_ns, checks["repeat_doubled"])]
        checks.update(repeat_in_photo=seen)
        if any(src in ("cells", "pixels") and n % m for n, m, src in zip(repeat, seen, sources)):
            # the photo repeats over m yarns (a DMF's dip): a repeat of the fabric is a multiple of it
            raise ParamsError(f"the given pattern repeats over {repeat[0]} wefts x {repeat[1]} warps, but the "
                              f"photo's repeat is {seen[0]} wefts x {seen[1]} warps, which does not divide it: "
                              "give the pattern of the photo's repeat or of a multiple of it", field="pattern")
        for i, (n, pitch, size, name) in enumerate(zip(repeat, (py, px), (rh_, rw_), ("wefts", "warps"))):
            length = min(size, config.regularize_max_px)
            if n * pitch > length:
                raise ParamsError(f"the given pattern repeats over {n} {name}, but the photo shows only "
                                  f"{int(length // pitch)} whole {name}: photograph a larger area, or give the "
                                  "pattern of one repeat", field="pattern")
            reps[i] = (n, refine_repeat(dmfs[i], pitch, n))
        sources, shown = ["given", "given"], [True, True]
    checks.update(repeat_from=sources)
    checks.update(repeat_depth=depths)
    (ny, rep_h), (nx, rep_w) = reps
    unconfirmed = [axis for axis, fl, fd in (("x", from_lattice[0], found[1]), ("y", from_lattice[1], found[0]))
                   if fl and not fd]
    if unconfirmed:
        timings["grid"] = time.perf_counter() - t
        return Rejected(f"no regular yarn grid: along {unconfirmed[0]} the yarn boundaries do not show, and the "
                        "repeat that the lattice of interlacings implies is not found in the photo: this does not "
                        "look like a woven fabric, or its yarns are hidden", "no_grid", checks, evidence)
    # the pitch is best known from the repeat, measured over all its multiples
    # (unless the two disagree: then the projection's pitch is kept)
    if shown[0] and abs(rep_h / ny / py - 1) < 0.03:
        py = rep_h / ny
    if shown[1] and abs(rep_w / nx / px - 1) < 0.03:
        px = rep_w / nx
    timings["grid"] = time.perf_counter() - t

    # --- §4.2 regularization over whole repeats ---------------------------------------------
    say("regularizing")
    t = time.perf_counter()
    reg = regularize(r_img, pitch_px=(px, py),
                     repeat_px=(rep_h if shown[0] else None, rep_w if shown[1] else None),
                     origin_px=origin, config=config)
    timings["regularize"] = time.perf_counter() - t
    # boundaries from the regularized image's projections, over its box (the paper's §4.4)
    y0, x0, y1, x1 = reg.box
    rg = luminance(reg.image)
    if rg.shape[0] > 2 * py and rg.shape[1] > 2 * px:
        xb_in = boundaries(projection(rg, axis=0), px, offset=x0)
        yb_in = boundaries(projection(rg, axis=1), py, offset=y0)
        xb = np.concatenate([xb[xb < x0 + 0.25 * px], xb_in, xb[xb > x1 + 0.75 * px]])
        yb = np.concatenate([yb[yb < y0 + 0.25 * py], yb_in, yb[yb > y1 + 0.75 * py]])
        xb, yb = _dedupe(np.sort(xb), px / 3), _dedupe(np.sort(yb), py / 3)
    origin = (float(y0), float(x0)) if reg.method == "kpca" else origin
    grid = Grid(x=AxisGrid(px, strengths[0], contrasts[0], xb), y=AxisGrid(py, strengths[1], contrasts[1], yb),
                repeat_px=(ny * py, nx * px), yarns=(ny, nx), repeat_found=(shown[0], shown[1]), origin_px=origin)
    timings["total"] = time.perf_counter() - t_all
    return Prepared(rect, reg, grid, checks, timings, colour_repeat(r_img, (px, py), origin))
