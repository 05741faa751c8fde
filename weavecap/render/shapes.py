"""Procedural cloth shapes: the project's own test meshes for ``weavecap render``.

The fold-shape study of Son et al. (supplement §3.4: planar sheets with sinusoidal folds of
increasing amplitude, and non-sinusoidal horseshoe folds of different opening widths), plus a
flat swatch, a flared skirt and a square cloth draped over a sphere. ``fixtures/make_meshes.py``
writes the fixture set (:data:`FIXTURES`) to ``fixtures/meshes/``; the fold renderer's training
data calls these functions with other parameters.

Every shape is in metres, y up, and its faces are wound counter-clockwise seen from the side
the fabric's face is on (the outside of the skirt, the top of the drape, the +z side of the
sheets, which the ``front`` view looks at). Texture coordinates are the flat pattern the
shape was made from, in metres (the sheets are bent without stretching, so their UVs are
isometric up to the discretisation; the skirt and the drape stretch a little, which
:mod:`weavecap.render.mesh` corrects).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

OBJ_DIGITS = 4  # decimals written to OBJ files (0.1 mm in metres)


@dataclass(frozen=True)
class Shape:
    """A triangle mesh with texture coordinates.

    Attributes
    ----------
    name : str
    positions : (V, 3) float64, metres
    faces : (F, 3) int64, counter-clockwise seen from the fabric's face
    uv : (V, 2) float64, the flat pattern's coordinates, metres
    description : one line, for the file header
    """

    name: str
    positions: np.ndarray
    faces: np.ndarray
    uv: np.ndarray
    description: str

    def to_trimesh(self):
        """The shape as a ``trimesh.Trimesh`` (texture coordinates as its UV visuals)."""
        import trimesh

        return trimesh.Trimesh(vertices=self.positions, faces=self.faces, process=False,
                               visual=trimesh.visual.TextureVisuals(uv=self.uv))

    def obj_text(self, command: str = "") -> str:
        """Wavefront OBJ text (v, vt, vn, f; no material), with a header naming the shape
        and the command that made it."""
        from trimesh.exchange.obj import export_obj

        body = export_obj(self.to_trimesh(), include_normals=True, include_texture=True, digits=OBJ_DIGITS,
                          header=None)
        lines = [line for line in body.splitlines() if not line.startswith(("mtllib", "usemtl"))]
        header = [f"# {self.name}: {self.description}", "# units: metres; y up; texture coordinates in metres"]
        if command:
            header.append(f"# made by: {command}")
        return "\n".join(header + lines) + "\n"


def _grid_faces(nu: int, nv: int) -> np.ndarray:
    """Triangles of an nu × nv vertex grid (index = iv * nu + iu), counter-clockwise in (u, v)."""
    iu, iv = np.meshgrid(np.arange(nu - 1), np.arange(nv - 1))
    a = (iv * nu + iu).ravel()
    b, c, d = a + 1, a + nu, a + nu + 1
    return np.concatenate([np.stack([a, b, d], 1), np.stack([a, d, c], 1)]).astype(np.int64)


def _arc_length_resample(points: np.ndarray, count: int) -> tuple[np.ndarray, float]:
    """``count`` points evenly spaced by arc length along a densely sampled polyline (N, D),
    and the polyline's length."""
    seg = np.linalg.norm(np.diff(points, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    target = np.linspace(0.0, s[-1], count)
    return np.stack([np.interp(target, s, points[:, k]) for k in range(points.shape[1])], axis=1), float(s[-1])


def _profile_sheet(name: str, profile: np.ndarray, height: float, samples: int, rows: int,
                   description: str) -> Shape:
    """A sheet swept along y from a profile curve (N, 2) of (x, z): u = arc length along the
    profile (isometric: the sheet is bent, not stretched), v = y; centred on the origin."""
    curve, length = _arc_length_resample(profile, samples)
    y = np.linspace(-height / 2, height / 2, rows)
    x = np.tile(curve[:, 0], rows)
    z = np.tile(curve[:, 1], rows)
    yy = np.repeat(y, samples)
    positions = np.stack([x - 0.5 * (curve[:, 0].max() + curve[:, 0].min()), yy, z], axis=1)
    u = np.tile(np.linspace(-length / 2, length / 2, samples), rows)
    return Shape(name, positions, _grid_faces(samples, rows), np.stack([u, yy], axis=1), description)


def flat_swatch(width: float = 0.2, height: float = 0.2, *, cells: int = 1) -> Shape:
    """A flat rectangle in the plane z = 0, facing +z, centred on the origin; ``cells`` quads a
    side. UV (0, 0) is its lower left corner, so a swatch a whole number of repeats wide and
    high starts a repeat at its top left, as a photo of the fabric does."""
    n = cells + 1
    x, y = np.meshgrid(np.linspace(-width / 2, width / 2, n), np.linspace(-height / 2, height / 2, n))
    positions = np.stack([x.ravel(), y.ravel(), np.zeros(n * n)], axis=1)
    return Shape("swatch", positions, _grid_faces(n, n), positions[:, :2] + (width / 2, height / 2),
                 f"flat swatch {width * 100:g} x {height * 100:g} cm")


def sine_folds(*, amplitude: float, wavelength: float = 0.05, width: float = 0.2, height: float = 0.2,
               samples_per_wave: int = 12, rows: int = 5, name: str | None = None) -> Shape:
    """Parallel sinusoidal folds z = A sin(2π x / λ), their ridges along y (§3.4 "Sine")."""
    waves = width / wavelength
    x = np.linspace(0.0, width, max(64, int(waves * samples_per_wave * 8)))
    profile = np.stack([x, amplitude * np.sin(2 * math.pi * x / wavelength)], axis=1)
    return _profile_sheet(name or "sine", profile, height, int(round(waves * samples_per_wave)) + 1, rows,
                          f"sine folds, amplitude {amplitude * 1000:g} mm, wavelength {wavelength * 1000:g} mm")


def horseshoe(*, opening: float, radius: float = 0.025, width: float = 0.2, height: float = 0.2,
              samples: int = 97, rows: int = 5, name: str | None = None) -> Shape:
    """A flat sheet that rises into one Ω-shaped fold: a loop of ``radius`` whose neck is
    ``opening`` wide (< 2 radius: the loop overhangs), flat beyond (§3.4 "Horseshoe")."""
    if not 0.0 < opening < 2.0 * radius:
        raise ValueError(f"opening {opening} must be in (0, 2 * radius = {2 * radius})")
    centre = math.sqrt(radius**2 - (opening / 2) ** 2)  # circle through the neck points (±opening/2, 0)
    start = math.atan2(-centre, -opening / 2)  # the left neck point's angle on the circle
    sweep = 2 * math.pi - 2 * (math.pi / 2 + start)  # the long way round, over the top
    theta = start - np.linspace(0.0, sweep, 400)
    loop = np.stack([radius * np.cos(theta), centre + radius * np.sin(theta)], axis=1)
    side = (width - opening) / 2
    left = np.stack([np.linspace(-opening / 2 - side, -opening / 2, 100), np.zeros(100)], axis=1)
    right = np.stack([np.linspace(opening / 2, opening / 2 + side, 100), np.zeros(100)], axis=1)
    profile = np.concatenate([left[:-1], loop, right[1:]])
    return _profile_sheet(name or "horseshoe", profile, height, samples, rows,
                          f"horseshoe fold, radius {radius * 1000:g} mm, opening {opening * 1000:g} mm")


def wave(*, amplitude: float = 0.012, wavelength: float = 0.05, meander: float = 1.2, width: float = 0.2,
         height: float = 0.2, samples_per_wave: int = 12, rows: int = 17, name: str = "wave") -> Shape:
    """Folds whose ridges meander: z = A sin(2π x/λ + m sin(2π y/h)) — deep valleys that
    bend, not developable (§3.4 "Wave"); u is the arc length along x of each row."""
    nu = int(round(width / wavelength * samples_per_wave)) + 1
    y = np.linspace(-height / 2, height / 2, rows)
    dense = np.linspace(0.0, width, nu * 16)
    positions, uv = [], []
    for yy in y:
        phase = meander * math.sin(2 * math.pi * (yy / height + 0.5))
        row, length = _arc_length_resample(np.stack([dense, amplitude * np.sin(2 * math.pi * dense / wavelength + phase)],
                                                    axis=1), nu)
        positions.append(np.stack([row[:, 0] - width / 2, np.full(nu, yy), row[:, 1]], axis=1))
        uv.append(np.stack([np.linspace(-length / 2, length / 2, nu), np.full(nu, yy)], axis=1))
    return Shape(name, np.concatenate(positions), _grid_faces(nu, rows), np.concatenate(uv),
                 f"meandering folds, amplitude {amplitude * 1000:g} mm, wavelength {wavelength * 1000:g} mm")


def skirt(*, waist: float = 0.14, hem: float = 0.32, length: float = 0.55, folds: int = 10,
          fold_depth: float = 0.035, around: int = 81, rows: int = 13, name: str = "skirt") -> Shape:
    """A flared skirt: a cone from the waist radius to the hem radius, hanging from y = 0 down
    to y = -length, with ``folds`` radial folds deepening towards the hem. UVs: the cone's
    flat pattern (an annular sector), seam at the back (θ = 0 duplicated)."""
    theta = np.linspace(0.0, 2 * math.pi, around)
    t = np.linspace(0.0, 1.0, rows)
    tt, th = np.meshgrid(t, theta, indexing="ij")
    r = waist + (hem - waist) * tt + fold_depth * tt**1.5 * np.sin(folds * th)
    positions = np.stack([(r * np.sin(th)).ravel(), (-length * tt).ravel(), (r * np.cos(th)).ravel()], axis=1)
    slant = math.hypot(hem - waist, length)
    apex = waist * slant / (hem - waist)  # the cone's apex distance above the waist, along the slant
    spread = 2 * math.pi * (hem - waist) / slant  # the flat sector's angle
    rho = apex + slant * tt
    phi = (th / (2 * math.pi) - 0.5) * spread
    uv = np.stack([(rho * np.sin(phi)).ravel(), (-rho * np.cos(phi)).ravel()], axis=1)
    faces = _grid_faces(around, rows)[:, [0, 2, 1]]  # outward seen from outside
    return Shape(name, positions, faces, uv,
                 f"flared skirt, waist {waist * 200:g} cm, hem {hem * 200:g} cm across, {folds} folds")


def drape_over_sphere(*, size: float = 0.6, radius: float = 0.15, cap_deg: float = 55.0, folds: int = 7,
                      fold_depth: float = 0.03, cells: int = 32, name: str = "drape") -> Shape:
    """A square cloth of side ``size`` dropped centred on a sphere of ``radius`` (centre at
    the origin): it follows the sphere to ``cap_deg`` from the top, then hangs, turning
    towards vertical, with ``folds`` folds that deepen with the distance from the cap.
    UVs: the flat cloth's coordinates."""
    n = cells + 1
    a, b = np.meshgrid(np.linspace(-size / 2, size / 2, n), np.linspace(-size / 2, size / 2, n))
    rho = np.hypot(a, b)
    phi = np.arctan2(b, a)
    cap = math.radians(cap_deg)
    r_cloth = radius * 1.01  # just off the sphere
    rim = r_cloth * cap  # arc length from the top to the cap's edge
    # beyond the rim the cloth leaves the sphere tangentially (direction at polar angle cap + 90°
    # from +y) and turns towards straight down (180°) over a length of about the radius
    s = np.linspace(0.0, size, 2000)
    direction = math.pi - (math.pi / 2 - cap) * np.exp(-s / radius)
    step = np.diff(s, prepend=0.0)
    out = np.cumsum(np.sin(direction) * step) + r_cloth * math.sin(cap)
    down = np.cumsum(np.cos(direction) * step) + r_cloth * math.cos(cap)
    beyond = np.maximum(rho - rim, 0.0)
    on_cap = rho <= rim
    polar = np.minimum(rho, rim) / r_cloth
    radial = np.where(on_cap, r_cloth * np.sin(polar), np.interp(beyond, s, out))
    height = np.where(on_cap, r_cloth * np.cos(polar), np.interp(beyond, s, down))
    radial = radial + fold_depth * np.minimum(beyond / radius, 1.0) * np.sin(folds * phi)
    positions = np.stack([(radial * np.cos(phi)).ravel(), height.ravel(), (radial * np.sin(phi)).ravel()], axis=1)
    uv = np.stack([a.ravel(), -b.ravel()], axis=1)  # seen from above: u along x, v along -z
    faces = _grid_faces(n, n)[:, [0, 2, 1]]  # the top of the cloth faces up (+y)
    return Shape(name, positions, faces, uv,
                 f"{size * 100:g} cm cloth draped over a sphere of radius {radius * 100:g} cm, {folds} folds")


#: the fixture meshes (fixtures/meshes/NAME.obj), by name
FIXTURES = {
    "swatch": lambda: flat_swatch(0.2, 0.2),
    "sine_low": lambda: sine_folds(amplitude=0.004, name="sine_low"),
    "sine_high": lambda: sine_folds(amplitude=0.015, name="sine_high"),
    "wave": lambda: wave(),
    "horseshoe_wide": lambda: horseshoe(opening=0.04, name="horseshoe_wide"),
    "horseshoe_narrow": lambda: horseshoe(opening=0.015, name="horseshoe_narrow"),
    "skirt": lambda: skirt(),
    "drape": lambda: drape_over_sphere(),
}
