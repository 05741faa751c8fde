"""Render a :class:`~weavecap.model.scene.FabricScene`, and differentiate image losses.

The integrator is ours, written in Dr.Jit over Mitsuba's ray queries, because the scenes of
§6.4 need only direct light and because a yarn transmits: a back light reaches the viewer
*through* the yarn it hits. Mitsuba's own integrators would find the yarn's far side in the
way of every shadow ray; here the shadow ray of a transmitted light starts at the exit point y
where it leaves the yarn (the point of §3.3's f_y^S), and is blocked only by other yarns.

Per camera sample: one primary ray; per directional light one shadow ray (two for a light
behind the surface); the ambient light as the BYSDF's directional albedo times a height-based
occlusion term (no rays). Everything is deterministic for a given seed; with ``spp = 1`` the
samples sit at pixel centres and the seed plays no part.
"""

from __future__ import annotations

import numpy as np

from . import bysdf as _bysdf
from .geometry import PITCH
from .scene import FabricScene

mi = _bysdf.mi
dr = _bysdf.dr

R2 = 1.32471795724474602596  # plastic number: the R2 low-discrepancy sequence's generator
AO_FLOOR = 0.35  # ambient seen by the lowest yarn points relative to the highest


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
    a = ((px + ox) / width - 0.5) * ext_w  # image coordinates, world units, y down
    b = ((py + oy) / height - 0.5) * ext_h
    theta = np.radians(fs.view.rotate_deg)
    c, si_ = float(np.cos(theta)), float(np.sin(theta))
    cx, cy = fs.frame.center
    fx = cx + c * a - si_ * b  # the fabric point seen there (inverse of a CCW turn in the image)
    fy = cy + si_ * a + c * b
    top = fs.z_range[1] + 1.0
    if fs.view.camera == "orthographic":
        origin = mi.Point3f(fx, fy, top)
        direction = mi.Vector3f(0.0, 0.0, -1.0)
    else:
        eye = fs.frame.eye_height + top
        origin = mi.Point3f(cx, cy, eye)
        direction = dr.normalize(mi.Vector3f(fx - cx, fy - cy, -eye))
    return mi.Ray3f(origin, direction), (height, width)


def _body_colours(fs: FabricScene, si, is_warp):
    """R^B and S^B at each hit: the warp's or the weft's colour, or their textures."""
    n_e, n_a = fs.fabric.shape
    out = []
    for key in ("body_reflection", "body_subsurface"):
        colours = []
        for yarn in ("warp", "weft"):
            dotted = f"{yarn}.{key}"
            tex = fs.textures.get(dotted)
            if tex is None:
                colours.append(fs.values[dotted])
            else:
                uv = mi.Point2f(si.p.x / (n_a * PITCH), si.p.y / (n_e * PITCH))
                colours.append(mi.Color3f(tex.eval(uv)))
        out.append(dr.select(is_warp, colours[0], colours[1]))
    return out


def radiance(fs: FabricScene, ray):
    """Radiance along each camera ray (Color3f), the integrator described in the module."""
    scene = fs.scene
    si = scene.ray_intersect(ray)
    hit = si.is_valid()
    is_warp = si.shape == fs.warp_shape
    body_r, body_s = _body_colours(fs, si, is_warp)
    p = fs.shading()
    wv = si.wi
    view_side = dr.dot(si.n, -ray.d) > 0.0

    result = mi.Color3f(0.0)
    for light in fs.rig.lights:
        d = mi.Vector3f(*light.direction)
        f = _bysdf.eval_bysdf(p, body_r, body_s, si.uv, wv, si.to_local(d))
        same_side = (dr.dot(si.n, d) > 0.0) == view_side
        front_blocked = scene.ray_test(si.spawn_ray(d), hit & same_side)
        exit_si = scene.ray_intersect(si.spawn_ray(d), hit & ~same_side)
        back_blocked = scene.ray_test(exit_si.spawn_ray(d), hit & ~same_side & exit_si.is_valid())
        visible = dr.select(same_side, ~front_blocked, ~back_blocked)
        result += dr.select(hit & visible, light.irradiance * f, 0.0)

    z_lo, z_hi = fs.z_range
    ao = AO_FLOOR + (1.0 - AO_FLOOR) * dr.clip((si.p.z - z_lo) / (z_hi - z_lo), 0.0, 1.0)
    ambient = fs.rig.ambient * ao * _bysdf.albedo_bysdf(p, body_r, body_s, si.uv, wv.z)
    result += dr.select(hit, ambient, 0.0)
    return dr.select(hit, result, mi.Color3f(fs.rig.backdrop))


def render(fs: FabricScene, *, seed: int = 0, spp: int | None = None):
    """Render to a Dr.Jit tensor of shape (H, W, 3), linear RGB, differentiable with respect
    to every value in ``fs.values`` that has gradients enabled."""
    spp = int(spp or fs.view.spp)
    ray, (height, width) = _camera_rays(fs, spp, seed)
    colour = radiance(fs, ray)
    pixels = mi.Color3f(*(dr.block_sum(channel, spp) / spp for channel in colour))
    return mi.TensorXf(dr.ravel(pixels), shape=(height, width, 3))


def render_numpy(fs: FabricScene, *, seed: int = 0, spp: int | None = None) -> np.ndarray:
    """:func:`render` as a float32 numpy array (H, W, 3), linear RGB."""
    with dr.suspend_grad():
        return np.array(render(fs, seed=seed, spp=spp), dtype=np.float32)


def mse_and_gradients(fs: FabricScene, target: np.ndarray, keys, *, seed: int = 0,
                      spp: int | None = None) -> tuple[float, dict[str, np.ndarray], np.ndarray]:
    """MSE between a render and ``target`` (H, W, 3), and its gradient for each dotted key.

    Returns
    -------
    loss : float
    grads : dict key → array (shape (1,) for scalars, (3,) for colours)
    image : (H, W, 3) float32, the render
    """
    keys = list(keys)
    for key in keys:
        dr.enable_grad(fs.values[key])
    try:
        image = render(fs, seed=seed, spp=spp)
        loss = dr.mean(dr.square(image - mi.TensorXf(np.asarray(target, dtype=np.float32))), axis=None)
        dr.backward(loss)
        grads = {key: np.array(dr.ravel(dr.grad(fs.values[key])), dtype=np.float64) for key in keys}
        return float(np.asarray(loss).ravel()[0]), grads, np.array(dr.detach(image), dtype=np.float32)
    finally:
        for key in keys:
            dr.disable_grad(fs.values[key])
