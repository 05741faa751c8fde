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

    # --- rectification (§4.1) ----------------------------------------------------------------
    #: Radon: pitch and disc diameter of the coarse angle search, and its angle step (degrees)
    radon_coarse_pitch_px: float = 8.0
    radon_coarse_diameter_px: int = 160
    radon_coarse_step_deg: float = 1.0
    #: Radon: disc diameter, half-width and step of the fine search around each yarn direction
    radon_fine_diameter_px: int = 320
    radon_fine_halfwidth_deg: float = 1.5
    radon_fine_step_deg: float = 0.25
    #: perspective: tile side in working pitches, number of spectral peaks tracked per tile
    tile_pitches: float = 12.0
    tile_peaks: int = 3
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
    #: kernel PCA: components kept, patches used to fit (sampled), smallest patch side (px)
    kpca_components: int = 8
    kpca_max_patches: int = 300
    kpca_min_patch_px: int = 24
    kpca_max_patch_px: int = 96
    kpca_seed: int = 0

    # --- period (§4.3) -----------------------------------------------------------------------
    #: a dip of the distance matching function counts when it falls below this fraction of its
    #: plateau; the smallest such dip within ``period_tolerance`` of the deepest one wins
    period_min_depth: float = 0.35
    period_tolerance: float = 0.15

    # --- grid (§4.4) -------------------------------------------------------------------------
    #: the yarn pitch is the finest period of the integral projection that still explains this
    #: fraction of the structure its repeat explains
    grid_explained: float = 0.55

    # --- rejection ---------------------------------------------------------------------------
    #: smallest resolvable yarn pitch in input px
    min_pitch_px: float = 3.0
    #: smallest relative contrast of the texture (std / mean of the flattened grey)
    min_contrast: float = 0.02
    #: smallest periodicity (1 - DMF at the repeat / DMF plateau) on each axis
    min_periodicity: float = 0.3
    #: smallest fraction of the image's structure a yarn grid explains
    min_grid_strength: float = 0.25
    #: fewest yarns along each axis of the photo
    min_yarns_in_photo: int = 4
