"""``weavecap render``'s stages in order: the fabric's surface model baked (or read from the
cache of earlier bakes, :mod:`.bake_cache`), placed on the mesh at
its physical size, the scene framed and lit, rendered in the chosen mode, a fold term added.

The mesh is read once (:func:`weavecap.render.mesh.load_mesh`) and may carry several fabrics in
turn; :func:`render_fabric` renders one. Samples are taken in passes of at most PASS_SPP
(progress between passes); pass ``k`` uses seed ``seed * MAX_PASSES + k``, so a seed gives the
same image bit for bit. Without ``--spp`` a mode that does not fix its own takes passes until
the image's noise is below what shows (:func:`adaptive_passes`).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..params import Fabric
from . import modes as _modes
from .bsdf import Placement
from .mesh import RenderMesh
from .scene import Camera, Lighting, frame_camera, ground, lighting
from .bake_cache import cached_bake
from .surface import SurfaceMaps, noise_map

DEFAULT_PITCH_MM = 0.3  # a medium-weight woven fabric (about 33 yarns a centimetre)
PASS_SPP = 16
MAX_PASSES = 1 << 16
MAX_SPP = 1 << 16
MAX_PIXELS = 8192 * 8192
#: texels per yarn: at least this many, and about one per pixel a yarn covers, up to the cap
MIN_TEXELS, MAX_TEXELS = 16, 64
LINEAR_FROM = 0.5  # pixels a texel covers (nearest yarn) from which maps are interpolated


@dataclass(frozen=True)
class RenderOptions:
    """Everything ``weavecap render`` can be told (see its ``--help``); lengths in metres,
    angles in degrees, ``size`` is (width, height) in pixels."""

    mode: str = "reference"
    spp: int | None = 64  # None: until the noise is below NOISE_L (adaptive_passes)
    size: tuple[int, int] = (1280, 720)
    view: tuple[float, float] = (0.0, 0.0)
    camera: str = "perspective"
    fov_deg: float = 35.0
    margin: float = 0.05
    light: str = "studio"
    pitch_mm: float | None = None
    angle_deg: float = 0.0
    offset: tuple[float, float] = (0.0, 0.0)
    max_depth: int = 8
    seed: int = 0
    ground: bool = False
    noise: bool = True
    fold: str = "auto"
    texels_per_yarn: int | None = None

    def __post_init__(self):
        if self.spp is not None and not 1 <= self.spp <= MAX_SPP:
            raise InputError(f"--spp {self.spp}: use a number of samples per pixel in [1, {MAX_SPP}]")
        w, h = self.size
        if w < 1 or h < 1 or w * h > MAX_PIXELS:
            raise InputError(f"--size {w}x{h}: use a width and height of at least 1 and at most {MAX_PIXELS} pixels "
                             "in all")
        if not 1 <= self.max_depth <= 1024:
            raise InputError(f"--max-depth {self.max_depth}: use a path length in [1, 1024]")
        if self.pitch_mm is not None and not (math.isfinite(self.pitch_mm) and 1e-3 <= self.pitch_mm <= 100.0):
            raise InputError(f"--pitch-mm {self.pitch_mm}: use a yarn pitch in [0.001, 100] mm")
        if not (math.isfinite(self.angle_deg) and all(math.isfinite(v) for v in self.offset)):
            raise InputError("--fabric-angle and --fabric-offset must be finite numbers")
        if not 0 <= self.seed < 2**32 // MAX_PASSES:
            raise InputError(f"--seed {self.seed}: use a seed in [0, {2**32 // MAX_PASSES - 1}]")


@dataclass
class RenderContext:
    """What a fold term (:class:`weavecap.render.modes.FoldTerm`) is given: the Mitsuba scene,
    the mesh, the fabric and its maps, camera, lighting, options and the image so far."""

    scene: object
    mesh: RenderMesh
    fabric: Fabric
    maps: SurfaceMaps
    camera: Camera
    lighting: Lighting
    options: RenderOptions
    image: np.ndarray


@dataclass
class RenderResult:
    """A render: ``image`` (H, W, 3) float32 linear RGB, and ``info`` (what was rendered, how,
    and the timings of each stage in seconds)."""

    image: np.ndarray
    info: dict = field(default_factory=dict)


def pitch_of(fabric: Fabric, override: float | None) -> tuple[float, str]:
    """The yarn pitch in mm and where it came from: ``--pitch-mm``, the params' ``scale``, or
    DEFAULT_PITCH_MM (the caller warns)."""
    if override is not None:
        return float(override), "--pitch-mm"
    scale = fabric.scale or {}
    if scale.get("pitch_mm"):
        return float(scale["pitch_mm"]), "params scale.pitch_mm"
    return DEFAULT_PITCH_MM, "default"


def texels_for_view(pitch_m: float, camera: Camera) -> int:
    """Texels per yarn for a view: about one per pixel the nearest yarn covers (a power of
    two), at least MIN_TEXELS and at most MAX_TEXELS."""
    pixels_per_yarn = pitch_m / max(camera.pixel, 1e-12)
    t = 2 ** math.ceil(math.log2(max(pixels_per_yarn, 1.0)))
    return int(min(MAX_TEXELS, max(MIN_TEXELS, t)))


@dataclass
class PreparedRender:
    """A scene ready to render: the Mitsuba scene and what went into it (see
    :func:`prepare_render`); ``info`` and ``timings`` are completed by :func:`render_fabric`."""

    scene: object
    camera: Camera
    lighting: Lighting
    maps: SurfaceMaps
    fold_term: object
    info: dict
    timings: dict


def prepare_render(fabric: Fabric, mesh: RenderMesh, options: RenderOptions) -> PreparedRender:
    """Everything before the samples: camera, lights, the fabric's bake at the view's texel
    size, its placement at the physical pitch, the mode's BSDF and integrator, the scene."""
    from ..backend import mitsuba

    mi = mitsuba()
    timings: dict[str, float] = {}
    notes: list[str] = []
    chosen = _modes.mode(options.mode)
    camera = frame_camera(mesh.bounds, view=options.view, kind=options.camera, fov_deg=options.fov_deg,
                          margin=options.margin, size=options.size)
    lights = lighting(options.light, camera)
    term = _modes.fold_term(options.fold, chosen, mesh)
    pitch_mm, pitch_source = pitch_of(fabric, options.pitch_mm)
    if pitch_source == "default":
        notes.append(f"warning: the params give no scale.pitch_mm; rendering at a pitch of {DEFAULT_PITCH_MM} mm "
                     "(a medium-weight woven); give --pitch-mm")
    pitch = pitch_mm / 1000.0
    texels = options.texels_per_yarn or texels_for_view(pitch, camera)
    pixels_per_yarn = pitch / max(camera.pixel, 1e-12)

    t = time.perf_counter()
    maps, bake_cached = cached_bake(fabric, texels)
    noise = noise_map(fabric, seed=options.seed) if options.noise else None
    timings["bake"] = time.perf_counter() - t

    t = time.perf_counter()
    n_e, n_a = fabric.shape
    placement = Placement(repeat_size=(n_a * pitch, n_e * pitch), angle_deg=options.angle_deg, offset=options.offset)
    linear = pixels_per_yarn / maps.texels_per_yarn >= LINEAR_FROM
    bsdf = chosen.bsdf(fabric, maps, placement, noise, linear)
    pass_spp = AUTO_PASS_SPP if options.spp is None else min(options.spp, PASS_SPP)
    scene_dict = {"type": "scene", "integrator": chosen.integrator(lights, options),
                  "sensor": camera.sensor(pass_spp, chosen.sampler), "garment": mesh.to_mitsuba(bsdf), **lights.emitters}
    if options.ground:
        scene_dict["ground"] = ground(mesh.bounds)
    scene = mi.load_dict(scene_dict)
    timings["scene"] = time.perf_counter() - t
    info = {
        "mode": chosen.name, "spp": options.spp, "size": list(options.size), "camera": options.camera,
        "view": list(options.view), "light": lights.name,
        "max_depth": options.max_depth if chosen.name == "reference" else 2,
        "pitch_mm": pitch_mm, "pitch_source": pitch_source,
        "repeat_mm": [n_a * pitch_mm, n_e * pitch_mm], "fabric_angle_deg": options.angle_deg,
        "fabric_offset": list(options.offset), "texels_per_yarn": maps.texels_per_yarn,
        "pixels_per_yarn": pixels_per_yarn, "texture_filter": "linear" if linear else "nearest",
        "bake_cached": bake_cached,
        "noise": noise is not None, "fold": term.name if term is not None else None, "fold_detail": None,
        "seed": options.seed,
        "timings": timings, "notes": notes,
    }
    return PreparedRender(scene=scene, camera=camera, lighting=lights, maps=maps, fold_term=term, info=info,
                          timings=timings)


def render_fabric(fabric: Fabric, mesh: RenderMesh, options: RenderOptions, *, progress=None) -> RenderResult:
    """Render ``fabric`` on ``mesh``.

    Parameters
    ----------
    fabric : the captured fabric
    mesh : from :func:`weavecap.render.mesh.load_mesh` (fabric coordinates in metres)
    options : RenderOptions
    progress : ``(done, total)`` callable, called after each pass of samples

    Returns
    -------
    RenderResult
    """
    start = time.perf_counter()
    prepared = prepare_render(fabric, mesh, options)
    timings = prepared.timings
    t = time.perf_counter()
    if options.spp is None:
        image, spp, noise = adaptive_passes(prepared.scene, options.seed, progress=progress)
        prepared.info.update(spp=spp, spp_rule=f"until the noise is at most {NOISE_L} L* (median), at most {AUTO_MAX_SPP}",
                             noise_l=noise)
    else:
        image = render_passes(prepared.scene, options.spp, options.seed, progress=progress)
    timings["render"] = time.perf_counter() - t
    if prepared.fold_term is not None:
        t = time.perf_counter()
        context = RenderContext(prepared.scene, mesh, fabric, prepared.maps, prepared.camera, prepared.lighting,
                                options, image)
        applied = prepared.fold_term.apply(context)
        image, detail = applied if isinstance(applied, tuple) else (applied, None)  # (image, what it modelled)
        image = np.asarray(image, dtype=np.float32)
        prepared.info["fold_detail"] = detail
        timings["fold"] = time.perf_counter() - t
    timings["total"] = time.perf_counter() - start
    return RenderResult(image=image, info=prepared.info)


def render_passes(scene, spp: int, seed: int, *, progress=None) -> np.ndarray:
    """``spp`` samples per pixel of ``scene`` in passes of at most PASS_SPP, averaged
    (float32 (H, W, 3)); pass k is seeded ``seed * MAX_PASSES + k``."""
    from ..backend import mitsuba

    mi = mitsuba()
    passes = math.ceil(spp / PASS_SPP)
    total = None
    done = 0
    for k in range(passes):
        n = min(PASS_SPP, spp - done)
        image = np.array(mi.render(scene, spp=n, seed=seed * MAX_PASSES + k), dtype=np.float64)
        total = image * n if total is None else total + image * n
        done += n
        if progress is not None:
            progress(done, spp)
    return (total / spp).astype(np.float32)


#: adaptive sampling (:func:`adaptive_passes`): passes of AUTO_PASS_SPP samples until the
#: median noise of the image is at most NOISE_L in CIE L* (1 is about the smallest lightness
#: step one sees side by side), at least AUTO_MIN_SPP and at most AUTO_MAX_SPP samples
AUTO_PASS_SPP, AUTO_MIN_SPP, AUTO_MAX_SPP = 8, 16, 512
NOISE_L = 1.0
#: median |N(0, 1)|: the median of |A - B| / 2 over pixels of one noise level is this × the
#: standard error of the mean of A and B
HALF_NORMAL_MEDIAN = 0.6745


def lightness(image: np.ndarray) -> np.ndarray:
    """CIE L* (0–100) of linear RGB (..., 3) as an sRGB display shows it (clipped to [0, 1])."""
    y = np.clip(np.asarray(image, np.float64), 0.0, 1.0) @ np.array([0.2126, 0.7152, 0.0722])
    return np.where(y > (6 / 29) ** 3, 116.0 * np.cbrt(y) - 16.0, y * (29 / 3) ** 3)


def noise_level(a: np.ndarray, b: np.ndarray, where: np.ndarray | None = None) -> float:
    """The median standard error in L* of the mean of two independent images ``a`` and ``b``
    (H, W, 3) of the same spp, over the pixels ``where`` ((H, W) bool; default all); 0 if none."""
    la, lb = lightness(a), lightness(b)
    where = np.ones(la.shape, bool) if where is None else where
    if not where.any():
        return 0.0
    return float(np.median(np.abs(la - lb)[where]) / 2.0 / HALF_NORMAL_MEDIAN)


def surface_pixels(scene) -> np.ndarray:
    """(H, W) bool: the pixels whose centre sees a shape of ``scene`` (one camera ray each) —
    where the noise is; the background (black, a backdrop or an environment seen directly) has
    none worth counting."""
    from ..backend import mitsuba

    mi = mitsuba()
    sensor = scene.sensors()[0]
    w, h = (int(v) for v in sensor.film().crop_size())
    y, x = np.mgrid[0:h, 0:w]
    pos = mi.Point2f(((x + 0.5) / w).ravel().astype(np.float32), ((y + 0.5) / h).ravel().astype(np.float32))
    ray, _ = sensor.sample_ray(0.0, 0.5, pos, mi.Point2f(0.5, 0.5))
    return np.array(scene.ray_intersect(ray).is_valid()).reshape(h, w)


def adaptive_passes(scene, seed: int, *, progress=None, noise_l: float = NOISE_L, min_spp: int = AUTO_MIN_SPP,
                    max_spp: int = AUTO_MAX_SPP) -> tuple[np.ndarray, int, float]:
    """Passes of AUTO_PASS_SPP samples (pass k seeded ``seed * MAX_PASSES + k``) until the
    noise of the mean (:func:`noise_level` of the even passes' mean against the odd ones', over
    the :func:`surface_pixels`) is at most ``noise_l``, or ``max_spp`` samples; at least
    ``min_spp``. Returns (image (H, W, 3) float32, the spp taken, the noise estimated)."""
    from ..backend import mitsuba

    mi = mitsuba()
    where = surface_pixels(scene)
    halves = [None, None]
    done, k, noise = 0, 0, float("inf")
    while True:
        image = np.array(mi.render(scene, spp=AUTO_PASS_SPP, seed=seed * MAX_PASSES + k), dtype=np.float64)
        halves[k % 2] = image if halves[k % 2] is None else halves[k % 2] + image
        done += AUTO_PASS_SPP
        k += 1
        if progress is not None:
            progress(done, max_spp)
        if k % 2 == 0 and done >= min_spp:
            noise = noise_level(halves[0] / (k // 2), halves[1] / (k // 2), where)
            if noise <= noise_l or done >= max_spp:
                break
    if progress is not None and done < max_spp:
        progress(done, done)
    return ((halves[0] + halves[1]) / k).astype(np.float32), done, noise
