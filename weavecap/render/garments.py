"""Garments no renderer here was trained on: the render bench's meshes (``weavecap bench --render``).

The fold renderer learnt on :mod:`.shapes` (sines, waves, horseshoes, a flared skirt, a drape
over a sphere); the woven renderer on flat repeats. The agreement bench judges both on shapes
made here, with other profiles, depths and tessellations:

- :func:`pleated_skirt`: a skirt of knife pleats — a cone whose radius zig-zags around, the
  pleats' inner walls facing each other (deep, narrow folds);
- :func:`pleated_curtain`: a curtain hanging in deep, narrow rounded pleats (pinched at the top,
  opening downwards; 60 mm deep, 36 mm apart);
- :func:`swag_drape`: a cloth hung from two pins, sagging between them, folds radiating
  from the pins;
- :func:`sleeve`: a tube bent at the elbow, with ring wrinkles on the inside of the bend;
- :func:`crumpled_sheet`: a sheet with folds in random directions.

Every shape is in metres, y up, faces counter-clockwise seen from the fabric's face, UVs the
flat pattern in metres (bent without stretching where the shape allows it; :mod:`.mesh`
corrects the rest), as :mod:`.shapes`.
"""

from __future__ import annotations

import math

import numpy as np

from .shapes import Shape, _arc_length_resample, _grid_faces


def _zigzag(phase: np.ndarray, sharpness: float) -> np.ndarray:
    """A triangle wave of period 1 in [-1, 1], its corners rounded by ``sharpness`` (0: a sine,
    1: sharp corners)."""
    tri = 2.0 * np.abs(2.0 * (phase - np.floor(phase + 0.5))) - 1.0
    return (1.0 - sharpness) * -np.cos(2.0 * math.pi * phase) + sharpness * tri


def pleated_skirt(*, waist: float = 0.15, hem: float = 0.26, length: float = 0.5, pleats: int = 16,
                  depth: float = 0.035, around: int = 16 * 12 + 1, rows: int = 25, name: str = "pleated_skirt") -> Shape:
    """A skirt of ``pleats`` knife pleats: a cone from the waist to the hem radius whose radius
    zig-zags by ±``depth``/2 around (pleats stitched flat at the waist, open from a fifth of
    the length down). UVs: each row's arc length around, and the slant length down (the pleats
    take up cloth, as real ones do)."""
    theta = np.linspace(0.0, 2.0 * math.pi, around)
    t = np.linspace(0.0, 1.0, rows)
    opened = np.clip((t - 0.05) / 0.2, 0.0, 1.0)[:, None]
    phase = pleats * theta[None, :] / (2.0 * math.pi)
    r = waist + (hem - waist) * t[:, None] + 0.5 * depth * opened * _zigzag(phase, 0.85)
    x, z = r * np.sin(theta), r * np.cos(theta)
    y = np.broadcast_to(-length * t[:, None], r.shape)
    positions = np.stack([x, y, z], axis=-1).reshape(-1, 3)
    seg = np.hypot(np.diff(x, axis=1), np.diff(z, axis=1))
    u = np.concatenate([np.zeros((rows, 1)), np.cumsum(seg, axis=1)], axis=1)
    u -= u[:, :1] + 0.5 * u[:, -1:]
    slant = math.hypot(hem - waist, length)
    v = np.broadcast_to(-slant * t[:, None], r.shape)
    uv = np.stack([u, v], axis=-1).reshape(-1, 2)
    faces = _grid_faces(around, rows)[:, [0, 2, 1]]
    return Shape(name, positions, faces, uv,
                 f"knife-pleated skirt, {pleats} pleats {depth * 1000:g} mm deep, hem {hem * 200:g} cm across")


def pleated_curtain(*, width: float = 0.5, height: float = 0.6, pleats: int = 14, depth: float = 0.06,
                    samples_per_pleat: int = 24, rows: int = 31, name: str = "pleated_curtain") -> Shape:
    """A curtain hanging in ``pleats`` deep pleats facing +z: the profile a rounded zig-zag of
    ``depth`` (front to back), pinched to a third of it at the top and full from half the
    height down. Each row is resampled by arc length; u is that arc length, v the height."""
    y = np.linspace(height / 2, -height / 2, rows)
    nu = pleats * samples_per_pleat + 1
    dense = np.linspace(0.0, width, nu * 16)
    positions, uv = [], []
    for yy in y:
        open_share = 1.0 / 3.0 + (2.0 / 3.0) * min(1.0, (height / 2 - yy) / (height / 2))
        profile = np.stack([dense, 0.5 * depth * open_share * _zigzag(pleats * dense / width, 0.6)], axis=1)
        row, length = _arc_length_resample(profile, nu)
        positions.append(np.stack([row[:, 0] - width / 2, np.full(nu, yy), row[:, 1]], axis=1))
        uv.append(np.stack([np.linspace(-length / 2, length / 2, nu), np.full(nu, yy)], axis=1))
    faces = _grid_faces(nu, rows)[:, [0, 2, 1]]  # rows run downwards: flip to face +z
    return Shape(name, np.concatenate(positions), faces, np.concatenate(uv),
                 f"pleated curtain {width * 100:g} x {height * 100:g} cm, {pleats} pleats {depth * 1000:g} mm deep")


def swag_drape(*, width: float = 0.6, drop: float = 0.35, sag: float = 0.12, folds: int = 6, depth: float = 0.025,
               cells: int = 72, name: str = "swag_drape") -> Shape:
    """A cloth of ``width`` × ``drop`` pinned at its two top corners: the top edge sags by
    ``sag`` between the pins (a catenary-like curve), the cloth below hangs with ``folds``
    folds that fan out from the pins (deepest in the middle) and bulges forward (+z) as it
    falls. UVs: the flat cloth."""
    n = cells + 1
    a, b = np.meshgrid(np.linspace(-0.5, 0.5, n), np.linspace(0.0, 1.0, n))  # across, down (0 at the top)
    top_sag = sag * (1.0 - (2.0 * a) ** 2)
    x = width * a * (1.0 - 0.25 * b)  # drawn in a little at the bottom
    y = -top_sag * (1.0 - 0.3 * b) - drop * b
    fan = np.sin(math.pi * (a + 0.5))  # 0 at the pins
    angle = folds * math.pi * (a + 0.5) / (1.0 + 0.6 * b)
    z = 0.06 * np.sin(math.pi * b) * fan + depth * fan * np.minimum(1.0, 3.0 * b) * np.sin(angle)
    positions = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    uv = np.stack([(width * a).ravel(), (-drop * b).ravel()], axis=1)
    faces = _grid_faces(n, n)[:, [0, 2, 1]]
    return Shape(name, positions, faces, uv,
                 f"swag drape {width * 100:g} cm between two pins, sag {sag * 100:g} cm, {folds} folds")


def sleeve(*, radius: float = 0.05, upper: float = 0.28, lower: float = 0.26, bend_deg: float = 70.0,
           wrinkles: int = 6, depth: float = 0.008, around: int = 64, rows: int = 121, name: str = "sleeve") -> Shape:
    """A sleeve: a tube of ``radius`` along an arm bent by ``bend_deg`` at the elbow (upper
    arm along −y, forearm turned towards +z), ring wrinkles of ``depth`` bunched on the inside
    of the bend. Faces outward. UVs: the tube cut open along its back (u around, v along the
    arm's centre line)."""
    total = upper + lower
    s = np.linspace(0.0, total, rows)
    bend = math.radians(bend_deg)
    elbow_len = 0.12  # the bend is spread over this length of the centre line
    turn = bend * np.clip((s - upper + elbow_len / 2) / elbow_len, 0.0, 1.0)  # centre line direction angle
    ds = np.diff(s, prepend=0.0)
    centre = np.stack([np.zeros_like(s), -np.cumsum(np.cos(turn) * ds), np.cumsum(np.sin(turn) * ds)], axis=1)
    tangent = np.stack([np.zeros_like(s), -np.cos(turn), np.sin(turn)], axis=1)
    side = np.array([1.0, 0.0, 0.0])
    inward = np.cross(tangent, side)  # points to the inside of the bend (+z side turned)
    phi = np.linspace(0.0, 2.0 * math.pi, around)
    near_elbow = np.exp(-0.5 * ((s - upper) / 0.06) ** 2)
    ring = depth * near_elbow * np.sin(2.0 * math.pi * wrinkles * (s - upper) / 0.12)
    rr = radius + ring[:, None] * (0.5 + 0.5 * np.cos(phi[None, :]))  # deepest on the inside (phi = 0)
    offset = (np.cos(phi)[None, :, None] * inward[:, None, :] + np.sin(phi)[None, :, None] * side[None, None, :])
    positions = (centre[:, None, :] + rr[..., None] * offset).reshape(-1, 3)
    uv = np.stack([np.broadcast_to(radius * (phi - math.pi)[None, :], rr.shape),
                   np.broadcast_to(-s[:, None], rr.shape)], axis=-1).reshape(-1, 2)
    faces = _grid_faces(around, rows)
    tri = positions[faces]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    centroid = tri.mean(axis=1)
    axis_point = centre[faces[:, 0] // around]
    if np.mean(np.sum(normal * (centroid - axis_point), axis=1)) < 0:
        faces = faces[:, [0, 2, 1]]
    return Shape(name, positions, faces, uv,
                 f"sleeve, radius {radius * 100:g} cm, bent {bend_deg:g} degrees, {wrinkles} wrinkles at the elbow")


def crumpled_sheet(size: float = 0.3, cells: int = 120, *, seed: int = 7, name: str = "crumpled") -> Shape:
    """A sheet with folds in random directions: z = Σ_k A_k sin(2π x_k/λ_k) g_k, eight ridges
    of random orientation, wavelength 3–7 cm and amplitude 2–7 mm, each under a Gaussian window
    of 5–9 cm at a random place. Metres, faces counter-clockwise from +z."""
    rng = np.random.default_rng(seed)
    n = cells + 1
    x, y = np.meshgrid(np.linspace(-size / 2, size / 2, n), np.linspace(-size / 2, size / 2, n))
    z = np.zeros_like(x)
    for _ in range(8):
        theta, lam = rng.uniform(0, np.pi), rng.uniform(0.03, 0.07)
        amp, width = rng.uniform(0.002, 0.007), rng.uniform(0.05, 0.09)
        cx, cy = rng.uniform(-size / 3, size / 3, 2)
        along = (x - cx) * np.cos(theta) + (y - cy) * np.sin(theta)
        z += amp * np.sin(2 * np.pi * along / lam) * np.exp(-((x - cx) ** 2 + (y - cy) ** 2) / (2 * width**2))
    positions = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    return Shape(name, positions, _grid_faces(n, n), positions[:, :2] + size / 2,
                 f"crumpled sheet {size * 100:g} cm, eight random folds (seed {seed})")


#: the bench's garments, by name: (the shape, a view that looks into its folds, deep folds?)
GARMENTS = {
    "pleated_skirt": (pleated_skirt, (30.0, 15.0), True),
    "pleated_curtain": (pleated_curtain, (0.0, 0.0), True),
    "swag_drape": (swag_drape, (15.0, 10.0), False),
    "sleeve": (sleeve, (60.0, 10.0), False),
    "crumpled": (crumpled_sheet, (20.0, 45.0), False),
}
