"""Render a :class:`~weavecap.model.scene.FabricScene`, and differentiate image losses.

The integrator is ours, written in Dr.Jit over Mitsuba's ray queries, because the scenes of
§6.4 need only direct light and because a yarn transmits: a back light reaches the viewer
*through* the yarn it hits. Mitsuba's own integrators would find the yarn's far side in the
way of every shadow ray; here the shadow ray of a transmitted light starts at the exit point y
where it leaves the yarn (the point of §3.3's f_y^S), and is blocked only by other yarns.

Per camera sample: one primary ray; per front light one shadow ray; per back light an
exit-point ray and a shadow ray; the ambient light as the BYSDF's directional albedo times a
height-based occlusion term (no rays). No continuous parameter moves a ray, so the rays are
cast once per view (:func:`geometry_pass`, cached as a :class:`GBuffer`) and a render is
:func:`shade`: the BYSDF over that buffer, one kernel forward and a few backward. The radii
move the geometry: their gradient is a central finite difference (:func:`radius_gradient`).
Everything is deterministic for a given seed; with ``spp = 1`` the samples sit at pixel
centres and the seed plays no part.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter

from . import bysdf as _bysdf
from .geometry import PITCH
from ..params import FIT_RANGES
from .scene import GEOMETRY_KEYS, FabricScene

mi = _bysdf.mi
dr = _bysdf.dr

R2 = 1.32471795724474602596  # plastic number: the R2 low-discrepancy sequence's generator
AO_FLOOR = 0.35  # ambient seen by the lowest yarn points relative to the highest


def ambient_occlusion(z, z_range: tuple[float, float]):
    """The share of the ambient light a yarn point at height ``z`` sees: 1 on the highest
    yarn tops, AO_FLOOR at the lowest points (``z_range``, world units), linear between."""
    z_lo, z_hi = z_range
    return AO_FLOOR + (1.0 - AO_FLOOR) * dr.clip((z - z_lo) / (z_hi - z_lo), 0.0, 1.0)


def _frac(x):
    return x - dr.floor(x)


def _camera_rays(fs: FabricScene, spp: int, seed: int):
    """Primary rays, pixel-major (sample ``s`` of pixel ``p`` is entry ``p * spp + s``)."""
    height, width = fs.frame.shape
    idx = dr.arange(mi.UInt32, height * width * spp)
    pix = idx // spp
    s = mi.Float(idx % spp)
    px, py = mi.Float(pix % width), mi.Float(pix // width)
    if spp == 1:
        ox, oy = mi.Float(0.5), mi.Float(0.5)
    else:
        ox = _frac(0.5 + s / R2)
        oy = _frac(0.5 + s / (R2 * R2))
        if seed:
            rng = mi.PCG32(size=height * width * spp, initstate=mi.UInt64(pix) * 2654435761 + seed)
            ox = _frac(ox + rng.next_float32())
            oy = _frac(oy + rng.next_float32())
    ext_w, ext_h = fs.frame.extent
    # the heights move with every radius: read from memory, not compiled in, they leave one
    # kernel for every geometry (a literal compiled a new one, ~80 ms, at each radius tried)
    top = dr.opaque(mi.Float, fs.z_range[1] + 1.0)
    a = ((px + ox) / width - 0.5) * ext_w  # image coordinates, world units, y down
    b = ((py + oy) / height - 0.5) * ext_h
    theta = np.radians(fs.view.rotate_deg)
    c, si_ = float(np.cos(theta)), float(np.sin(theta))
    cx, cy = fs.frame.center
    fx = cx + c * a - si_ * b  # the fabric point seen there (inverse of a CCW turn in the image)
    fy = cy + si_ * a + c * b
    if fs.view.camera == "orthographic":
        origin = mi.Point3f(fx, fy, top)
        direction = mi.Vector3f(0.0, 0.0, -1.0)
    else:
        eye = fs.frame.eye_height + top
        origin = mi.Point3f(cx, cy, eye)
        direction = dr.normalize(mi.Vector3f(fx - cx, fy - cy, -eye))
    return mi.Ray3f(origin, direction), (height, width)


@dataclass
class GBuffer:
    """Everything a render needs that does not depend on a continuous parameter (§6.4 scenes).

    Built once per view, seed and geometry by :func:`geometry_pass` (ray casts, one kernel);
    each render then only shades it (:func:`shade`), so a fitting step traces no rays and its
    gradient graph holds only the BYSDF. Arrays have one entry per camera sample
    (``H * W * spp``, pixel-major).

    Attributes
    ----------
    shape : (H, W) pixels; spp : samples per pixel
    hit : Bool, the sample sees a yarn; is_warp : Bool, that yarn is a warp
    uv : Point2f, tube texture coordinates (plies and fibres)
    wv : Vector3f, direction to the viewer in the local shading frame
    wl : per light, Vector3f direction to the light in the local frame
    lit : per light, Bool: the light reaches the point (directly, or through the yarn's exit
        point when it lights the far side)
    ao : Float, the ambient occlusion factor (1 on yarn tops, AO_FLOOR deepest)
    fabric_uv : Point2f, the hit's position in repeats (body-colour textures), or None
    thread : Int32, the index of the yarn hit in the tiled fabric (its column for a warp, its
        row for a weft; :mod:`weavecap.model.threads`), for per-thread colours, or None
    """

    shape: tuple[int, int]
    spp: int
    hit: object
    is_warp: object
    uv: object
    wv: object
    wl: list
    lit: list
    ao: object
    fabric_uv: object = None
    thread: object = None

    @property
    def size(self) -> int:
        return self.shape[0] * self.shape[1] * self.spp


def geometry_pass(fs: FabricScene, *, spp: int, seed: int) -> GBuffer:
    """Cast the camera, shadow and exit-point rays of the module's integrator, and evaluate."""
    scene = fs.scene
    with dr.suspend_grad():
        ray, shape = _camera_rays(fs, spp, seed)
        si = scene.ray_intersect(ray)
        hit = si.is_valid()
        view_side = dr.dot(si.n, -ray.d) > 0.0
        wl, lit = [], []
        for light in fs.rig.lights:
            d = mi.Vector3f(*light.direction)
            same_side = (dr.dot(si.n, d) > 0.0) == view_side
            front_blocked = scene.ray_test(si.spawn_ray(d), hit & same_side)
            if light.direction[2] < 0.0:
                # a back light reaches the viewer only through the yarn: exit-point rays.
                # Front lights skip them (what they send through a tube's flank is a few %
                # of a dim grazing lobe), so a front-only rig does no transmission work.
                exit_si = scene.ray_intersect(si.spawn_ray(d), hit & ~same_side)
                back_blocked = scene.ray_test(exit_si.spawn_ray(d), hit & ~same_side & exit_si.is_valid())
                visible = dr.select(same_side, ~front_blocked, ~back_blocked)
            else:
                visible = same_side & ~front_blocked
            wl.append(si.to_local(d))
            lit.append(hit & visible)
        ao = ambient_occlusion(si.p.z, tuple(dr.opaque(mi.Float, z) for z in fs.z_range))  # as ``top``
        fabric_uv = None
        if fs.textures:
            n_e, n_a = fs.fabric.shape
            fabric_uv = mi.Point2f(si.p.x / (n_a * PITCH), si.p.y / (n_e * PITCH))
        is_warp = si.shape == fs.warp_shape
        thread = None
        if fs.threads:  # warp j lies in x ∈ [j, j + 1) pitches, weft i in y ∈ [i, i + 1)
            thread = mi.Int32(dr.floor(dr.select(is_warp, si.p.x, si.p.y) / PITCH))
        g = GBuffer(shape=shape, spp=spp, hit=hit, is_warp=is_warp, uv=mi.Point2f(si.uv),
                    wv=mi.Vector3f(si.wi), wl=wl, lit=lit, ao=ao, fabric_uv=fabric_uv, thread=thread)
        dr.eval(g.hit, g.is_warp, g.uv, g.wv, g.wl, g.lit, g.ao, g.fabric_uv, g.thread)
    return g


def _broadcast(value, size: int):
    """``value`` (width 1) as an array of ``size`` entries, by a gather: its gradient then comes
    back through one scatter-add instead of a reduction per use (one backward kernel, not
    hundreds). A value already ``size`` wide (a per-sample gradient leaf) passes through."""
    if dr.width(value) == size:
        return value
    return dr.gather(type(value), value, dr.zeros(mi.UInt32, size))


def _body_colours(fs: FabricScene, g: GBuffer):
    """R^B and S^B at each hit: the warp's or the weft's colour, their textures, or the colour
    of the thread hit where the family has a colour order (:mod:`weavecap.model.threads`)."""
    per_yarn = {}
    for yarn in ("warp", "weft"):
        table = fs.threads.get(yarn)
        if table is not None:
            per_yarn[yarn] = table.at(g.thread)
            continue
        colours = []
        for key in ("body_reflection", "body_subsurface"):
            dotted = f"{yarn}.{key}"
            tex = fs.textures.get(dotted)
            colours.append(_broadcast(fs.values[dotted], g.size) if tex is None else mi.Color3f(tex.eval(g.fabric_uv)))
        per_yarn[yarn] = colours
    return [dr.select(g.is_warp, per_yarn["warp"][k], per_yarn["weft"][k]) for k in range(2)]


def shade(fs: FabricScene, g: GBuffer):
    """Radiance of each camera sample (Color3f): the lights and the ambient term through the
    BYSDF, with the current (possibly gradient-tracked) values of ``fs``."""
    p = _bysdf.Shading(**{k: _broadcast(v, g.size) for k, v in vars(fs.shading()).items()})
    body_r, body_s = _body_colours(fs, g)
    result = mi.Color3f(0.0)
    for light, wl, lit in zip(fs.rig.lights, g.wl, g.lit):
        f = _bysdf.eval_bysdf(p, body_r, body_s, g.uv, g.wv, wl)
        result += dr.select(lit, light.irradiance * f, 0.0)
    result += fs.rig.ambient * g.ao * _bysdf.albedo_bysdf(p, body_r, body_s, g.uv, g.wv.z)
    gain = mi.Color3f(*fs.rig.gain)  # the rig as the camera recorded it (exposure × white balance)
    dr.make_opaque(gain)  # a kernel input: a new gain compiles nothing
    return dr.select(g.hit, result, mi.Color3f(fs.rig.backdrop)) * gain


def gbuffer(fs: FabricScene, *, spp: int, seed: int) -> GBuffer:
    """The scene's G-buffer for ``spp`` and ``seed``, cached with its geometry (a radius or
    pattern set by :meth:`FabricScene.set` switches to that geometry's cache)."""
    key = (spp, seed)
    if key not in fs.cache:
        fs.cache.clear()
        fs.cache[key] = geometry_pass(fs, spp=spp, seed=seed)
    return fs.cache[key]


def render(fs: FabricScene, *, seed: int = 0, spp: int | None = None):
    """Render to a Dr.Jit tensor of shape (H, W, 3), linear RGB, differentiable with respect
    to every value in ``fs.values`` that has gradients enabled."""
    spp = int(spp or fs.view.spp)
    g = gbuffer(fs, spp=spp, seed=seed)
    colour = shade(fs, g)
    height, width = g.shape
    if spp > 1:
        dr.eval(colour)  # one kernel for the three channels
        colour = mi.Color3f(*(dr.block_sum(channel, spp) / spp for channel in colour))
    return mi.TensorXf(dr.ravel(colour), shape=(height, width, 3))


def render_numpy(fs: FabricScene, *, seed: int = 0, spp: int | None = None) -> np.ndarray:
    """:func:`render` as a float32 numpy array (H, W, 3), linear RGB."""
    with dr.suspend_grad():
        return np.array(render(fs, seed=seed, spp=spp), dtype=np.float32)


def blur(image: np.ndarray, sigma_px: float) -> np.ndarray:
    """A Gaussian blur of a one-repeat image (H, W, 3) of σ ``sigma_px``, wrapping around (the
    repeat tiles): what §4.2's regularization does to the photo a render is compared with."""
    if sigma_px <= 0:
        return image
    return gaussian_filter(image, (sigma_px, sigma_px, 0), mode="wrap")


def white_level(target: np.ndarray) -> float:
    """The level at which the camera that took ``target`` saturated: 1 for a normalised
    low-dynamic-range photo (no pixel above 1), none (inf) for a high-dynamic-range one."""
    return 1.0 if float(np.max(target)) <= 1.0 else float("inf")


def as_photographed(image: np.ndarray, blur_px: float, white: float = 1.0) -> np.ndarray:
    """A render (H, W, 3) as the photo shows it: clipped at the sensor's ``white`` level, then
    blurred by :func:`blur`. Back-lit gaps and clear yarns render far above 1 (4 on a pale
    satin), while the photo clips them; compared unclipped, they cost the true parameters of
    a synthetic satin 8 12 dB (11.8 against 24.0 dB)."""
    return blur(np.minimum(image, white), blur_px)


def blurred_mse(image: np.ndarray, target: np.ndarray, blur_px: float = 0.0) -> float:
    """MSE (float64) between ``image`` as photographed (:func:`as_photographed` at the white
    level of ``target``) and ``target``, both (H, W, 3)."""
    shown = as_photographed(image, blur_px, white_level(target))
    return float(np.mean(np.square(shown.astype(np.float64) - target)))


def radius_gradient(fs: FabricScene, target: np.ndarray, key: str, *, seed: int = 0, spp: int | None = None,
                    blur_px: float = 0.0, step: float = 0.02) -> float:
    """d MSE / d radius (``warp.radius`` or ``weft.radius``) by a central finite difference of
    ``step`` world units; the geometry is rebuilt at both ends and restored. Ray-cast geometry
    has no smooth derivative at the silhouettes that a radius mostly moves, so a difference
    over a small step is both simpler and more faithful here than edge-sampling AD."""
    r0 = float(fs.fabric.get(key))
    lo, hi = FIT_RANGES[key]
    a, b = max(lo, r0 - step), min(hi, r0 + step)
    losses = []
    for r in (a, b):
        fs.set(key, r)
        losses.append(blurred_mse(render_numpy(fs, seed=seed, spp=spp), target, blur_px))
    fs.set(key, r0)
    return (losses[1] - losses[0]) / (b - a)


def mse_and_gradients(fs: FabricScene, target: np.ndarray, keys, *, seed: int = 0,
                      spp: int | None = None, blur_px: float = 0.0) -> tuple[float, dict[str, np.ndarray], np.ndarray]:
    """MSE between a render as photographed (:func:`as_photographed`: clipped at the white
    level of ``target``, blurred by σ ``blur_px``) and ``target`` (H, W, 3), and its gradient
    for each dotted key of :data:`weavecap.params.FIT_RANGES` in ``keys`` (reverse-mode AD;
    radii by :func:`radius_gradient`). The blur is linear and symmetric, so the loss's adjoint
    image is the blurred residual, zero where the render is clipped, and reverse mode runs
    from it (``dr.backward`` of Σ image · adjoint).

    Returns
    -------
    loss : float
    grads : dict key → float64 array (shape (1,) for scalars, (3,) for colours)
    image : (H, W, 3) float32, the render (not blurred)
    """
    keys = list(keys)
    ad_keys = [k for k in keys if k not in GEOMETRY_KEYS]
    target = np.asarray(target, dtype=np.float32)
    spp_ = int(spp or fs.view.spp)
    size = gbuffer(fs, spp=spp_, seed=seed).size
    # Each parameter becomes a per-sample leaf: the backward pass is then element-wise and the
    # per-sample gradients are summed here in float64, in a fixed order. (Summing in Dr.Jit
    # uses threaded atomics whose order varies, and a fit must be the same for the same seed.)
    saved = {key: fs.values[key] for key in ad_keys}
    leaves = {key: _broadcast(dr.detach(value), size) for key, value in saved.items()}
    try:
        fs.values.update(leaves)
        for leaf in leaves.values():
            dr.enable_grad(leaf)
        image = render(fs, seed=seed, spp=spp_)
        image_np = np.array(dr.detach(image), dtype=np.float32)
        white = white_level(target)
        residual = as_photographed(image_np, blur_px, white).astype(np.float64) - target
        if ad_keys:
            adjoint = (blur(residual * (2.0 / residual.size), blur_px) * (image_np < white)).astype(np.float32)
            dr.backward(dr.sum(image * mi.TensorXf(adjoint), axis=None))
        adjoints = {key: dr.grad(leaf) for key, leaf in leaves.items()}
        dr.eval(adjoints)  # one backward kernel for all of them
        grads = {key: np.array(adj, dtype=np.float64).reshape(-1, size).sum(axis=1) for key, adj in adjoints.items()}
    finally:
        fs.values.update(saved)
    loss_value = float(np.mean(np.square(residual)))
    for key in keys:
        if key in GEOMETRY_KEYS:
            grads[key] = np.array([radius_gradient(fs, target, key, seed=seed, spp=spp, blur_px=blur_px)])
    return loss_value, {key: grads[key] for key in keys}, image_np
