"""The woven renderer's section of ``weavecap bench --render``: quality and speed, measured.

Scene: a flat sheet of the fabric (UVs in metres, the face up), a perspective camera at
ELEVATION_DEG above it, one directional light (the key light of the ``studio`` rig) and a dark
backdrop seen through the gaps. A view is set by how many pixels one repeat covers at the
image centre (√ of its footprint's area): from ``close`` (40 px a repeat) to ``far`` (5
repeats a pixel). The fabrics: two the network was trained on (fixtures), and four it never
saw: two random fabrics of seeds the training never drew, the fixture whose pattern is
replaced by a random 7×5 one, and one captured by ``weavecap fit`` from a real photo
(``fixtures/params/w092_fit.json``).

For each fabric and view (SIZE² pixels):

- truth: the direct-lighting reference (:class:`weavecap.render.bsdf.SurfaceBSDF` with the
  ``weavecap_path`` integrator at ``max_depth=2``, as ``--mode direct``) at TRUTH_SPP;
- neural: :class:`.bsdf.NeuralSurfaceBSDF` with ``fabric_direct`` at one sample a pixel;
- the reference at 1 spp, at equal time, and at REF_SPPS, other seeds than the truth's; its
  MSE against spp is interpolated (log–log) to the spp where it reaches the neural MSE
  (extrapolated with MSE ∝ 1/spp past the last), and that spp's time over the neural time is
  the speed-up at equal error.

Times are frame times (:func:`frame_costs`, per fabric, side by side in one process): a
1280×720 frame of the close view, warm (median of TIMED_FRAMES after one), of the neural
renderer at 1 spp, of the reference at 1 and FRAME_SPP spp (a call's fixed cost plus a
sample's), and of a plain diffuse-textured sheet (Mitsuba's ``diffuse`` with the fabric's
colour texture, ``direct``) at 1 spp; the equal-time spp is what the reference renders in the
neural frame's time. (A 96² render's time is mostly a call's overhead, for both.) Also the
encoder per fabric, the weights' size and a white furnace test of the network (its
hemispherical albedo, reflection plus transmission, ≤ 1.05).
"""

from __future__ import annotations

import math
import statistics
import time
from dataclasses import dataclass

import numpy as np

from ..params import Fabric

ELEVATION_DEG = 55.0  # camera above the sheet's plane
FOV_DEG = 30.0
SIZE = 96  # pixels a side of the quality views
TRUTH_SPP = 1024
REF_SPPS = (1, 4, 16, 64, 256)
PITCH_M = 1e-3  # the yarn pitch in the scene (the views scale with it)
KEY_LIGHT = ((-0.55, 0.55, 0.65), 3.0)  # studio's key: direction towards it (sheet frame), irradiance
BACKDROP = 0.02
TIMED_FRAMES = 3
FRAME = (1280, 720)
FRAME_SPP = 16  # the reference's second timed frame


from ..render.woven import PIXEL_CENTRES as NEURAL_SAMPLER  # noqa: E402


@dataclass(frozen=True)
class View:
    """A view of the sheet: ``pixels_per_repeat`` at the image centre."""

    name: str
    pixels_per_repeat: float


VIEWS = (View("close", 40.0), View("near", 10.0), View("mid", 2.5), View("yarn", 0.6), View("far", 0.2))


# ---------------------------------------------------------------------------------------------
# the scene


def _mi():
    from ..render.woven import terms as _terms

    return _terms._backend()


def sheet_mesh(bsdf, half_extent: float):
    """A square sheet in z = 0 (normal +z, the fabric's face), UVs = positions (metres)."""
    mi, _ = _mi()
    h = float(half_extent)
    positions = np.array([[-h, -h, 0.0], [h, -h, 0.0], [h, h, 0.0], [-h, h, 0.0]], dtype=np.float32)
    props = mi.Properties()
    props["bsdf"] = bsdf
    mesh = mi.Mesh("sheet", 4, 2, props=props, has_vertex_normals=True, has_vertex_texcoords=True)
    params = mi.traverse(mesh)
    params["vertex_positions"] = mi.Float(positions.ravel())
    params["faces"] = mi.UInt32(np.array([0, 1, 2, 0, 2, 3], dtype=np.uint32))
    params["vertex_normals"] = mi.Float(np.tile([0.0, 0.0, 1.0], 4).astype(np.float32))
    params["vertex_texcoords"] = mi.Float((positions[:, :2] + 0.0).ravel())
    params.update()
    return mesh


def camera_distance(view: View, repeat_m: float, width_px: int) -> float:
    """Distance from the sheet's centre at which one repeat covers ``view.pixels_per_repeat``
    pixels (√ of the centre pixel's footprint area) for an image ``width_px`` wide."""
    pixel_angle = 2.0 * math.tan(math.radians(FOV_DEG) / 2.0) / width_px
    cos_view = math.sin(math.radians(ELEVATION_DEG))
    footprint = repeat_m / view.pixels_per_repeat  # side of the centre pixel's footprint, metres
    return footprint * math.sqrt(cos_view) / pixel_angle


def scene(bsdf, integrator: dict, view: View, repeat_m: float, size: tuple[int, int], spp: int, *,
          sampler: dict | None = None):
    """The Mitsuba scene of the sheet under the key light, seen from ``view`` (``sampler``:
    the sensor's, default independent)."""
    mi, _ = _mi()
    d = camera_distance(view, repeat_m, size[0])
    el = math.radians(ELEVATION_DEG)
    origin = [0.0, -d * math.cos(el), d * math.sin(el)]
    sensor = {"type": "perspective", "fov": FOV_DEG, "fov_axis": "x", "near_clip": d * 1e-3, "far_clip": d * 100.0,
              "to_world": mi.ScalarTransform4f().look_at(origin=origin, target=[0, 0, 0], up=[0, 0, 1]),
              "film": {"type": "hdrfilm", "width": int(size[0]), "height": int(size[1]), "rfilter": {"type": "box"},
                       "pixel_format": "rgb"},
              "sampler": dict(sampler or {"type": "independent"}, sample_count=int(spp))}
    direction, irradiance = KEY_LIGHT
    light = {"type": "directional", "direction": [-c for c in direction],
             "irradiance": {"type": "rgb", "value": [irradiance] * 3}}
    return mi.load_dict({"type": "scene", "integrator": integrator, "sensor": sensor, "light": light,
                         "sheet": sheet_mesh(bsdf, 8.0 * d)})


def placement_of(fabric: Fabric):
    from ..render.bsdf import Placement

    n_e, n_a = fabric.shape
    return Placement(repeat_size=(n_a * PITCH_M, n_e * PITCH_M))


def reference_integrator() -> dict:
    from ..render import integrator as _integrator  # noqa: F401  (registers "weavecap_path")

    return {"type": "weavecap_path", "max_depth": 2, "rr_depth": 5, "background": BACKDROP}


def neural_integrator() -> dict:
    from ..render import direct as _direct  # noqa: F401  (registers "fabric_direct")

    return {"type": "fabric_direct", "background": BACKDROP}


def plain_bsdf(maps, fabric: Fabric):
    """Mitsuba's ``diffuse`` with the fabric's mean body colour per texel (warp/weft by the
    warp share, times coverage) as a bitmap texture over one repeat."""
    mi, _ = _mi()
    from ..render.woven.terms import fabric_colours

    c = fabric_colours(fabric)
    w = maps.warp[0][..., None]
    colour = (w * np.asarray(c["warp_reflection"]) + (1 - w) * np.asarray(c["weft_reflection"])) * maps.coverage[0][..., None]
    n_e, n_a = fabric.shape
    to_uv = mi.ScalarTransform4f().scale([1.0 / (n_a * PITCH_M), -1.0 / (n_e * PITCH_M), 1.0])
    return mi.load_dict({"type": "diffuse", "reflectance": {
        "type": "bitmap", "bitmap": mi.Bitmap(np.ascontiguousarray(colour, dtype=np.float32)), "raw": True,
        "filter_type": "nearest", "wrap_mode": "repeat", "to_uv": to_uv}})


def render(scene_, spp: int, seed: int) -> tuple[np.ndarray, float]:
    """(image (H, W, 3) float32, seconds)."""
    mi, dr = _mi()
    t = time.perf_counter()
    image = np.array(mi.render(scene_, spp=spp, seed=seed), dtype=np.float32)
    return image, time.perf_counter() - t


def mse(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.mean((np.asarray(a, np.float64) - np.asarray(b, np.float64)) ** 2))


def spp_to_reach(spps: list[int], errors: list[float], target: float) -> tuple[float, bool]:
    """The spp at which the reference's MSE (measured at ``spps``) reaches ``target``:
    log–log interpolation between the measurements that bracket it; past the last, MSE ∝
    1/spp from it (second value True: extrapolated)."""
    s, e = np.log(np.asarray(spps, float)), np.log(np.maximum(np.asarray(errors, float), 1e-30))
    t = math.log(max(target, 1e-30))
    if t >= e[0]:
        return float(spps[0]) * math.exp(e[0] - t) if t > e[0] else float(spps[0]), False
    for k in range(1, len(s)):
        if t >= e[k]:
            f = (t - e[k - 1]) / (e[k] - e[k - 1])
            return float(math.exp(s[k - 1] + f * (s[k] - s[k - 1]))), False
    return float(spps[-1]) * math.exp(e[-1] - t), True


# ---------------------------------------------------------------------------------------------
# the fabrics


BENCH_SEED = 90210  # the unseen random fabrics' generator (the training draws [seed, shard, 0])


def bench_fabrics() -> list[tuple[str, bool, Fabric]]:
    """(name, seen in training, fabric): two fixtures the data starts with, two random
    fabrics from a generator the training never used, and a capture of a real photo."""
    from .. import params
    from ..estimate.sampling import random_fabric, random_pattern
    from ..fixtures import path as fixture_path

    out = [("plain (fixture)", True, params.load(fixture_path("params", "plain.json"))),
           ("satin 5 (fixture)", True, params.load(fixture_path("params", "satin_5.json")))]
    rng = np.random.default_rng(BENCH_SEED)
    for family in ("twill", "random"):
        _, pattern = random_pattern(rng, family=family)
        n_e, n_a = pattern.shape
        out.append((f"{family} {n_e}x{n_a} (random)", False, random_fabric(rng, pattern)))
    out.append(("W092 plain (fit of a real photo)", False, params.load(fixture_path("captured", "w092_plain_fit.json"))))
    return out


def _surface_bsdf(fabric, maps, linear: bool):
    from ..render.bsdf import SurfaceBSDF

    return SurfaceBSDF(fabric, maps, placement_of(fabric), linear=linear)


def frame_costs(fabric: Fabric, maps, *, frames: int = TIMED_FRAMES) -> dict:
    """Warm FRAME-sized frame times of the close view, side by side: the neural renderer at
    1 spp, the reference at 1 and FRAME_SPP spp (its time is then ``a + b · spp``: a call's
    fixed cost and a sample's), ``--mode direct``'s integrator with the surface model at 1 spp,
    and a plain diffuse-textured direct render at 1 spp. Times
    are taken at frame size, where the per-pixel work (not a call's overhead, which is most of
    a 96² render's time) decides them."""
    from ..render.woven.bsdf import NeuralSurfaceBSDF

    n_e, n_a = fabric.shape
    repeat = max(n_e, n_a) * PITCH_M
    view = VIEWS[0]
    cases = {"neural": (NeuralSurfaceBSDF(fabric, maps, placement_of(fabric)), neural_integrator(), NEURAL_SAMPLER, 1),
             "reference_1": (_surface_bsdf(fabric, maps, True), reference_integrator(), None, 1),
             f"reference_{FRAME_SPP}": (_surface_bsdf(fabric, maps, True), reference_integrator(), None, FRAME_SPP),
             "direct": (_surface_bsdf(fabric, maps, True), neural_integrator(), None, 1),
             "plain": (plain_bsdf(maps, fabric), {"type": "direct"}, None, 1)}
    out = {"size": list(FRAME)}
    for name, (bsdf, integrator, sampler, spp) in cases.items():
        sc = scene(bsdf, integrator, view, repeat, FRAME, spp, sampler=sampler)
        _, cold = render(sc, spp, seed=0)
        out[f"{name}_cold_s"] = cold
        out[f"{name}_warm_s"] = statistics.median(render(sc, spp, seed=k + 1)[1] for k in range(frames))
    t1, tn = out["reference_1_warm_s"], out[f"reference_{FRAME_SPP}_warm_s"]
    out["reference_per_spp_s"] = max((tn - t1) / (FRAME_SPP - 1), 1e-9)
    out["reference_fixed_s"] = max(t1 - out["reference_per_spp_s"], 0.0)
    out["ratio_to_plain"] = out["neural_warm_s"] / out["plain_warm_s"]
    out["direct_ratio_to_plain"] = out["direct_warm_s"] / out["plain_warm_s"]
    out["equal_time_spp"] = max(1, int((out["neural_warm_s"] - out["reference_fixed_s"]) / out["reference_per_spp_s"]))
    return out


def measure_view(fabric: Fabric, maps, view: View, costs: dict, *, size: int = SIZE,
                 truth_spp: int = TRUTH_SPP) -> dict:
    """Every figure of one fabric and view (module docstring), and the images; ``costs``:
    :func:`frame_costs` of the fabric (the equal-time spp and the speed-up use them)."""
    from ..render.woven.bsdf import NeuralSurfaceBSDF

    n_e, n_a = fabric.shape
    repeat = max(n_e, n_a) * PITCH_M
    px = (size, size)
    pixels_per_texel = view.pixels_per_repeat / (max(n_e, n_a) * maps.texels_per_yarn)
    ref_scene = scene(_surface_bsdf(fabric, maps, pixels_per_texel >= 0.5), reference_integrator(), view, repeat, px, 16)
    neural_scene = scene(NeuralSurfaceBSDF(fabric, maps, placement_of(fabric)), neural_integrator(), view, repeat, px, 1,
                         sampler=NEURAL_SAMPLER)
    truth, truth_s = render(ref_scene, truth_spp, seed=1)
    render(neural_scene, 1, seed=0)  # compile
    neural, neural_s = render(neural_scene, 1, seed=0)
    errors, times, images = [], [], {}
    for k, spp in enumerate(REF_SPPS):
        image, seconds = render(ref_scene, spp, seed=10 + k)
        errors.append(mse(image, truth))
        times.append(seconds)
        images[spp] = image
    equal_spp = costs["equal_time_spp"]
    equal, _ = render(ref_scene, equal_spp, seed=99)
    neural_mse = mse(neural, truth)
    reach, extrapolated = spp_to_reach(list(REF_SPPS), errors, neural_mse)
    reach_s = costs["reference_fixed_s"] + costs["reference_per_spp_s"] * reach
    return {"view": view.name, "pixels_per_repeat": view.pixels_per_repeat, "size": size, "truth_spp": truth_spp,
            "truth_seconds": truth_s, "neural_mse": neural_mse, "neural_seconds": neural_s,
            "reference_mse": dict(zip(map(str, REF_SPPS), errors)), "reference_seconds": dict(zip(map(str, REF_SPPS), times)),
            "equal_time_spp": equal_spp, "equal_time_mse": mse(equal, truth),
            "spp_to_reach_neural": reach, "extrapolated": extrapolated,
            "speedup_at_equal_error": reach_s / costs["neural_warm_s"],
            "images": {"truth": truth, "neural": neural, "reference_1spp": images[1], "equal_time": equal}}


def white(fabric: Fabric) -> Fabric:
    """``fabric`` with every colour 1 (body and specular), for the furnace test."""
    one = [1.0, 1.0, 1.0]
    return fabric.replace({"warp.body_reflection": one, "weft.body_reflection": one, "warp.body_subsurface": one,
                           "weft.body_subsurface": one, "specular.reflection": one, "specular.transmission": one,
                           "specular.transmission_exit": one})


def furnace(fabric: Fabric, maps, *, views: int = 6, directions: int = 64, seed: int = 0) -> dict:
    """The white fabric's hemispherical albedo (reflection + transmission: ∫ f |cos| dω over
    the sphere, stratified) under the network and under the surface model, at random
    footprints (points to repeats) and view directions; the largest of each."""
    from ..render.bsdf import SurfaceTextures, eval_surface, shading_of
    from ..render.woven.bsdf import NeuralSurfaceBSDF
    from ..training.woven import stratified_hemisphere

    mi, dr = _mi()
    fabric = white(fabric)
    rng = np.random.default_rng(seed)
    bsdf = NeuralSurfaceBSDF(fabric, maps, placement_of(fabric))
    textures = SurfaceTextures(maps)
    shading, colours = shading_of(fabric)
    up = stratified_hemisphere(rng, directions)
    sphere = np.concatenate([up, up * np.array([1.0, 1.0, -1.0])])  # cosine-distributed: pdf |cos|/π per half
    n_dirs = len(sphere)
    worst_net, worst_ref = 0.0, 0.0
    f = lambda a: mi.Float(np.ascontiguousarray(a, dtype=np.float32))  # noqa: E731
    for _ in range(views):
        wi = stratified_hemisphere(rng, 1)[0]
        s, t = rng.random(2)
        size = float(np.exp(rng.uniform(np.log(0.05), np.log(5 * max(fabric.shape)))))
        rep = lambda v: mi.Vector3f(*(f(np.full(n_dirs, c)) for c in v))  # noqa: E731
        wo = mi.Vector3f(*(f(sphere[:, k]) for k in range(3)))
        value = bsdf.query(f(np.full(n_dirs, s)), f(np.full(n_dirs, t)), f(np.full(n_dirs, size)), rep(wi), wo,
                           mi.Bool(np.zeros(n_dirs, dtype=bool)))
        cos = np.abs(sphere[:, 2])
        weight = np.where(cos > 1e-6, np.pi / np.maximum(cos, 1e-6), 0.0) / len(up)  # 1/pdf per direction, per half
        albedo = (np.array(value).T * weight[:, None]).sum(axis=0)
        worst_net = max(worst_net, float(albedo.max()))
        point = textures.lookup(f(np.full(n_dirs, s)), f(np.full(n_dirs, t)), mi.Bool(False))
        ref = np.array(eval_surface(shading, colours, point, rep(wi), wo)).T
        worst_ref = max(worst_ref, float((ref * weight[:, None]).sum(axis=0).max()))
    return {"neural_max_albedo": worst_net, "surface_model_max_albedo": worst_ref}


def encoder_time(fabric: Fabric, maps, *, calls: int = 5) -> float:
    """Median seconds to encode one fabric (both sides) from its maps, after one call."""
    from ..render.woven.bsdf import shared_model

    _, _, encoder = shared_model()
    times = []
    for k in range(calls + 1):
        encoder._cache.clear()
        t = time.perf_counter()
        encoder.encode(maps, fabric)
        times.append(time.perf_counter() - t)
    return statistics.median(times[1:])


def run(*, views=VIEWS, size: int = SIZE, truth_spp: int = TRUTH_SPP, fabrics=None, progress=None) -> dict:
    """The whole section: per fabric and view the quality figures, the done-when criteria,
    the frame times, the encoder time, the weights' size and the furnace test. Images are
    returned under ``"images"`` (fabric name → view name → dict)."""
    from ..render.surface import bake
    from ..render.woven.infer import weights_path

    say = progress or (lambda message: None)
    rows, images, encoders, furnaces, costs = [], {}, [], [], {}
    fabrics = bench_fabrics() if fabrics is None else fabrics
    for name, seen, fabric in fabrics:
        maps = bake(fabric, texels_per_yarn=16)
        encoders.append(encoder_time(fabric, maps))
        furnaces.append(furnace(fabric, maps))
        say(f"woven bench: {name}, {FRAME[0]}x{FRAME[1]} frame times")
        costs[name] = frame_costs(fabric, maps)
        images[name] = {}
        for view in views:
            say(f"woven bench: {name}, {view.name} view")
            result = measure_view(fabric, maps, view, costs[name], size=size, truth_spp=truth_spp)
            images[name][view.name] = result.pop("images")
            rows.append({"fabric": name, "seen": seen, **result})
    frames = costs[fabrics[0][0]]
    by_fabric = {}
    for r in rows:
        by_fabric.setdefault(r["fabric"], []).append(r)
    moire = {f: rs[-1]["neural_mse"] <= rs[0]["neural_mse"] for f, rs in by_fabric.items()}
    criteria = {
        "neural_below_reference_1spp_every_view": all(r["neural_mse"] < r["reference_mse"]["1"] for r in rows),
        "neural_below_equal_time_share": float(np.mean([r["neural_mse"] < r["equal_time_mse"] for r in rows])),
        "no_moire_far_not_worse_than_close": all(moire.values()),
        "speedup_at_equal_error_min": float(min(r["speedup_at_equal_error"] for r in rows)),
        "speedup_at_equal_error_median": float(np.median([r["speedup_at_equal_error"] for r in rows])),
        "frame_ratio_to_plain": float(max(c["ratio_to_plain"] for c in costs.values())),
        "weights_mb": weights_path().stat().st_size / 1e6,
        "encoder_ms_max": 1000.0 * max(encoders),
        "furnace_max": max(f["neural_max_albedo"] for f in furnaces),
    }
    return {"views": rows, "frames": frames, "frame_costs": costs, "encoder_seconds": dict(zip([f[0] for f in fabrics], encoders)),
            "furnace": dict(zip([f[0] for f in fabrics], furnaces)), "moire": moire, "criteria": criteria,
            "images": images}


def table(results: dict) -> str:
    """The section as text: one line per fabric and view, then the criteria."""
    lines = ["woven neural renderer (Chen et al. 2024) against the direct reference at "
             f"{results['views'][0]['truth_spp']} spp, {results['views'][0]['size']}² px views:",
             f"{'fabric':34} {'view':6} {'px/rep':>6} {'neural':>9} {'ref 1spp':>9} {'ref eq.t':>9} {'eq.spp':>6} "
             f"{'spp=neural':>10} {'speed-up':>8}"]
    for r in results["views"]:
        lines.append(f"{r['fabric'][:34]:34} {r['view']:6} {r['pixels_per_repeat']:6.1f} {r['neural_mse']:9.2e} "
                     f"{r['reference_mse']['1']:9.2e} {r['equal_time_mse']:9.2e} {r['equal_time_spp']:6d} "
                     f"{r['spp_to_reach_neural']:10.1f}{'+' if r['extrapolated'] else ' '} "
                     f"{r['speedup_at_equal_error']:8.1f}")
    c, fr = results["criteria"], results["frames"]
    lines += ["",
              f"neural below the reference at 1 spp on every view: {c['neural_below_reference_1spp_every_view']}",
              f"neural below the reference at equal time: {100 * c['neural_below_equal_time_share']:.0f}% of views",
              f"no moire (farthest view's error <= nearest's), every fabric: {c['no_moire_far_not_worse_than_close']}",
              f"time for the reference to reach the neural MSE / neural time: min {c['speedup_at_equal_error_min']:.1f}x, "
              f"median {c['speedup_at_equal_error_median']:.1f}x ('+': extrapolated past {REF_SPPS[-1]} spp)",
              f"{fr['size'][0]}x{fr['size'][1]} frame of {results['views'][0]['fabric']}, warm: neural "
              f"{fr['neural_warm_s']:.3f} s, plain diffuse direct {fr['plain_warm_s']:.3f} s (ratio "
              f"{fr['ratio_to_plain']:.2f}; worst fabric {c['frame_ratio_to_plain']:.2f}); --mode direct "
              f"{fr['direct_warm_s']:.3f} s a sample (ratio {fr['direct_ratio_to_plain']:.2f}); reference "
              f"{fr['reference_fixed_s']:.3f} s + {fr['reference_per_spp_s']:.3f} s a sample (equal time: "
              f"{fr['equal_time_spp']} spp); cold neural {fr['neural_cold_s']:.2f} s, plain {fr['plain_cold_s']:.2f} s",
              f"weights {c['weights_mb']:.2f} MB; encoder {c['encoder_ms_max']:.1f} ms a fabric (max); "
              f"white furnace (max hemispherical albedo) {c['furnace_max']:.3f}"]
    return "\n".join(lines)


def picture(images: dict, fabric: str, *, scale: int = 2, gain: float = 1.0):
    """A ``PIL.Image``: for each view of ``fabric`` a row reference | neural | reference at
    1 spp | |neural − reference| × 4 (sRGB, each image ``scale``× nearest-neighbour)."""
    from PIL import Image, ImageDraw

    from ..photo import linear_to_srgb

    rows = []
    for view, im in images[fabric].items():
        err = np.abs(im["neural"] - im["truth"]) * 4.0
        rows.append(np.concatenate([im["truth"], im["neural"], im["reference_1spp"], err], axis=1))
    grid = np.concatenate(rows, axis=0) * gain
    srgb = np.clip(np.round(linear_to_srgb(np.clip(grid, 0.0, 1.0)) * 255.0), 0, 255).astype(np.uint8)
    img = Image.fromarray(srgb).resize((srgb.shape[1] * scale, srgb.shape[0] * scale), Image.NEAREST)
    band = 16
    out = Image.new("RGB", (img.width, img.height + band), (24, 24, 24))
    out.paste(img, (0, band))
    draw = ImageDraw.Draw(out)
    w = img.width // 4
    for k, label in enumerate(("reference (direct, truth)", "neural, 1 spp", "reference, 1 spp", "|error| x4")):
        draw.text((k * w + 4, 2), label, fill=(230, 230, 230))
    return out


def write(results: dict, folder) -> list:
    """OUT/woven.json (every figure) and one OUT/woven_<fabric>.png picture a fabric."""
    import json
    from pathlib import Path

    from ..io import atomic_path, atomic_write_text

    folder = Path(folder)
    data = {k: v for k, v in results.items() if k != "images"}
    atomic_write_text(folder / "woven.json", json.dumps(data, indent=1) + "\n")
    written = [folder / "woven.json"]
    for name in results["images"]:
        slug = "".join(c if c.isalnum() else "_" for c in name.split(" (")[0]).strip("_").lower()
        path = folder / f"woven_{slug}.png"
        with atomic_path(path) as tmp:
            picture(results["images"], name).save(tmp, format="PNG")
        written.append(path)
    return written


QUICK_VIEWS = (VIEWS[0], VIEWS[2], VIEWS[-1])


def section_run(quick: bool = False, progress=None) -> dict:
    """The ``woven`` section of :mod:`weavecap.bench.render`: :func:`run` without the images
    (``quick``: the close, mid and far views of one seen and two unseen fabrics)."""
    fabrics = bench_fabrics()
    if quick:
        fabrics = [fabrics[0], fabrics[3], fabrics[4]]
    results = run(views=QUICK_VIEWS if quick else VIEWS, fabrics=fabrics, progress=progress)
    results.pop("images")
    return results


def section_table(results: dict) -> str:
    return "```\n" + table(results) + "\n```"


def _register() -> None:
    from .render import Section, register_section

    register_section(Section("woven", "Woven neural renderer against the direct reference (Chen et al. 2024)",
                             section_run, section_table))


_register()


def main(argv: list[str] | None = None) -> None:
    """``python -m weavecap.bench.woven OUT``: the whole section, with its pictures
    (OUT/woven.json, OUT/woven_<fabric>.png: reference | neural | reference 1 spp | error)."""
    import sys

    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 1:
        raise SystemExit("usage: python -m weavecap.bench.woven OUT")
    results = run(progress=lambda m: print(m, file=sys.stderr, flush=True))
    for path in write(results, argv[0]):
        print(path, file=sys.stderr)
    print(table(results))


if __name__ == "__main__":
    main()
