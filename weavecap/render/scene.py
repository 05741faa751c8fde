"""The scene around a garment: a camera framed on the mesh, lights, an optional ground.

Views (docs/design.md, "Commands", the ``render`` contract): ``front`` puts the camera on +z looking towards
−z with y up; ``back``, ``left``, ``right`` turn it about y (azimuth 180°, −90°, 90°);
``top`` looks down (elevation 90°, −z up in the image); ``AZ,EL`` gives azimuth and
elevation in degrees. The camera frames the mesh's bounding box: with margin 0 its eight
corners fit the image exactly (perspective: the nearest distance at which they all lie in the
field of view; orthographic: the smallest extent that holds them), a margin F widens the frame
by F on each side.

Lights, all relative to the camera so a view keeps its lighting:

- ``studio``: key (upper left front), fill (right, dimmer), rim (behind, above) and a dim
  uniform ambient — directional lights, noise-free under next-event estimation;
- ``sun``: one directional light at 50° elevation and a sky of uniform radiance;
- ``both``, ``front``, ``back``: the capture rigs of ``synth`` and ``fit`` (§6.4,
  :func:`weavecap.model.scene.light_rig`): their directional lights, their ambient term and
  their backdrop (seen through the gaps) as the forward model evaluates them;
- a path to an ``.exr`` or ``.hdr`` environment map (Mitsuba's ``envmap``, +y up).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..model import bysdf as _bysdf
from ..model.scene import RIGS, light_rig

mi = _bysdf.mi
dr = _bysdf.dr

VIEWS = {"front": (0.0, 0.0), "back": (180.0, 0.0), "left": (-90.0, 0.0), "right": (90.0, 0.0), "top": (0.0, 90.0)}
CAPTURE_RIGS = RIGS
LIGHTS = ("studio", "sun") + CAPTURE_RIGS
ENV_SUFFIXES = (".exr", ".hdr")
#: studio lights: (direction towards the light in the camera frame (right, up, towards the
#: camera), irradiance); and the ambient radiance that keeps shadows from going black
STUDIO = (((-0.55, 0.55, 0.65), 3.0), ((0.75, 0.15, 0.45), 1.0), ((0.25, 0.6, -0.75), 2.0))
STUDIO_AMBIENT = 0.08
SUN = ((-0.35, 0.77, 0.53), 3.0)  # 50° elevation, from the upper left front
SKY = (0.18, 0.22, 0.30)
GROUND_ALBEDO = 0.35


def parse_view(text: str) -> tuple[float, float]:
    """``front|back|left|right|top`` or ``AZ,EL`` (degrees) → (azimuth, elevation)."""
    key = text.strip().lower()
    if key in VIEWS:
        return VIEWS[key]
    try:
        az, el = (float(v) for v in key.split(","))
    except ValueError:
        raise InputError(f"--view {text!r}: use front, back, left, right, top or AZ,EL in degrees (e.g. 30,20)") from None
    if not (math.isfinite(az) and math.isfinite(el)) or not -90.0 <= el <= 90.0:
        raise InputError(f"--view {text!r}: the elevation must be a number in [-90, 90] degrees")
    return az, el


@dataclass(frozen=True)
class Camera:
    """A framed camera. ``origin``, ``target`` and ``up`` are world points/vectors (metres);
    ``fov_deg`` is the horizontal field of view (perspective) and ``half_width`` the half
    extent of the frame (orthographic); ``pixel`` the size in metres of a pixel at the nearest
    point of the bounding box (for the texture resolution)."""

    kind: str
    origin: tuple
    target: tuple
    up: tuple
    size: tuple[int, int]  # (width, height)
    fov_deg: float
    half_width: float
    near: float
    far: float
    pixel: float

    @property
    def basis(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(right, up, towards the camera): the camera frame's unit axes in world space."""
        back = np.asarray(self.origin) - np.asarray(self.target)
        back /= np.linalg.norm(back)
        right = np.cross(np.asarray(self.up), back)
        right /= np.linalg.norm(right)
        return right, np.cross(back, right), back

    def sensor(self, spp: int, sampler: dict | None = None) -> dict:
        """The Mitsuba sensor (perspective or orthographic, box-filtered film of ``size``)."""
        look = mi.ScalarTransform4f().look_at(origin=list(self.origin), target=list(self.target), up=list(self.up))
        film = {"type": "hdrfilm", "width": int(self.size[0]), "height": int(self.size[1]),
                "rfilter": {"type": "box"}, "pixel_format": "rgb"}
        sampler = dict(sampler or {"type": "independent"}, sample_count=int(spp))
        if self.kind == "orthographic":
            to_world = look @ mi.ScalarTransform4f().scale([self.half_width, self.half_width, 1.0])
            return {"type": "orthographic", "to_world": to_world, "film": film, "sampler": sampler,
                    "near_clip": float(self.near), "far_clip": float(self.far)}
        return {"type": "perspective", "to_world": look, "fov": float(self.fov_deg), "fov_axis": "x", "film": film,
                "sampler": sampler, "near_clip": float(self.near), "far_clip": float(self.far)}


def frame_camera(bounds: np.ndarray, *, view: tuple[float, float], kind: str = "perspective",
                 fov_deg: float = 35.0, margin: float = 0.05, size: tuple[int, int] = (1280, 720)) -> Camera:
    """A camera looking at the centre of ``bounds`` ((2, 3) box, metres) from ``view``
    (azimuth, elevation in degrees), framing the box's corners with ``margin``."""
    if kind not in ("perspective", "orthographic"):
        raise InputError(f"--camera {kind!r} is unknown; use perspective or orthographic")
    if not (math.isfinite(margin) and 0.0 <= margin <= 10.0):
        raise InputError(f"--margin {margin}: use a number in [0, 10] (0 frames the bounding box exactly)")
    if not (math.isfinite(fov_deg) and 1.0 <= fov_deg <= 150.0):
        raise InputError(f"--fov {fov_deg}: use a number of degrees in [1, 150]")
    width, height = size
    aspect = width / height
    az, el = (math.radians(v) for v in view)
    toward = np.array([math.sin(az) * math.cos(el), math.sin(el), math.cos(az) * math.cos(el)])
    up = np.array([0.0, 1.0, 0.0]) if abs(el) < math.radians(89.9) else \
        np.array([-math.sin(az), 0.0, -math.cos(az)]) * np.sign(el)
    centre = bounds.mean(axis=0)
    corners = np.array([[bounds[i, 0], bounds[j, 1], bounds[k, 2]] for i in (0, 1) for j in (0, 1) for k in (0, 1)])
    right = np.cross(up, toward)
    right /= np.linalg.norm(right)
    cam_up = np.cross(toward, right)
    rel = corners - centre
    x, y, z = rel @ right, rel @ cam_up, rel @ toward  # z: towards the camera
    radius = float(np.linalg.norm(rel, axis=1).max()) or 1.0
    if kind == "orthographic":
        half = max(float(np.abs(x).max()), float(np.abs(y).max()) * aspect, 1e-9) * (1.0 + margin)
        distance = float(z.max()) + radius + 1e-3
        pixel = 2.0 * half / width
        fov = fov_deg
    else:
        tan_x = math.tan(math.radians(fov_deg) / 2.0) / (1.0 + margin)
        tan_y = tan_x / aspect
        distance = float(np.max(np.maximum(z + np.abs(x) / tan_x, z + np.abs(y) / tan_y)))
        distance = max(distance, float(z.max()) + 1e-3 * radius)
        half = 0.0
        nearest = max(distance - float(z.max()), 1e-6)
        pixel = 2.0 * nearest * math.tan(math.radians(fov_deg) / 2.0) / width
        fov = fov_deg
    origin = centre + distance * toward
    near = max(1e-4 * radius, (distance - float(z.max())) * 0.5) if kind == "perspective" else 1e-4 * radius
    return Camera(kind=kind, origin=tuple(origin), target=tuple(centre), up=tuple(up), size=(int(width), int(height)),
                  fov_deg=fov, half_width=half, near=near, far=distance + 4.0 * radius, pixel=pixel)


@dataclass(frozen=True)
class Lighting:
    """The emitters of a scene (Mitsuba dicts by name) and what the integrator needs of the
    capture rigs: their ambient radiance and backdrop (``None`` when not a rig)."""

    name: str
    emitters: dict
    ambient: float = 0.0
    background: float | None = None


def _directional(direction_to_light: np.ndarray, irradiance: float) -> dict:
    """A directional light; next-event estimation picks it in proportion to its irradiance."""
    d = np.asarray(direction_to_light, dtype=np.float64)
    d = d / np.linalg.norm(d)
    return {"type": "directional", "direction": (-d).tolist(), "sampling_weight": float(irradiance),
            "irradiance": {"type": "rgb", "value": [float(irradiance)] * 3}}


def _uniform_sky(radiance) -> dict:
    """A constant environment; picked in proportion to the irradiance it gives (π × radiance)."""
    value = [float(radiance)] * 3 if np.isscalar(radiance) else [float(v) for v in radiance]
    return {"type": "constant", "sampling_weight": math.pi * float(np.mean(value)),
            "radiance": {"type": "rgb", "value": value}}


def lighting(name: str, camera: Camera) -> Lighting:
    """The lights ``name`` (LIGHTS, or an environment map's path) for ``camera``."""
    right, up, back = camera.basis
    to_world = lambda v: v[0] * right + v[1] * up + v[2] * back  # noqa: E731  (camera frame → world)
    if name == "studio":
        emitters = {f"light_{k}": _directional(to_world(d), e) for k, (d, e) in enumerate(STUDIO)}
        emitters["ambient"] = _uniform_sky(STUDIO_AMBIENT)
        return Lighting("studio", emitters)
    if name == "sun":
        return Lighting("sun", {"sun": _directional(to_world(SUN[0]), SUN[1]), "sky": _uniform_sky(SKY)})
    if name in CAPTURE_RIGS:
        rig = light_rig(name)
        # the rig's directions are in the forward model's frame: x right, y down the image, z
        # towards the camera
        emitters = {f"light_{k}": _directional(to_world((l.direction[0], -l.direction[1], l.direction[2])),
                                               l.irradiance) for k, l in enumerate(rig.lights)}
        return Lighting(name, emitters, ambient=rig.ambient, background=rig.backdrop)
    path = Path(name)
    if path.suffix.lower() not in ENV_SUFFIXES:
        raise InputError(f"--light {name!r}: use one of {', '.join(LIGHTS)}, or an environment map (.exr, .hdr)")
    if not path.is_file():
        raise InputError(f"--light {name}: environment map not found")
    try:
        mi.Bitmap(str(path))
    except Exception as exc:  # noqa: BLE001 - Mitsuba's reader says why
        raise InputError(f"{path}: not a readable environment map ({exc})") from None
    return Lighting(path.name, {"environment": {"type": "envmap", "filename": str(path.resolve())}})


def ground(bounds: np.ndarray) -> dict:
    """A grey diffuse floor under the mesh's lowest point, ten times its size."""
    lo, hi = bounds
    centre = 0.5 * (lo + hi)
    extent = 10.0 * float(np.linalg.norm(hi - lo)) or 1.0
    to_world = (mi.ScalarTransform4f().translate([float(centre[0]), float(lo[1]) - 1e-4 * extent, float(centre[2])])
                @ mi.ScalarTransform4f().rotate([1, 0, 0], -90) @ mi.ScalarTransform4f().scale([extent, extent, 1]))
    return {"type": "rectangle", "to_world": to_world,
            "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [GROUND_ALBEDO] * 3}}}
