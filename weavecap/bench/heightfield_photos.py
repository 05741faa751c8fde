"""Photos of woven fabric with known truth, made WITHOUT weavecap's forward model.

The fit bench of :mod:`weavecap.bench.fit` renders its photos with the model that then fits
them, so it cannot show model mismatch. This module is a second, independent source: it shares
deliberately NO code with :mod:`weavecap.model` (no Algorithm 1 geometry, no BYSDF, no Mitsuba,
no light rig). Its fabric is a height field of yarns evaluated per pixel in numpy:

- each warp j and weft i has its own centre, width and colour (jittered per yarn), and a
  cross-section profile: ``ellipse`` (√(1 − d²)), ``lens`` (1 − d²) or ``flat`` (a
  super-ellipse, 1 − |d|⁴ under a 4th root); it undulates along its length, up where it is on
  top of a crossing and down where it is under, with a cosine between cell centres (floats
  stay up);
- where a warp and a weft both cover a point, the higher surface is seen; where neither does,
  a gap: dark (front light) or the back light seen through (``backlit``), with the yarns'
  thin edges glowing in the light they transmit;
- shading of its own (not the BYSDF): diffuse (Lambert, a key light plus a height-based
  ambient occlusion) and an anisotropic Kajiya–Kay highlight about the yarn's tangent in the
  light's colour; ply striations (helical grooves at a twist angle) and fibre streaks (value
  noise stretched along the yarn);
- then a camera: an in-plane turn, a homography of a camera pitched and yawed a few degrees,
  2×2 supersampling, Gaussian optical blur, unknown exposure (stops) and white balance (gain
  per channel), signal-dependent sensor noise, sRGB encoding and JPEG.

Conventions are weavecap's: ``pattern`` is (wefts, warps), 1 = weft over warp; row i is the
i-th weft from the top of the photo (before the turn), column j the j-th warp from the left;
colours are linear RGB. :func:`bench_specs` is the fit bench's independent set (18 photos);
:func:`write_photo` saves one as JPEG.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

RGB = tuple[float, float, float]
CROSS_SECTIONS = ("ellipse", "lens", "flat")
GAPS = ("dark", "backlit")


@dataclass(frozen=True)
class PhotoSpec:
    """Everything one photo is made from (all lengths in photo pixels at the photo's centre).

    Attributes
    ----------
    name : a label (file stem).
    pattern : (wefts, warps) 0/1, 1 = weft over warp; the photo's minimum repeat.
    warp_colour, weft_colour : linear RGB albedo of each family (before the per-yarn jitter).
    pitch_px : (warp pitch along x, weft pitch along y).
    width : yarn width as a share of its pitch, (warp, weft).
    cross_section : one of :data:`CROSS_SECTIONS`.
    gaps : ``dark`` or ``backlit`` (:data:`GAPS`).
    crimp : how far a yarn dips under a crossing, as a share of its thickness.
    plies, twist_deg, ply_depth : ply striations: grooves per yarn width, their angle to the
        yarn's axis, and how dark the grooves are (0–1).
    fibre_depth : contrast of the fibre streaks (0–1).
    highlight, shininess : strength and exponent of the Kajiya–Kay highlight.
    jitter_position, jitter_width, jitter_colour : per-yarn standard deviations (share of the
        pitch, share of the width, share of each channel).
    light_deg : (azimuth, elevation) of the key light.
    exposure_stops : the camera's exposure error (photo = 2**stops × scene).
    white_balance : gain per channel of the camera's white balance error.
    rotate_deg : in-plane turn of the fabric (counter-clockwise, y down).
    tilt_deg : (pitch, yaw) of the camera away from head-on.
    blur_px : σ of the optical blur; noise : sensor noise σ at mid-grey (linear).
    jpeg_quality : 1–100, or 0 for no JPEG.
    size_px : (height, width) of the photo.
    """

    name: str
    pattern: np.ndarray
    warp_colour: RGB
    weft_colour: RGB
    pitch_px: tuple[float, float] = (30.0, 30.0)
    width: tuple[float, float] = (0.85, 0.85)
    cross_section: str = "ellipse"
    gaps: str = "dark"
    crimp: float = 0.5
    plies: int = 3
    twist_deg: float = 30.0
    ply_depth: float = 0.35
    fibre_depth: float = 0.15
    highlight: float = 0.25
    shininess: float = 40.0
    jitter_position: float = 0.03
    jitter_width: float = 0.05
    jitter_colour: float = 0.04
    light_deg: tuple[float, float] = (-60.0, 55.0)
    exposure_stops: float = 0.0
    white_balance: RGB = (1.0, 1.0, 1.0)
    rotate_deg: float = 0.0
    tilt_deg: tuple[float, float] = (0.0, 0.0)
    blur_px: float = 0.8
    noise: float = 0.01
    jpeg_quality: int = 90
    size_px: tuple[int, int] = (1024, 1024)
    extra: dict = field(default_factory=dict)

    def __post_init__(self):
        p = np.asarray(self.pattern)
        if p.ndim != 2 or p.size < 2 or not np.isin(p, (0, 1)).all():
            raise ValueError(f"{self.name}: pattern must be a 2-D 0/1 array, got shape {p.shape}")
        if self.cross_section not in CROSS_SECTIONS:
            raise ValueError(f"{self.name}: cross_section {self.cross_section!r} is not one of {CROSS_SECTIONS}")
        if self.gaps not in GAPS:
            raise ValueError(f"{self.name}: gaps {self.gaps!r} is not one of {GAPS}")


# ------------------------------------------------------------------------------------ patterns

def twill(over: int, under: int, direction: int = 1) -> np.ndarray:
    """A twill ``over``/``under`` (each weft over ``over`` warps): row i is row 0 moved by
    ``direction`` × i warps (+1 and −1 are the two diagonal directions)."""
    row = np.array([1] * over + [0] * under, dtype=np.uint8)
    return np.stack([np.roll(row, direction * i) for i in range(over + under)])


def satin(n: int, move: int, *, weft_faced: bool = True) -> np.ndarray:
    """An ``n``-end satin moving ``move`` warps a weft; weft-faced (mostly 1) or warp-faced."""
    p = np.ones((n, n), dtype=np.uint8)
    p[np.arange(n), (np.arange(n) * move) % n] = 0
    return p if weft_faced else 1 - p


def basket(k: int) -> np.ndarray:
    """A basket k/k: k × k blocks of a plain weave."""
    return np.kron(np.array([[1, 0], [0, 1]], dtype=np.uint8), np.ones((k, k), dtype=np.uint8))


def _is_minimal(p: np.ndarray) -> bool:
    """No cyclic shift smaller than the shape (along either axis) leaves ``p`` unchanged."""
    n_e, n_a = p.shape
    return (all(not np.array_equal(p, np.roll(p, k, axis=0)) for k in range(1, n_e))
            and all(not np.array_equal(p, np.roll(p, k, axis=1)) for k in range(1, n_a)))


def random_weave(rng: np.random.Generator, shape: tuple[int, int]) -> np.ndarray:
    """A random pattern of ``shape`` in which every yarn interlaces, no float runs longer than
    four cells (a fabric that holds together), and ``shape`` is the minimum repeat."""
    while True:
        p = (rng.random(shape) < 0.5).astype(np.uint8)
        runs_ok = True
        for q in (p, p.T):
            tiled = np.concatenate([q, q], axis=1)
            for row in tiled:
                edges = np.flatnonzero(np.diff(row.astype(int)) != 0)
                if edges.size < 2 or np.diff(edges).max(initial=0) > 4:
                    runs_ok = False
        if runs_ok and _is_minimal(p):
            return p


# ------------------------------------------------------------------------------------ fabric

@dataclass(frozen=True)
class _Yarns:
    """Per-yarn centres, half widths and colours of one family, indexed from -pad."""

    centre: np.ndarray  # (N,) fabric px
    half: np.ndarray  # (N,) fabric px
    colour: np.ndarray  # (N, 3)
    first: int  # yarn index of entry 0


def _yarns(rng, count: int, pitch: float, width: float, colour: RGB, spec: PhotoSpec) -> _Yarns:
    first = -count // 2 - 2
    idx = np.arange(first, first + count + 4)
    centre = (idx + 0.5) * pitch + rng.normal(0, spec.jitter_position * pitch, idx.size)
    half = 0.5 * width * pitch * np.clip(1 + rng.normal(0, spec.jitter_width, idx.size), 0.6, 1.15)
    col = np.clip(np.asarray(colour)[None] * (1 + rng.normal(0, spec.jitter_colour, (idx.size, 3))), 0, 1)
    return _Yarns(centre, half, col, first)


def _profile(d: np.ndarray, kind: str) -> tuple[np.ndarray, np.ndarray]:
    """Cross-section height (0 at the edges, 1 on the axis) and its derivative in d ∈ [-1, 1]."""
    d = np.clip(d, -0.999, 0.999)
    if kind == "ellipse":
        h = np.sqrt(1 - d * d)
        return h, -d / h
    if kind == "lens":
        return 1 - d * d, -2 * d
    q = 1 - d ** 4  # flat: super-ellipse of order 4
    h = q ** 0.25
    return h, -(d ** 3) / np.maximum(q, 1e-6) ** 0.75


def _undulation(pos: np.ndarray, pitch: float, up: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A yarn's height along its length: +1 at the centres of the cells where it is on top, -1
    where it is under, a cosine in between. ``up`` (..., 2): the states of the two cells around
    each point (the one before the point's cell centre and the one after). Returns the height
    and its derivative in ``pos`` (px)."""
    t = pos / pitch - 0.5
    f = t - np.floor(t)
    w = 0.5 - 0.5 * np.cos(np.pi * f)
    s0, s1 = 2.0 * up[..., 0] - 1, 2.0 * up[..., 1] - 1
    dw = 0.5 * np.pi * np.sin(np.pi * f) / pitch
    return s0 * (1 - w) + s1 * w, (s1 - s0) * dw


def _value_noise(rng, n: int = 256) -> np.ndarray:
    return rng.random((n, n)).astype(np.float32)


def _sample_noise(tex: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Bilinear value noise, wrapped, at texture coordinates (a, b)."""
    n = tex.shape[0]
    a0, b0 = np.floor(a).astype(np.int64), np.floor(b).astype(np.int64)
    fa, fb = a - a0, b - b0
    fa, fb = fa * fa * (3 - 2 * fa), fb * fb * (3 - 2 * fb)
    t00, t01 = tex[a0 % n, b0 % n], tex[a0 % n, (b0 + 1) % n]
    t10, t11 = tex[(a0 + 1) % n, b0 % n], tex[(a0 + 1) % n, (b0 + 1) % n]
    return (t00 * (1 - fb) + t01 * fb) * (1 - fa) + (t10 * (1 - fb) + t11 * fb) * fa


class _Fabric:
    """The height-field fabric of a :class:`PhotoSpec`, evaluated at fabric points (u, v) px
    (u along the wefts, to the right; v along the warps, down), origin at the fabric's centre."""

    def __init__(self, spec: PhotoSpec, rng: np.random.Generator, extent_px: float):
        self.spec = spec
        pa, pe = spec.pitch_px
        self.pattern = np.asarray(spec.pattern, dtype=np.uint8)
        n_warps, n_wefts = int(extent_px / pa) + 8, int(extent_px / pe) + 8
        self.warps = _yarns(rng, n_warps, pa, spec.width[0], spec.warp_colour, spec)
        self.wefts = _yarns(rng, n_wefts, pe, spec.width[1], spec.weft_colour, spec)
        self.noise = (_value_noise(rng), _value_noise(rng))
        # the repeat's phase at the fabric's centre: a random whole-cell offset
        self.offset = (int(rng.integers(self.pattern.shape[0])), int(rng.integers(self.pattern.shape[1])))

    def _state(self, i: np.ndarray, j: np.ndarray) -> np.ndarray:
        n_e, n_a = self.pattern.shape
        return self.pattern[(i + self.offset[0]) % n_e, (j + self.offset[1]) % n_a]

    def _family(self, yarns: _Yarns, across: np.ndarray, along: np.ndarray, pitch_across: float,
                pitch_along: float, warp: bool):
        """The best-covering yarn of one family at each point: (height, d height/d across,
        d height/d along, covered, yarn index, d, along-coordinate)."""
        shape = across.shape
        k0 = np.floor(across / pitch_across).astype(np.int64)
        best_h = np.full(shape, -np.inf, np.float32)
        out = {}
        for dk in (-1, 0, 1):
            k = k0 + dk
            e = np.clip(k - yarns.first, 0, yarns.centre.size - 1)
            d = (across - yarns.centre[e]) / yarns.half[e]
            cover = np.abs(d) < 1
            prof, dprof = _profile(d, self.spec.cross_section)
            # the cells before and after the point along the yarn, and whether this yarn is up
            c = np.floor(along / pitch_along - 0.5).astype(np.int64)
            if warp:  # warp k runs along v; up where the weft is under (state 0)
                up = np.stack([1 - self._state(c, k), 1 - self._state(c + 1, k)], axis=-1)
            else:  # weft k runs along u; up where state 1
                up = np.stack([self._state(k, c), self._state(k, c + 1)], axis=-1)
            und, dund = _undulation(along, pitch_along, up)
            thick = yarns.half[e]
            h = thick * (prof + self.spec.crimp * und)
            dh_across = thick * dprof / yarns.half[e]
            dh_along = thick * self.spec.crimp * dund
            take = cover & (h > best_h)
            best_h = np.where(take, h, best_h)
            for key, val in (("h", h), ("da", dh_across), ("dl", dh_along), ("e", e), ("d", d), ("prof", prof)):
                out[key] = np.where(take, val, out[key]) if key in out else np.where(take, val, 0)
        out["cover"] = np.isfinite(best_h)
        return out

    def radiance(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Linear RGB radiance of the scene (before the camera) at fabric points (u, v)."""
        spec = self.spec
        pa, pe = spec.pitch_px
        wa = self._family(self.warps, u, v, pa, pe, warp=True)
        we = self._family(self.wefts, v, u, pe, pa, warp=False)
        h_a = np.where(wa["cover"], wa["h"], -np.inf)
        h_e = np.where(we["cover"], we["h"], -np.inf)
        is_warp = h_a >= h_e
        seen = wa["cover"] | we["cover"]

        def pick(key):
            return np.where(is_warp, wa[key], we[key])

        # surface normal of the height field; warp: across = u, along = v; weft the other way
        dhdu = np.where(is_warp, wa["da"], we["dl"])
        dhdv = np.where(is_warp, wa["dl"], we["da"])
        n = np.stack([-dhdu, -dhdv, np.ones_like(dhdu)], axis=-1)
        n /= np.linalg.norm(n, axis=-1, keepdims=True)
        az, el = np.deg2rad(spec.light_deg)
        light = np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
        lambert = np.clip(n @ light, 0, None)
        height = pick("h")
        top = max(float(self.warps.half.max()), float(self.wefts.half.max())) * (1 + spec.crimp)
        ao = 0.45 + 0.55 * np.clip((height + top) / (2 * top), 0, 1)
        colour = np.where(is_warp[..., None], self.warps.colour[wa["e"]], self.wefts.colour[we["e"]])
        # ply striations: helical grooves across the yarn at the twist angle; fibre streaks
        d = pick("d")
        along = np.where(is_warp, v, u)
        half = np.where(is_warp, self.warps.half[wa["e"]], self.wefts.half[we["e"]])
        tw = np.tan(np.deg2rad(spec.twist_deg))
        phase = spec.plies * (d + along * tw / (2 * half)) * 0.5
        groove = (0.5 + 0.5 * np.cos(2 * np.pi * phase)) ** 4
        ply = 1 - spec.ply_depth * groove
        tex = np.where(is_warp, _sample_noise(self.noise[0], d * 12 + wa["e"] * 31.0, along / (0.8 * half)),
                       _sample_noise(self.noise[1], d * 12 + we["e"] * 31.0, along / (0.8 * half)))
        fibre = 1 - spec.fibre_depth * (tex - 0.5) * 2
        diffuse = colour * ((0.35 * ao + 0.75 * lambert) * ply * fibre)[..., None]
        # Kajiya-Kay highlight about the tangent (the yarn's axis, tilted by its undulation)
        t = np.where(is_warp[..., None], np.stack([np.zeros_like(u), np.ones_like(u), wa["dl"]], -1),
                     np.stack([np.ones_like(u), np.zeros_like(u), we["dl"]], -1))
        t /= np.linalg.norm(t, axis=-1, keepdims=True)
        half_vec = light + np.array([0.0, 0.0, 1.0])
        half_vec /= np.linalg.norm(half_vec)
        th = t @ half_vec
        spec_term = spec.highlight * np.sqrt(np.clip(1 - th * th, 0, 1)) ** spec.shininess * ply * (lambert > 0)
        out = diffuse + spec_term[..., None]
        if spec.gaps == "backlit":  # the back light seen through the gaps, and glowing thin edges
            back = 0.9
            glow = back * 0.5 * (1 - pick("prof")) ** 2
            out = out + (glow[..., None] * colour)
            gap = np.full(3, back)
        else:
            gap = np.full(3, 0.015)
        return np.where(seen[..., None], out, gap).astype(np.float32)


# ------------------------------------------------------------------------------------ camera

def _homography(spec: PhotoSpec) -> np.ndarray:
    """Fabric px (centred) → photo px: turn, then a camera pitched/yawed by ``tilt_deg`` at a
    distance of twice the photo's width, then centred in the photo."""
    h, w = spec.size_px
    th = np.deg2rad(spec.rotate_deg)
    rot = np.array([[np.cos(th), np.sin(th), 0], [-np.sin(th), np.cos(th), 0], [0, 0, 1]])
    focal = 2.0 * max(h, w)
    p, y = np.deg2rad(spec.tilt_deg)
    rx = np.array([[1, 0, 0], [0, np.cos(p), -np.sin(p)], [0, np.sin(p), np.cos(p)]])
    ry = np.array([[np.cos(y), 0, np.sin(y)], [0, 1, 0], [-np.sin(y), 0, np.cos(y)]])
    r3 = ry @ rx
    # plane z = 0 seen from distance focal: x_cam = R [u, v, 0] + [0, 0, focal]
    proj = np.array([[focal, 0, 0], [0, focal, 0], [0, 0, 1]]) @ np.column_stack([r3[:, 0], r3[:, 1], [0, 0, focal]])
    proj /= proj[2, 2]
    centre = np.array([[1, 0, (w - 1) / 2], [0, 1, (h - 1) / 2], [0, 0, 1]])
    return centre @ proj @ rot


def scene_radiance(spec: PhotoSpec, *, seed: int = 0, supersample: int = 2) -> np.ndarray:
    """The photo before the camera's electronics: (H, W, 3) linear RGB, the fabric through the
    lens (turn, perspective, ``supersample``² samples a pixel, optical blur)."""
    import cv2

    rng = np.random.default_rng(seed)
    h, w = spec.size_px
    hmg = _homography(spec)
    inv = np.linalg.inv(hmg)
    fabric = _Fabric(spec, rng, extent_px=2.0 * np.hypot(h, w))
    out = np.zeros((h, w, 3), np.float64)
    offsets = (np.arange(supersample) + 0.5) / supersample - 0.5
    rows = max(1, 262144 // w)
    for y0 in range(0, h, rows):
        yy, xx = np.mgrid[y0:min(h, y0 + rows), 0:w].astype(np.float64)
        acc = np.zeros(yy.shape + (3,))
        for oy in offsets:
            for ox in offsets:
                pts = np.stack([xx + ox, yy + oy, np.ones_like(xx)], -1) @ inv.T
                u, v = pts[..., 0] / pts[..., 2], pts[..., 1] / pts[..., 2]
                acc += fabric.radiance(u, v)
        out[y0:y0 + yy.shape[0]] = acc / supersample ** 2
    out = out.astype(np.float32)
    if spec.blur_px > 0:
        out = cv2.GaussianBlur(out, (0, 0), spec.blur_px)
    return out


def render_photo(spec: PhotoSpec, *, seed: int = 0) -> np.ndarray:
    """The photo as a camera saves it: (H, W, 3) uint8 sRGB (JPEG artefacts included when
    ``spec.jpeg_quality`` > 0). Exposure and white balance err as the spec says; noise is
    signal dependent (shot noise plus a read-noise floor)."""
    import cv2

    from ..photo import linear_to_srgb

    rng = np.random.default_rng(seed + 7919)
    img = scene_radiance(spec, seed=seed) * (2.0 ** spec.exposure_stops) * np.asarray(spec.white_balance, np.float32)
    sigma = spec.noise * np.sqrt(np.clip(img, 0, None) / 0.5 + 0.05)
    img = img + rng.normal(0, 1, img.shape).astype(np.float32) * sigma
    srgb = (np.clip(linear_to_srgb(np.clip(img, 0, 1)), 0, 1) * 255 + 0.5).astype(np.uint8)
    if spec.jpeg_quality:
        ok, buf = cv2.imencode(".jpg", cv2.cvtColor(srgb, cv2.COLOR_RGB2BGR),
                               [cv2.IMWRITE_JPEG_QUALITY, int(spec.jpeg_quality)])
        srgb = cv2.cvtColor(cv2.imdecode(buf, cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB)
    return srgb


def write_photo(path: str | Path, spec: PhotoSpec, *, seed: int = 0) -> Path:
    """Render ``spec`` and save it (JPEG at ``spec.jpeg_quality``, else PNG by extension)."""
    import cv2

    path = Path(path)
    srgb = render_photo(spec, seed=seed)
    params = [cv2.IMWRITE_JPEG_QUALITY, 100] if path.suffix.lower() in (".jpg", ".jpeg") else []
    if not cv2.imwrite(str(path), cv2.cvtColor(srgb, cv2.COLOR_RGB2BGR), params):
        raise OSError(f"could not write {path}")
    return path


# ------------------------------------------------------------------------------------ the set

def _colour(rng) -> np.ndarray:
    """A dyed-yarn colour: a random hue, saturation and value, in linear RGB."""
    import colorsys

    hue, sat, val = rng.random(), rng.uniform(0.15, 0.85), rng.uniform(0.3, 0.95)
    srgb = np.array(colorsys.hsv_to_rgb(hue, sat, val))
    return np.where(srgb <= 0.04045, srgb / 12.92, ((srgb + 0.055) / 1.055) ** 2.4)


def bench_specs(*, seed: int = 11, quick: bool = False) -> list[PhotoSpec]:
    """The fit bench's independent set (18 photos; ``quick``: 4 of them).

    Plain; twills 2/1, 3/1 and 2/2 in both directions; satins 5 and 8, weft- and warp-faced;
    basket 2/2; random weaves 4×4, 6×6 and 8×8; a back-lit plain and a 3×6 random. Warp and
    weft colours are drawn independently, every third photo with near-identical ones; gaps
    alternate dark and back-lit; exposure is off by up to ±1 stop and each channel's white
    balance by up to ±20 %; turned up to ±15°, camera tilted up to 6°, blur σ 0.5–1.3 px,
    noise, JPEG 80–95; yarn pitch 24–40 px in a 1024×1024 photo (1 MP); the cross-section,
    ply count, twist, highlight and crimp vary.
    """
    rng = np.random.default_rng(seed)
    patterns = [("plain", np.array([[1, 0], [0, 1]], np.uint8)),
                ("twill21_a", twill(2, 1, 1)), ("twill21_b", twill(2, 1, -1)),
                ("twill31_a", twill(3, 1, 1)), ("twill31_b", twill(3, 1, -1)),
                ("twill22_a", twill(2, 2, 1)), ("twill22_b", twill(2, 2, -1)),
                ("satin5_weft", satin(5, 2)), ("satin5_warp", satin(5, 3, weft_faced=False)),
                ("satin8_weft", satin(8, 3)), ("satin8_warp", satin(8, 5, weft_faced=False)),
                ("basket22", basket(2)),
                ("random4x4", random_weave(rng, (4, 4))), ("random6x6", random_weave(rng, (6, 6))),
                ("random8x8", random_weave(rng, (8, 8))),
                ("plain_backlit", np.array([[1, 0], [0, 1]], np.uint8)),
                ("random3x6", random_weave(rng, (3, 6))), ("twill31_c", twill(1, 3, 1))]
    specs = []
    for k, (name, pattern) in enumerate(patterns):
        warp = _colour(rng)
        weft = warp * (1 + rng.normal(0, 0.02, 3)) if k % 3 == 2 else _colour(rng)
        pitch = float(rng.uniform(24, 40))
        specs.append(PhotoSpec(
            name=f"{k:02d}_{name}", pattern=pattern, warp_colour=tuple(np.clip(warp, 0, 1)),
            weft_colour=tuple(np.clip(weft, 0, 1)),
            pitch_px=(pitch, pitch * float(rng.uniform(0.85, 1.15))),
            width=(float(rng.uniform(0.72, 0.92)), float(rng.uniform(0.72, 0.92))),
            cross_section=CROSS_SECTIONS[k % 3], gaps="backlit" if (k % 2 == 1 or name.endswith("backlit")) else "dark",
            crimp=float(rng.uniform(0.35, 0.6)), plies=int(rng.integers(2, 6)), twist_deg=float(rng.uniform(15, 40)),
            ply_depth=float(rng.uniform(0.15, 0.45)), fibre_depth=float(rng.uniform(0.05, 0.2)),
            highlight=float(rng.uniform(0.1, 0.35)), shininess=float(rng.uniform(15, 60)),
            light_deg=(float(rng.uniform(-120, -30)), float(rng.uniform(45, 70))),
            exposure_stops=float(rng.uniform(-1, 1)),
            white_balance=tuple(float(g) for g in 1 + rng.uniform(-0.2, 0.2, 3)),
            rotate_deg=float(rng.uniform(-15, 15)),
            tilt_deg=(float(rng.uniform(-6, 6)), float(rng.uniform(-6, 6))),
            blur_px=float(rng.uniform(0.5, 1.3)), noise=float(rng.uniform(0.005, 0.015)),
            jpeg_quality=int(rng.integers(80, 96))))
    if quick:
        keep = ("plain", "twill31_a", "satin5_weft", "random4x4")
        specs = [s for s in specs if s.name[3:] in keep]
    return specs


def with_camera(spec: PhotoSpec, **changes) -> PhotoSpec:
    """``spec`` with camera settings changed (the same fabric, e.g. another exposure)."""
    return replace(spec, **changes)
