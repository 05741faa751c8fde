"""Photos rendered by weavecap's own forward model, with known truth (shared by tests and the bench).

Renders of the forward model are the test data of preparation: yarns with
procedural plies and fibres, gaps lit from behind, warps and wefts of different colours and
radii. Each photo is a random fabric over Table 1 (``weavecap.estimate.sampling``), turned
in-plane, seen by a perspective camera, with noise and JPEG.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from weavecap.estimate.sampling import random_fabric, random_pattern
from weavecap.photo import linear_to_srgb, srgb_to_linear

FAMILIES = ("plain", "twill", "satin", "basket", "rib", "random")


def minimum_repeat(pattern: np.ndarray) -> tuple[int, int]:
    """(wefts, warps) of the smallest cyclic shift along each axis that leaves ``pattern`` as it is.

    A random pattern may repeat within itself along one axis (two identical pairs of rows);
    a photo can only show that smaller repeat.
    """
    p = np.asarray(pattern)
    out = []
    for axis in (0, 1):
        n = p.shape[axis]
        out.append(next(k for k in range(1, n + 1) if n % k == 0 and np.array_equal(np.roll(p, k, axis=axis), p)))
    return out[0], out[1]


@dataclass(frozen=True)
class ForwardTruth:
    """What a forward-model photo shows: the pattern, its minimum repeat, pitch (px at the
    image centre, the same along both axes) and the turn (synth's ``rotate_deg``, CCW)."""

    family: str
    pattern: np.ndarray
    yarns: tuple[int, int]
    pitch_px: float
    rotate_deg: float


def forward_photo(rng: np.random.Generator, *, family: str | None = None, pattern: np.ndarray | None = None,
                  size: int = 512, spp: int = 4,
                  max_turn_deg: float = 40.0, pitch_px: tuple[float, float] = (9.0, 26.0), min_tiles: int = 5,
                  noise: float = 0.01, jpeg: int = 90, seed: int = 0) -> tuple[np.ndarray, ForwardTruth]:
    """Render one photo of a random fabric of ``family`` (random if None; or of ``pattern``, when
    given) with the forward model.

    The pitch is drawn from ``pitch_px`` and then set by a whole number of repeats per axis, at
    least ``min_tiles`` (so that a turned photo still holds a few repeats). Returns the photo
    (linear RGB float32, as ``load_photo`` gives after the JPEG round trip) and its truth.
    """
    from weavecap.model.render import render_numpy
    from weavecap.model.scene import View, build_scene

    if pattern is None:
        family, pattern = random_pattern(rng, family=family, max_size=8)
    pattern = np.asarray(pattern, np.uint8)
    fabric = random_fabric(rng, pattern)
    n_e, n_a = pattern.shape
    want = float(rng.uniform(*pitch_px))
    tiles = (max(min_tiles, round(size / (want * n_e))), max(min_tiles, round(size / (want * n_a))))
    pitch = size / max(tiles[0] * n_e, tiles[1] * n_a)
    turn = float(rng.uniform(-max_turn_deg, max_turn_deg))
    view = View(tiles=tiles, size=size, spp=spp, rotate_deg=turn, camera="perspective", fov_deg=12.0)
    img = render_numpy(build_scene(fabric, view), seed=seed)
    img = img + rng.normal(0.0, noise, img.shape).astype(np.float32)
    srgb = (np.clip(linear_to_srgb(np.clip(img, 0, 1)), 0, 1) * 255 + 0.5).astype(np.uint8)
    _, buf = cv2.imencode(".jpg", srgb, [cv2.IMWRITE_JPEG_QUALITY, jpeg])
    srgb = cv2.imdecode(buf, cv2.IMREAD_UNCHANGED)
    photo = srgb_to_linear(srgb.astype(np.float32) / 255.0).astype(np.float32)
    return photo, ForwardTruth(family or "given", pattern, minimum_repeat(pattern), float(pitch), turn)


def measure_forward(prepared, truth: ForwardTruth) -> dict:
    """Errors of one prepared forward-model photo against its truth: turn (degrees; synth's
    ``rotate_deg`` θ ↔ prepare's ``rotation_deg`` = −θ), pitch (relative, input px at the
    centre, worse of the two axes) and whether the repeat in yarns is exact."""
    turn = prepared.rectification.rotation_deg + truth.rotate_deg
    turn = (turn + 45.0) % 90.0 - 45.0  # the two yarn families look alike to the angle search
    pitch = prepared.checks["pitch_input_px"]
    return {"turn_err": abs(turn), "pitch_err": max(abs(p / truth.pitch_px - 1) for p in pitch),
            "repeat_ok": tuple(prepared.grid.yarns) == tuple(truth.yarns)}
