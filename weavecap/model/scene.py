"""A close-up scene of a fabric: yarn meshes, camera and the light rig of §6.4 (Wu et al. 2025).

:class:`FabricScene` owns the Mitsuba scene (one tube mesh for the wefts, one for the warps,
each carrying a :class:`~weavecap.model.bysdf.BYSDF`) and one store of Dr.Jit values, keyed
by the dotted names of :data:`weavecap.params.FIT_RANGES`, that both those plugins and
:mod:`weavecap.model.render` read. Changing a continuous value never recompiles a kernel; a
new pattern or radius rebuilds the meshes (a few ms).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from ..errors import InputError
from ..params import FIT_RANGES, Fabric
from . import bysdf as _bysdf
from .geometry import PITCH, TubeMesh, crossover_height, fabric_meshes
from .threads import thread_tables

mi = _bysdf.mi
dr = _bysdf.dr

#: shading keys of :class:`weavecap.model.bysdf.Shading` → dotted fabric keys
SHADING_KEYS = {
    "coefficient": "specular.coefficient", "reflection": "specular.reflection",
    "transmission": "specular.transmission", "transmission_exit": "specular.transmission_exit",
    "roughness": "specular.roughness", "roughness_exit": "specular.roughness_exit",
    "ior": "specular.ior", "ior_exit": "specular.ior_exit", "attenuation": "specular.attenuation",
    "body_attenuation": "body_attenuation", "ply_shadow": "shadowing.ply", "fiber_shadow": "shadowing.fiber",
    "plies": "plies", "fibers": "fibers",
}
YARN_KEYS = ("warp.body_reflection", "weft.body_reflection", "warp.body_subsurface", "weft.body_subsurface")
GEOMETRY_KEYS = ("warp.radius", "weft.radius")


@dataclass(frozen=True)
class Light:
    """A directional light: unit ``direction`` towards the light (world), irradiance ``E``."""

    direction: tuple[float, float, float]
    irradiance: float


def _unit(x, y, z) -> tuple[float, float, float]:
    n = math.sqrt(x * x + y * y + z * z)
    return (x / n, y / n, z / n)


@dataclass(frozen=True)
class LightRig:
    """§6.4: an ambient light and directional lights; ``backdrop`` is the radiance seen
    through the gaps between yarns (a lit panel behind the fabric, or the room).

    The camera looks down -z, so "front" lights have z > 0 and "back" lights z < 0.
    ``gain`` (RGB) is the rig's intensity and colour as the camera recorded them — exposure
    times white balance, a property of the photo, not of the fabric: every light, the ambient
    and the backdrop are scaled by it, so a render is ``gain`` times the render at (1, 1, 1).
    """

    ambient: float
    lights: tuple[Light, ...]
    backdrop: float
    name: str = "custom"
    gain: tuple[float, float, float] = (1.0, 1.0, 1.0)

    def with_gain(self, gain) -> "LightRig":
        """The same rig recorded with another ``gain`` (RGB, or one number for all channels)."""
        g = np.broadcast_to(np.asarray(gain, dtype=np.float64), (3,))
        if not np.all(np.isfinite(g)) or np.any(g <= 0):
            raise InputError(f"light gain {g.tolist()} must be three positive finite numbers")
        return replace(self, gain=tuple(float(v) for v in g))

    @property
    def lit_from_back(self) -> bool:
        return any(light.direction[2] < 0 for light in self.lights)

    @property
    def backdrop_is_reference(self) -> bool:
        """Whether what the gaps show is a reference for the photo's exposure and white
        balance: the lit panel of a rig lit from the back, not the room behind a front-lit
        fabric."""
        return self.lit_from_back and self.backdrop > 0


FRONT = Light(_unit(0.25, -0.35, 1.0), 1.0)
BACK = Light(_unit(0.1, 0.15, -1.0), 1.0)
SIDES = (Light(_unit(1.0, 0.0, 0.45), 0.45), Light(_unit(-1.0, 0.0, 0.45), 0.45))


#: what the gaps of the ``front`` rig show: nothing. Behind a front-lit fabric lies the room in
#: the fabric's own shadow — on the real photos the gaps are the darkest pixels (FabricNET
#: 0027's 5th percentile L* 17 where a backdrop of 0.05 rendered L* 52 at its fitted gain of 4.4),
#: and the independent generator's dark gaps are 0.015. Measured with it against 0.05: docs/capture.md
FRONT_BACKDROP = 0.0
#: the rigs :func:`light_rig` knows
RIGS = ("both", "front", "back", "lamp")
#: the ambient light of the ``lamp`` rig, in place of the side lights (which give a flat surface
#: 2 × 0.45 × sin 24° ≈ 0.37 in ``both``); the one value tried, not tuned
LAMP_AMBIENT = 0.28


def light_rig(which: str = "both") -> LightRig:
    """The default rig (``both``: ambient + front, back and two side lights, §6.4), the
    front-only / back-only rigs for photos whose lighting is known, or ``lamp``: one lamp in
    front (the front light) over a lit panel (the back light), no side lights, a stronger
    ambient in their place.

    ``--light auto`` never takes ``lamp`` before the fit (:func:`weavecap.fit.rigs.choose_rig`);
    a rig search weighs it (:func:`weavecap.fit.rigs.search`). Measured with it (normal; docs/capture.md, the light
    rig), against auto's ``both``: on the independent photos, the satin 8 warp-faced's
    sharpness 0.31 → 1.05 (rounded pink risers where auto's are flat bars), the twill 3/1's ΔE
    13.3 / 2.1 → 5.5 / 5.3 and the twill 2/1 Z's 8.3 / 2.5 → 3.2 / 0.4; on the real photos, the
    plains W027 and W077 sharper (0.79 → 0.92, 0.74 → 0.88) but their colours further off (ΔE up
    to 7.5, 7.9), and both satins fitted as custom weaves. Not by rounder shading: on a grey
    plain its yarn flanks get 0.95 of their tops' light, 0.86 under ``both``; the fits differ in
    where the colours and the specular lobe settle."""
    if which == "both":
        return LightRig(ambient=0.12, lights=(FRONT, BACK) + SIDES, backdrop=BACK.irradiance, name="both")
    if which == "lamp":
        return LightRig(ambient=LAMP_AMBIENT, lights=(FRONT, BACK), backdrop=BACK.irradiance, name="lamp")
    if which == "front":
        return LightRig(ambient=0.15, lights=(FRONT,) + SIDES, backdrop=FRONT_BACKDROP, name="front")
    if which == "back":
        return LightRig(ambient=0.05, lights=(BACK,), backdrop=BACK.irradiance, name="back")
    raise InputError(f"light rig {which!r} is unknown; use one of {', '.join(RIGS)}")


@dataclass(frozen=True)
class View:
    """What the camera sees.

    Attributes
    ----------
    tiles : (rows, cols) of repeats in the frame
    size : pixels along the longer side of the frame (the other follows the aspect ratio)
    camera : ``"orthographic"`` (a flat close-up) or ``"perspective"``
    fov_deg : field of view of the perspective camera along the longer side
    rotate_deg : the fabric appears turned by this angle, counter-clockwise, in the image
    spp : samples per pixel (a stratified grid; 1 = pixel centres). Directional and ambient
        light are evaluated exactly, so samples only antialias edges.
    """

    tiles: tuple[int, int] = (1, 1)
    size: int = 128
    camera: str = "orthographic"
    fov_deg: float = 30.0
    rotate_deg: float = 0.0
    spp: int = 4

    def __post_init__(self):
        if not (math.isfinite(self.rotate_deg) and math.isfinite(self.fov_deg)):
            raise InputError(f"rotation {self.rotate_deg} and field of view {self.fov_deg} must be finite numbers "
                             "of degrees")
        if self.camera not in ("orthographic", "perspective"):
            raise InputError(f"camera {self.camera!r} is unknown; use orthographic or perspective")
        if not (8 <= self.size <= 8192):
            raise InputError(f"image size {self.size} is out of range; allowed [8, 8192] pixels")
        if not (1 <= self.spp <= 1024):
            raise InputError(f"spp {self.spp} is out of range; allowed [1, 1024]")
        if not (1.0 <= self.fov_deg <= 120.0):
            raise InputError(f"field of view {self.fov_deg} is out of range; allowed [1, 120] degrees")
        if not all(1 <= t <= 64 for t in self.tiles):
            raise InputError(f"tiles {self.tiles} out of range; allowed 1..64 repeats per axis")


@dataclass
class Frame:
    """The camera frame in world units: centre, size, pixel grid and the yarn window to build."""

    center: tuple[float, float]
    extent: tuple[float, float]  # (width, height) of the un-rotated frame, world units
    shape: tuple[int, int]  # (height, width) in pixels
    rows: tuple[int, int]  # wefts to build
    cols: tuple[int, int]  # warps to build
    eye_height: float = 0.0  # perspective camera height above the fabric (0 for orthographic)


def make_frame(pattern_shape: tuple[int, int], view: View) -> Frame:
    """Where the camera looks and which yarns must exist to fill its picture."""
    n_e, n_a = pattern_shape
    width = view.tiles[1] * n_a * PITCH
    height = view.tiles[0] * n_e * PITCH
    if width >= height:
        shape = (max(1, round(view.size * height / width)), view.size)
    else:
        shape = (view.size, max(1, round(view.size * width / height)))
    cx, cy = width / 2.0, height / 2.0
    theta = math.radians(view.rotate_deg)
    half_w = 0.5 * (abs(width * math.cos(theta)) + abs(height * math.sin(theta)))
    half_h = 0.5 * (abs(width * math.sin(theta)) + abs(height * math.cos(theta)))
    eye = 0.0
    if view.camera == "perspective":
        eye = 0.5 * max(width, height) / math.tan(math.radians(view.fov_deg) / 2.0)
        margin = 1.5  # rays at the frame edge meet the yarns' tops before the plane z = 0
        half_w, half_h = half_w * margin, half_h * margin
    rows = (math.floor((cy - half_h) / PITCH) - 1, math.ceil((cy + half_h) / PITCH) + 1)
    cols = (math.floor((cx - half_w) / PITCH) - 1, math.ceil((cx + half_w) / PITCH) + 1)
    return Frame(center=(cx, cy), extent=(width, height), shape=shape, rows=rows, cols=cols, eye_height=eye)


def yarn_mesh(name: str, tubes: TubeMesh, bsdf_obj):
    """A ``mi.Mesh`` of tubes (positions, normals, texture coordinates) carrying ``bsdf_obj``."""
    props = mi.Properties()
    props["bsdf"] = bsdf_obj
    mesh = mi.Mesh(name, tubes.positions.shape[0], tubes.faces.shape[0], props=props,
                   has_vertex_normals=True, has_vertex_texcoords=True)
    params = mi.traverse(mesh)
    params["vertex_positions"] = mi.Float(tubes.positions.ravel())
    params["faces"] = mi.UInt32(tubes.faces.ravel())
    params["vertex_normals"] = mi.Float(tubes.normals.ravel())
    params["vertex_texcoords"] = mi.Float(tubes.texcoords.ravel())
    params.update()
    return mesh


def body_texture(path: str):
    """A body-colour texture (linear RGB, wrapped over one repeat of the fabric) and its mean."""
    from ..photo import load_photo

    rgb = np.clip(load_photo(path).rgb, 0.0, 1.0).astype(np.float32)
    tex = mi.Texture2f(mi.TensorXf(rgb), filter_mode=dr.FilterMode.Linear, wrap_mode=dr.WrapMode.Repeat)
    return tex, tuple(float(c) for c in rgb.reshape(-1, 3).mean(axis=0))


@dataclass
class FabricScene:
    """A fabric set up for rendering: meshes, frame, lights and the parameter store.

    Build it with :func:`build_scene`. ``values`` maps every dotted key of
    :data:`weavecap.params.FIT_RANGES` except the radii and body textures to a Dr.Jit value
    (``mi.Float`` or ``mi.Color3f``); enable gradients on them to differentiate a render.
    """

    fabric: Fabric
    view: View
    rig: LightRig
    frame: Frame
    scene: object
    values: dict
    textures: dict = field(default_factory=dict)
    warp_shape: object = None
    z_range: tuple[float, float] = (0.0, 1.0)
    cache: dict = field(default_factory=dict)  # G-buffers of weavecap.model.render, per (spp, seed)
    built: dict = field(default_factory=dict)  # the last geometries built (:func:`_rebuild`)
    threads: dict = field(default_factory=dict)  # family → per-thread colours (weavecap.model.threads)

    def set(self, key: str, value) -> None:
        """Set one parameter by dotted key (or ``"pattern"``); a radius or a pattern rebuilds
        the geometry (milliseconds), any other value only changes what the kernels read."""
        if key in GEOMETRY_KEYS or key == "pattern":
            if np.array_equal(np.asarray(value), self.fabric.get(key)):
                return  # the geometry built already (a search stepping back onto its last trial)
            self.fabric = self.fabric.replace({key: value if key == "pattern" else float(value)})
            _rebuild(self)
            return
        if key not in self.values:
            raise KeyError(f"{key} is not a renderable parameter")
        old = self.values[key]
        new = type(old)(*np.atleast_1d(np.asarray(value, dtype=np.float64)).tolist()) if isinstance(old, mi.Color3f) \
            else mi.Float(float(value))
        dr.make_opaque(new)
        self.values[key] = new
        _bind_shapes(self)

    def set_threads(self, threads) -> None:
        """Give the fabric these thread colours (:class:`weavecap.params.Threads`, or None for
        the family colours on every thread): new tables, and new G-buffers where the thread
        indices were not cast before (the geometry stays)."""
        had = bool(self.threads)
        self.fabric = self.fabric.with_threads(threads)
        self.threads = thread_tables(self.fabric)
        if bool(self.threads) != had:
            self.cache.clear()
            for built in self.built.values():
                built[3].clear()

    def to_fabric(self) -> Fabric:
        """The fabric with the store's current values (plies and fibres rounded to integers)."""
        values = {}
        for key, value in self.values.items():
            if key in self.textures:
                continue
            flat = np.array(dr.ravel(value), dtype=np.float64)
            values[key] = tuple(flat.tolist()) if isinstance(value, mi.Color3f) else float(flat[0])
        for key in ("plies", "fibers"):
            values[key] = int(round(values[key]))
        for key, (lo, hi) in FIT_RANGES.items():  # the store is float32: 0.8 reads 0.80000001
            if key in values:
                values[key] = tuple(float(np.clip(v, lo, hi)) for v in values[key]) \
                    if isinstance(values[key], tuple) else type(values[key])(np.clip(values[key], lo, hi))
        return self.fabric.replace(values)

    def shading(self) -> "_bysdf.Shading":
        """The shared BYSDF parameters, from the store."""
        return _bysdf.Shading(**{sk: self.values[fk] for sk, fk in SHADING_KEYS.items()})


def parameter_store(fabric: Fabric) -> dict:
    """Dr.Jit values (opaque) of every shading key and yarn colour of ``fabric``, by dotted key
    (a body-colour texture is left out: :func:`body_texture` loads it)."""
    values = {}
    for key in list(SHADING_KEYS.values()) + list(YARN_KEYS):
        v = fabric.get(key)
        if isinstance(v, str):  # a texture: the store holds its mean colour for lobe weights
            continue
        values[key] = mi.Color3f(*v) if isinstance(v, tuple) else mi.Float(float(v))
        dr.make_opaque(values[key])
    return values


def _bind(plugin, values: dict, yarn: str) -> None:
    """Point a yarn's BYSDF plugin at the store's values (shared shading + its own colours)."""
    plugin.values.update({sk: values[fk] for sk, fk in SHADING_KEYS.items()})
    for key in ("body_reflection", "body_subsurface"):
        if f"{yarn}.{key}" in values:
            plugin.values[key] = values[f"{yarn}.{key}"]


def _bind_shapes(fs: FabricScene) -> None:
    """Point the scene's two yarn meshes' BYSDFs (wefts, then warps) at the store's values."""
    for shape, yarn in zip(fs.scene.shapes(), ("weft", "warp")):
        _bind(shape.bsdf(), fs.values, yarn)


def height_range(fabric: Fabric) -> tuple[float, float]:
    """(lowest, highest) z a yarn surface of ``fabric`` can reach, world units."""
    top = crossover_height(fabric.warp.radius, fabric.weft.radius) / 2 + max(fabric.warp.radius, fabric.weft.radius)
    return (-top, top)


#: geometries a scene keeps built, so that a search stepping back to one of them (a radius or a
#: cell flip tried and refused) costs no BVH build and no geometry pass
GEOMETRIES_KEPT = 4


def _rebuild(fs: FabricScene) -> None:
    """Point ``fs`` at the geometry of ``fs.fabric``'s pattern and radii: one of the last
    :data:`GEOMETRIES_KEPT` built (with its G-buffers), or built anew. A build is Embree's BVH
    over every triangle (~0.9 µs each: 18 ms for a 5 × 5 satin's window at 24 px a cell) and
    then a geometry pass (15 ms), against 3 ms for a render that reuses both; a greedy radius
    search steps back onto a geometry it built on every round."""
    fabric = fs.fabric
    key = (fabric.pattern.shape, fabric.pattern.tobytes(), float(fabric.warp.radius), float(fabric.weft.radius))
    if key in fs.built:
        fs.built[key] = fs.built.pop(key)  # the most recently used last
        fs.scene, fs.warp_shape, fs.z_range, fs.cache = fs.built[key]
        _bind_shapes(fs)  # the store's values may have been replaced since
        return
    _build(fs)
    fs.built[key] = (fs.scene, fs.warp_shape, fs.z_range, fs.cache)
    while len(fs.built) > GEOMETRIES_KEPT:
        fs.built.pop(next(iter(fs.built)))


def _build(fs: FabricScene) -> None:
    fabric, frame = fs.fabric, fs.frame
    wefts, warps = fabric_meshes(fabric.pattern, r_warp=fabric.warp.radius, r_weft=fabric.weft.radius,
                                 rows=frame.rows, cols=frame.cols)
    plugins = []
    for yarn in ("weft", "warp"):
        plugin = _bysdf.BYSDF(mi.Properties())
        _bind(plugin, fs.values, yarn)
        plugins.append(plugin)
    weft_mesh = yarn_mesh("wefts", wefts, plugins[0])
    warp_mesh = yarn_mesh("warps", warps, plugins[1])
    fs.scene = mi.load_dict({"type": "scene", "wefts": weft_mesh, "warps": warp_mesh})
    fs.warp_shape = mi.ShapePtr(warp_mesh)
    dr.make_opaque(fs.warp_shape)  # read from memory, as the heights are: no kernel per scene built
    fs.z_range = height_range(fabric)
    fs.cache = {}


def build_scene(fabric: Fabric, view: View | None = None, *, light: str | LightRig = "both") -> FabricScene:
    """Set up ``fabric`` for rendering under ``view`` and a light rig (name or :class:`LightRig`)."""
    view = view or View()
    rig = light if isinstance(light, LightRig) else light_rig(light)
    frame = make_frame(fabric.shape, view)
    fs = FabricScene(fabric=fabric, view=view, rig=rig, frame=frame, scene=None, values=parameter_store(fabric),
                     threads=thread_tables(fabric))
    for yarn in ("warp", "weft"):
        tex = fabric.get(f"{yarn}.body_reflection")
        if isinstance(tex, str):
            fs.textures[f"{yarn}.body_reflection"], mean = body_texture(tex)
            fs.values[f"{yarn}.body_reflection"] = mi.Color3f(*mean)  # for lobe weights and plugins
    _rebuild(fs)
    return fs
