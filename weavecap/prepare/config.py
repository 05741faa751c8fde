"""Hyper-parameters of photo preparation (Wu et al. 2025 §4), in one place."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class PrepareConfig:
    """Every tunable number of :func:`weavecap.prepare.prepare_photo`.

    Lengths are in pixels unless named otherwise; "pitch" is the distance between the centres
    of neighbouring yarns.
    """

    # --- resolution -------------------------------------------------------------------------
    #: largest side of the centre crop used for the first, coarse pitch estimate (input px)
    coarse_crop_px: int = 768
    #: that estimate is the finest spectral peak reaching this share of the strongest one and
    #: this multiple of the spectrum's median (rectify.coarse_pitch)
    coarse_rel_floor: float = 0.2
    coarse_noise_floor: float = 6.0
    #: yarn pitch of the working image used to find the angle and the perspective
    work_pitch_px: float = 8.0
    #: largest side of that working image (a centre crop beyond it)
    work_max_px: int = 768
    #: yarn pitch the rectified image is resampled to when the photo has more (never upsampled)
    rectified_pitch_px: float = 16.0
    #: largest number of pixels of the rectified image
    rectified_max_pixels: int = 2_500_000

    # --- illumination ------------------------------------------------------------------------
    #: σ of the low-pass that estimates the lighting, in yarn pitches
    illumination_sigma_pitches: float = 4.0
    #: a photo whose grid is not found is prepared again ``colour_blind``: each colour channel
    #: divided by its own low-pass of σ ``colour_sigma_pitches`` texture periods
    #: (illumination.colour_normalised) before the angles, projections and cells, and the
    #: weave's repeat found from the direction of the cells' edges (period.orientation_features):
    #: a yarn-dyed stripe or check, a colour block no longer hides the grid
    colour_blind: bool = False
    colour_sigma_pitches: float = 1.5

    # --- rectification (§4.1) ----------------------------------------------------------------
    #: Radon: pitch and disc diameter of the coarse angle search, and its angle step (degrees)
    radon_coarse_pitch_px: float = 8.0
    radon_coarse_diameter_px: int = 160
    radon_coarse_step_deg: float = 1.0
    #: largest departure from 90° between the two yarn families searched for (degrees)
    radon_pair_skew_deg: float = 4.0
    #: pairs scoring at least this share of the best are equally good; the squarest one wins
    radon_pair_tie: float = 0.85
    #: σ of the Gaussian before the Laplacian of the Radon once the yarn pitch is measured, in
    #: pitches: the filter's gain then peaks at the yarn frequency (1/(π·√2·σ)), not its harmonics
    radon_band_sigma_pitch: float = 0.225
    #: Radon: disc diameter, half-width and step of the fine search around each yarn direction
    radon_fine_diameter_px: int = 320
    radon_fine_halfwidth_deg: float = 1.5
    radon_fine_step_deg: float = 0.25
    #: perspective: tile side in working pitches, number of spectral peaks tracked per tile
    tile_pitches: float = 12.0
    tile_peaks: int = 3
    #: fewest working pitches across a tile (small photos get smaller tiles down to this)
    tile_min_pitches: float = 5.0
    #: perspective: RANSAC iterations, inlier threshold (relative frequency error), minimum tiles
    ransac_iterations: int = 60
    ransac_threshold: float = 0.02
    min_tiles: int = 6
    #: perspective terms smaller than this (relative scale change across the image) are dropped
    min_perspective: float = 0.004
    #: largest perspective accepted (relative scale change across the image); beyond: none
    max_perspective: float = 0.6

    # --- regularization (§4.2) ---------------------------------------------------------------
    #: Gaussian σ as a fraction of the yarn pitch (the paper: 1/16 of the yarn size)
    gaussian_sigma_pitch: float = 1.0 / 16.0
    #: largest side of the box of the rectified image that is regularized (px)
    regularize_max_px: int = 768
    #: kernel PCA: components kept, repeats used to fit (sampled), largest side of one repeat
    #: once resampled (px), fewest whole repeats in the box for kernel PCA to be used
    kpca_components: int = 8
    kpca_max_patches: int = 300
    kpca_max_patch_px: int = 64
    kpca_min_repeats: int = 6
    kpca_seed: int = 0

    # --- period (§4.3) -----------------------------------------------------------------------
    #: largest side of the centre crop whose distance matching functions are superposed
    period_max_px: int = 1024
    #: most yarns in a repeat along one axis
    max_repeat_yarns: int = 48
    #: the repeat is the fewest yarns whose DMF dip d ≤ max(rel·d*, d* + abs), d* the deepest
    period_rel_tol: float = 1.6
    period_abs_tol: float = 0.04
    #: a dip counts as a repeat when 1 - d* reaches this (else: a single repeat in the photo)
    period_min_depth: float = 0.3
    #: the cell DMF (period.cell_repeat): blocks per cell side whose mean colours and gradients
    #: describe a cell
    cell_blocks: int = 3
    #: the repeat is the fewest yarns whose cell DMF d ≤ d* + tol·(d⁺ - d*), d* the lowest and
    #: d⁺ the highest; a repeat shows when 1 - d*/d⁺ reaches min_depth and d⁺ - d* is z
    #: standard errors
    cell_tol: float = 0.1
    cell_z: float = 3.0
    cell_min_depth: float = 0.15

    # --- grid (§4.4) -------------------------------------------------------------------------
    #: when the projections' pitch exceeds the coarse period this many times, the coarse period
    #: was a harmonic of the yarns: rectify again from the projections' pitch
    recoarse_ratio: float = 2.5
    #: the pitch is doubled (or tripled) while that explains this much more of the projection
    grid_octave_gain: float = 0.15
    #: the projections' pitches are divided by these (per axis, grid.crossing_pitches) when the
    #: lattice of yarn crossings is at least crossing_gain times stronger at the divided pitches
    #: and at least crossing_min_share of the spectrum's strongest peak, none finer than
    #: crossing_min_pitch_px (rectified px) or min_pitch_px (input px)
    crossing_divisors: tuple[int, ...] = (2, 3, 4, 6)
    crossing_gain: float = 2.0
    crossing_min_share: float = 0.01
    crossing_min_pitch_px: float = 4.0

    # --- rejection ---------------------------------------------------------------------------
    #: smallest resolvable yarn pitch in input px
    min_pitch_px: float = 3.5
    #: smallest relative contrast of the texture (std / mean of the flattened grey)
    min_contrast: float = 0.02
    #: smallest periodicity of the integral projection at the pitch (see grid.folded_strength):
    #: the share of the projection's variance that one yarn period explains, chance removed
    min_grid_strength: float = 0.2
    #: an axis with a flat projection takes its pitch from the spectral lattice (grid.lattice_pitch,
    #: over a centre crop of at most lattice_max_px, repeats up to lattice_max_yarns), or from the
    #: projection where the two agree within lattice_pitch_tol; a DMF repeat must confirm it
    lattice_pitch_tol: float = 0.03
    #: ... and only when the other axis's projection is at least this periodic; the lattice must
    #: hold this power share of the off-axis spectral peaks
    lattice_min_known_strength: float = 0.4
    lattice_min_share: float = 0.85
    lattice_max_px: int = 512
    #: the autocorrelation's lattice (prepare.lattice): the fit score from which it gives an
    #: axis without a periodic projection its pitch, and overrules a projection finer than its cell
    lattice_min_score: float = 0.8
    #: most yarns a lattice basis vector spans along an axis (a reduced basis of a satin of up
    #: to 8 ends spans at most 3)
    lattice_max_multiple: int = 4
    #: a photo whose projections are not both periodic is still a woven grid when its
    #: autocorrelation fits a lattice this well (prepare.lattice.fit_lattice)
    lattice_woven_score: float = 0.35
    lattice_max_yarns: int = 12
    #: fewest yarns along each axis of the photo
    min_yarns_in_photo: int = 4
