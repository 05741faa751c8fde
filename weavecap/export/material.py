"""The PBR material of a fabric, fitted to its surface model (:mod:`weavecap.render.surface`).

How a physically based yarn model maps to a metal-roughness material is a choice; weavecap
fits it per texel from the surface model's own maps and BSDF (no second model):

- **opacity** — the surface model's coverage (the gaps between yarns are holes);
- **normal** — its mean shading normal (face frame: +x along u, +y up the image: OpenGL);
- **height** — its yarn heights, in millimetres through ``scale.pitch_mm``;
- **roughness** — √α^S: the BYSDF's specular lobe is GGX with α = α^S on the yarn, and the
  metal-roughness convention squares roughness into α;
- **specular** — the yarns' Fresnel reflectance at normal incidence ``F0(η^S)`` times R^S;
- **base colour** — the colour for which the principled BSDF, at the texel's normal, returns
  the same *reflection albedo* as the surface BSDF for a viewer straight above (the capture
  rigs' camera): the surface BSDF's albedo is integrated by sampling its lobes
  (:func:`weavecap.render.bsdf.sample_surface`, reflected directions, neighbours' horizons
  and groove shadowing included), the principled BSDF's (Mitsuba's plugin) for base colour 0
  and 1 at the same view, and since the latter is linear in the base colour the solve is
  exact;
- **transmission** — the light the yarns let through from behind, for the same viewer: the
  same integral over the directions below the fabric (the surface model's transmission lobes
  and exit-point visibility), a colour in [0, 1];
- **translucent base colour** — the base colour for a material that blends a diffuse
  transmission of that colour in (weight :func:`weavecap.export.maps.transmission_weight`): its reflection lobes
  keep 1 − weight, so it is solved for reflection / (1 − weight). Gap texels of every colour
  map take their nearest yarn's value (so filtering and mipmaps do not darken yarn edges).

Left out: the body lobes' angular shape beyond the principled diffuse one (and the
transmission's beyond a Lambertian one), and the §6.3 irregularity noise.
"""

from __future__ import annotations

import math

import numpy as np

from ..params import Fabric
from .maps import PbrMaps, specular_level, transmission_weight

#: stratified samples of the surface BSDF per texel (n × n), and of the principled BSDF per
#: view angle (for its albedo table)
SURFACE_SAMPLES = 12
PRINCIPLED_SAMPLES = 128
ALBEDO_TABLE = 33  # view cosines of the principled albedo table, from MIN_COS to 1
MIN_COS = 0.05
LANES = 1 << 21  # BSDF evaluations per Dr.Jit call (bounds memory)
MIN_COVERAGE = 0.02  # texels less covered than this are gaps: their base colour is their neighbour's


def _mi():
    from ..backend import mitsuba

    return mitsuba()


def _stratified(n: int, count: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """``count`` sets of n² jittered 2D samples and n² shuffled 1D ones (deterministic)."""
    rng = np.random.default_rng(seed)
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    u = (i.ravel()[None] + rng.random((count, n * n))) / n
    v = (j.ravel()[None] + rng.random((count, n * n))) / n
    s1 = (rng.permuted(np.tile(np.arange(n * n), (count, 1)), axis=1) + rng.random((count, n * n))) / (n * n)
    return s1.astype(np.float32), np.stack([u, v], axis=-1).astype(np.float32)


def principled_albedo(*, roughness: float, specular: float, cos_view: np.ndarray, base: float,
                      seed: int = 0) -> np.ndarray:
    """Reflection albedo of Mitsuba's ``principled`` BSDF (metallic 0, grey base colour
    ``base``) on a texel whose mapped normal is at ``cos_view`` (N,) to the view straight
    above: the mean of its sampled weights over PRINCIPLED_SAMPLES² stratified samples, over
    the directions above both the mapped normal's horizon and the swatch's (the view is the
    swatch's normal, so the latter is ``wo · wi > 0``)."""
    mi = _mi()
    import drjit as dr

    bsdf = mi.load_dict({"type": "principled", "base_color": {"type": "rgb", "value": float(base)},
                         "roughness": float(roughness), "metallic": 0.0, "specular": float(specular)})
    n = PRINCIPLED_SAMPLES
    k = len(cos_view)
    s1, s2 = _stratified(n, k, seed)
    cos = np.repeat(np.clip(cos_view, MIN_COS, 1.0), n * n)
    si = dr.zeros(mi.SurfaceInteraction3f, len(cos))
    si.wi = mi.Vector3f(np.sqrt(1.0 - cos**2), 0.0 * cos, cos)
    si.sh_frame = mi.Frame3f(mi.Vector3f(0.0, 0.0, 1.0))
    bs, weight = bsdf.sample(mi.BSDFContext(), si, mi.Float(s1.ravel()), mi.Point2f(s2.reshape(-1, 2).T))
    w = np.array(dr.select((bs.wo.z > 0.0) & (dr.dot(bs.wo, si.wi) > 0.0), weight, 0.0))  # (3, N n²)
    return w.mean(axis=0).reshape(k, n * n).mean(axis=1)


def surface_albedo(fabric: Fabric, surface, *, seed: int = 0,
                   repeats: tuple[int, int] = (1, 1)) -> tuple[np.ndarray, np.ndarray]:
    """(H, W, 3) reflection and transmission albedo of the surface BSDF of the face, per texel
    (its area mean, the maps interpolated as the BSDF interpolates them), for a viewer straight
    above — the light it returns from a uniform sky over the face, and from one behind the
    fabric through the yarns — per unit of covered area (the gaps are the opacity's business),
    over ``repeats`` (rows, columns) of the weave repeat ``surface`` holds (each thread in its
    colour, where the fabric has thread colours)."""
    mi = _mi()
    import drjit as dr

    from ..render.bsdf import SurfaceTextures, sample_surface, shading_of

    shading, colours = shading_of(fabric)
    textures = SurfaceTextures(surface)
    h_one, w_one = surface.shape
    h, w = h_one * repeats[0], w_one * repeats[1]
    n = SURFACE_SAMPLES
    rows_per_call = max(1, LANES // (w * n * n))
    out = np.zeros((2, h, w, 3), np.float32)
    for r0 in range(0, h, rows_per_call):
        r1 = min(h, r0 + rows_per_call)
        rr, cc = np.meshgrid(np.arange(r0, r1), np.arange(w), indexing="ij")
        texels = rr.size
        s1, s2 = _stratified(n, texels, seed + r0)
        # each sample at its own place in the texel: the texel's area average, as a renderer
        # that sees many texels a pixel averages the interpolated maps
        jitter = np.random.default_rng(seed + r0 + 1).random((2, texels * n * n))
        s = ((np.repeat(cc.ravel(), n * n) + jitter[0]) / w_one).astype(np.float32)  # in weave repeats
        t = (1.0 - (np.repeat(rr.ravel(), n * n) + jitter[1]) / h_one).astype(np.float32)
        point = textures.lookup(mi.Float(s), mi.Float(t), mi.Bool(False))
        wi = mi.Vector3f(0.0, 0.0, 1.0)
        wo, pdf, value, _ = sample_surface(shading, colours, point, wi, mi.Float(s1.ravel()),
                                           mi.Point2f(s2.reshape(-1, 2).T))
        ok = pdf > 0.0
        weight = np.array(dr.select(ok, value / dr.select(ok, pdf, 1.0), 0.0)).T.reshape(texels, n * n, 3)
        up = np.array(wo.z > 0.0).reshape(texels, n * n, 1)
        out[0, r0:r1] = np.where(up, weight, 0.0).mean(axis=1).reshape(r1 - r0, w, 3)
        out[1, r0:r1] = np.where(up, 0.0, weight).mean(axis=1).reshape(r1 - r0, w, 3)
    coverage = np.tile(surface.coverage[0], repeats)[..., None]
    out = np.where(coverage > 0.0, out / np.maximum(coverage, 1e-6), 0.0).astype(np.float32)
    return out[0], out[1]


def _fill_gaps(image: np.ndarray, gaps: np.ndarray) -> np.ndarray:
    """``image`` with every gap texel set to its nearest non-gap texel's value, nearest on the
    torus (the tile wraps)."""
    from scipy.ndimage import distance_transform_edt

    if not gaps.any() or gaps.all():
        return image
    h, w = gaps.shape
    tiled = np.tile(gaps, (3, 3))
    _, (ri, ci) = distance_transform_edt(tiled, return_indices=True)
    ri, ci = ri[h:2 * h, w:2 * w] % h, ci[h:2 * h, w:2 * w] % w
    return image[ri, ci]


def roughness_of(fabric: Fabric) -> float:
    """√α^S, α clipped as the BYSDF clips it."""
    from ..model.bysdf import ALPHA_MIN

    return math.sqrt(max(fabric.specular.roughness, ALPHA_MIN))


def pbr_maps(fabric: Fabric, *, pitch_mm: float, texels_per_yarn: int = 16, repeats: int = 1,
             seed: int = 0) -> PbrMaps:
    """Bake the surface model of one repeat and fit the PBR material to it (module docstring).

    Parameters
    ----------
    fabric : the captured fabric
    pitch_mm : yarn spacing, millimetres (``scale.pitch_mm``): the tile is ``n_a · pitch`` wide
    texels_per_yarn : map resolution (lowered for large repeats by the surface model, and for
        the fabric's whole repeat where it has thread colours)
    repeats : repeats of the fabric per tile side: of the weave, or where the fabric has thread
        colours, of its whole repeat (:attr:`weavecap.params.Fabric.full_repeat`, the lcm of the
        weave's and the colour repeats: the colour maps are solved over it, the others are the
        weave repeat's tiled)
    seed : of the stratified samples (the same seed gives the same maps)
    """
    from ..render.surface import FACE, bake, texels_for

    colour_tile = tuple(int(f // n) for f, n in zip(fabric.full_repeat, fabric.shape))  # weave repeats
    surface = bake(fabric, texels_per_yarn=texels_for(fabric.full_repeat, texels_per_yarn))
    coverage = np.tile(surface.coverage[FACE], colour_tile)
    normal = np.tile(surface.normal[FACE], colour_tile + (1,))
    rough = roughness_of(fabric)
    ior, spec_colour = float(fabric.specular.ior), float(np.mean(fabric.specular.reflection))
    level = specular_level(ior, spec_colour)
    cos_table = np.linspace(MIN_COS, 1.0, ALBEDO_TABLE)
    a0 = principled_albedo(roughness=rough, specular=level, cos_view=cos_table, base=0.0, seed=seed)
    a1 = principled_albedo(roughness=rough, specular=level, cos_view=cos_table, base=1.0, seed=seed)
    cos_n = np.clip(normal[..., 2], MIN_COS, 1.0)
    lo, span = np.interp(cos_n, cos_table, a0)[..., None], np.interp(cos_n, cos_table, a1 - a0)[..., None]
    reflection, transmission = surface_albedo(fabric, surface, seed=seed, repeats=colour_tile)
    gaps = coverage < MIN_COVERAGE
    transmission = _fill_gaps(np.clip(transmission, 0.0, 1.0), gaps)
    # a material that also transmits gives its reflection lobes the weight 1 - w
    weight = transmission_weight(transmission)[..., None]
    base = _fill_gaps(np.clip((reflection - lo) / np.maximum(span, 1e-6), 0.0, 1.0), gaps)
    translucent = _fill_gaps(np.clip((reflection / np.maximum(1.0 - weight, 1e-6) - lo) / np.maximum(span, 1e-6),
                                     0.0, 1.0), gaps)
    height = np.tile(surface.height[FACE], colour_tile) * pitch_mm
    h_lo, h_hi = float(height.min()), float(height.max())
    n_e, n_a = fabric.full_repeat
    tile = (repeats, repeats)

    def rep(a: np.ndarray) -> np.ndarray:
        return np.tile(a, tile + (1,) * (a.ndim - 2)).astype(np.float32)

    return PbrMaps(base_color=rep(base), transmission=rep(transmission), translucent_base=rep(translucent),
                   normal=rep(normal), roughness=rep(np.full(coverage.shape, rough)),
                   opacity=rep(np.clip(coverage, 0.0, 1.0)),
                   height=rep((height - h_lo) / max(h_hi - h_lo, 1e-9)), height_mm=h_hi - h_lo,
                   size_mm=(n_a * repeats * pitch_mm, n_e * repeats * pitch_mm),
                   repeats=(repeats * colour_tile[0], repeats * colour_tile[1]),
                   ior=ior, specular=spec_colour)
