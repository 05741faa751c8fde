"""Varied procedural woven images with every cell's state known: the cell classifier's
training and held-out data (:mod:`.cell_classifier`).

The forward model (:mod:`weavecap.model`) renders smooth, clean yarns; real cloth is hairy,
plied, twisted, striped, unevenly lit, blurred and compressed, and a classifier trained on the
model's renders alone learns the model's looks. This generator draws each image from a wide
family of looks with plain numpy/OpenCV (it shares no code with the forward model nor with the
independent bench's :mod:`weavecap.heightfield_photos`, so that both benches stay a test):

- **weaves** (:func:`random_weave`): plain, twills a/b both ways, satins and extended satins,
  basket and hopsack, warp and weft ribs, point and broken (herringbone) twills with legs of
  2–12 yarns, and random interlacing patterns, at a random cyclic phase, either face;
- **yarns**: each warp and weft with its own centre, width (30–105% of its pitch), wobble and
  brightness; a cross-section lit by a random light (Lambert plus a highlight of random
  strength); crimp (a yarn darkens where it dips under its neighbour, so floats show their
  ends); plies (1–4 helical grooves at a random twist), fibre striations at a random angle to
  the yarn's axis, slubs (brightness drifting along the yarn) and hairs (thin curved strokes
  across yarns and gaps);
- **colours**: warp and weft alike, near alike or unlike, from near-black to near-white;
  yarn-dyed stripes and checks (a family's yarns drawing from 2–3 colours in runs); gaps dark
  (front light) or bright (back light);
- **camera**: an uneven illumination field, the image rendered at 0.5–1.7 times the canvas's
  cell size and resampled (the photo's pitch is never the canvas's), a grid registered up to
  ±0.15 cell off with a scale error of ±3% and a turn of ±1.5° (a real photo's grid is never
  exact), defocus, exposure with clipping, sensor noise and JPEG; a fifth of the images with
  the grid half a cell off (cells centred between crossings: their labels are the mean state
  they cover, so the classifier learns to be unsure there and a lattice's phase can be told by
  its confidence, :func:`weavecap.estimate.decide.decide`).

The image is returned on a *cell canvas*, the layout of :func:`weavecap.estimate.cells.cell_canvas`:
each cell ``cell_px`` square, cell (i, j) the crossing of weft i (a row, from the top) and
warp j (a column), with its label 1 where the weft is on top. Every draw comes from the
``numpy.random.Generator`` passed in.
"""

from __future__ import annotations

from math import gcd

import cv2
import numpy as np

from ..photo import linear_to_srgb, srgb_to_linear
from .sampling import herringbone, interlaces, point_twill, satin, twill

#: the share of images whose grid is half a cell off along one axis or both
OFF_PHASE = 0.2
#: cells drawn beyond the canvas on each side (room for the grid's offset and turn)
MARGIN = 2
#: the weave kinds :func:`random_weave` draws, equally often
WEAVE_KINDS = ("plain", "twill", "satin", "extended_satin", "basket", "rib", "point_twill", "herringbone",
               "random")


# ----------------------------------------------------------------------------- weaves

def random_weave(rng: np.random.Generator, kind: str | None = None, *, max_size: int = 24) -> np.ndarray:
    """One weave's repeat (wefts, warps) uint8, 1 = weft on top, of ``kind`` (a random one of
    :data:`WEAVE_KINDS` if None), at most ``max_size`` yarns a side; either face (the
    complement) and either role of the families (the transpose of the complement) equally
    likely, every yarn interlacing."""
    kind = kind or str(rng.choice(WEAVE_KINDS))
    while True:
        if kind == "plain":
            p = np.array([[1, 0], [0, 1]], np.uint8)
        elif kind == "twill":
            n = int(rng.integers(3, 9))
            over = int(rng.integers(1, n))
            p = twill(over, n - over, step=int(rng.choice([-1, 1])))
        elif kind in ("satin", "extended_satin"):
            n = int(rng.choice([5, 6, 7, 8, 9, 10, 11, 12]))
            moves = [s for s in range(2, n - 1) if gcd(s, n) == 1]
            if not moves:  # 6 has no regular satin: the irregular 6-end satin's move sequence
                p = np.ones((6, 6), np.uint8)
                p[np.arange(6), [0, 2, 4, 1, 5, 3]] = 0
            else:
                p = satin(n, int(rng.choice(moves)))
                if kind == "extended_satin":
                    p = _extended(p, int(rng.integers(2, max(3, n // 2))))
        elif kind == "basket":
            a, b = int(rng.integers(2, 5)), int(rng.integers(1, 5))
            if rng.random() < 0.6:
                b = a
            p = np.kron(np.array([[1, 0], [0, 1]], np.uint8), np.ones((a, b), np.uint8))
        elif kind == "rib":
            k = int(rng.integers(2, 5))
            block = np.ones((k, 1), np.uint8) if rng.random() < 0.5 else np.ones((1, k), np.uint8)
            p = np.kron(np.array([[1, 0], [0, 1]], np.uint8), block)
        elif kind in ("point_twill", "herringbone"):
            n = int(rng.integers(3, 7))
            over = int(rng.integers(1, n))
            base = twill(over, n - over, step=1)
            leg = int(rng.integers(max(3, n // 2), 13)) if kind == "point_twill" else int(rng.integers(2, 13))
            p = point_twill(base, leg) if kind == "point_twill" else herringbone(base, leg)
            if rng.random() < 0.5:  # the zigzag along the wefts instead of along the warps
                p = 1 - p.T
        elif kind == "random":
            shape = (int(rng.integers(2, 9)), int(rng.integers(2, 9)))
            p = (rng.random(shape) < rng.uniform(0.3, 0.7)).astype(np.uint8)
        else:
            raise ValueError(f"unknown weave kind {kind!r}; one of {', '.join(WEAVE_KINDS)}")
        if rng.random() < 0.5:
            p = 1 - p
        if rng.random() < 0.5:
            p = 1 - p.T
        p = np.roll(p, (int(rng.integers(0, p.shape[0])), int(rng.integers(0, p.shape[1]))), axis=(0, 1))
        if max(p.shape) <= max_size and interlaces(p):
            return p.astype(np.uint8)


def _extended(p: np.ndarray, run: int) -> np.ndarray:
    """A satin's extension: each sinking point of ``p`` widened to ``run`` cells along its weft."""
    n = p.shape[1]
    down = p == 0
    out = down.copy()
    for k in range(1, run):
        out |= np.roll(down, k, axis=1)
    return (~out).astype(np.uint8) if run < n else p


# ----------------------------------------------------------------------------- looks

def _colour(rng: np.random.Generator) -> np.ndarray:
    """A linear RGB yarn colour: a hue, a saturation and a value from near-black to near-white."""
    h = rng.uniform(0, 180)
    s = rng.choice([rng.uniform(0, 0.15), rng.uniform(0.15, 1.0)])
    v = rng.choice([rng.uniform(0.03, 0.2), rng.uniform(0.2, 1.0), rng.uniform(0.85, 1.0)])
    hsv = np.array([[[h, s, v]]], np.float32)
    return srgb_to_linear(cv2.cvtColor(hsv, cv2.COLOR_HSV2RGB)[0, 0])


def _family_colours(rng: np.random.Generator, count: int, base: np.ndarray) -> np.ndarray:
    """(count, 3) the colours of one family's yarns: ``base`` with a per-yarn brightness jitter,
    and a third of the time yarn-dyed stripes (runs of 1–8 yarns from 2–3 colours)."""
    colours = np.repeat(base[None], count, axis=0)
    if rng.random() < 0.3:
        palette = [base] + [_colour(rng) for _ in range(int(rng.integers(1, 3)))]
        k, pick = 0, 0
        while k < count:
            run = int(rng.integers(1, 9))
            colours[k:k + run] = palette[pick]
            pick = (pick + 1 + int(rng.integers(0, len(palette) - 1))) % len(palette)
            k += run
    return colours * rng.uniform(0.85, 1.15, (count, 1)).astype(np.float32)


def _noise1d(rng: np.random.Generator, n: int, corr: float) -> np.ndarray:
    """A random 1-D signal of ``n`` samples with correlation length ``corr`` samples, zero
    mean, unit standard deviation."""
    x = cv2.GaussianBlur(rng.standard_normal((1, n)).astype(np.float32), (0, 0), max(0.3, corr),
                         borderType=cv2.BORDER_REFLECT)[0]
    return (x - x.mean()) / max(1e-6, float(x.std()))


def _lookup(signal: np.ndarray, t: np.ndarray) -> np.ndarray:
    """``signal`` read at positions ``t`` (wrapping), linearly interpolated."""
    n = signal.size
    t = np.mod(t, n)
    i = np.floor(t).astype(np.int64)
    f = (t - i).astype(np.float32)
    return signal[i % n] * (1 - f) + signal[(i + 1) % n] * f


class _Family:
    """One yarn family's geometry and looks, drawn at random (positions in render pixels)."""

    def __init__(self, rng: np.random.Generator, count: int, pitch: float, base: np.ndarray):
        self.count, self.pitch = count, pitch
        self.offset = rng.normal(0, 0.05 * pitch, count)
        self.width = pitch * np.clip(rng.uniform(0.3, 1.05) * rng.normal(1, 0.06, count), 0.25, 1.1)
        self.wobble = rng.uniform(0, 0.06 * pitch) * rng.random(count)
        self.wave = rng.uniform(3, 10) * pitch
        self.phase = rng.uniform(0, 2 * np.pi, count)
        self.colours = _family_colours(rng, count, base)
        self.plies = int(rng.integers(1, 5))
        self.ply_angle = np.deg2rad(rng.uniform(15, 45)) * rng.choice([-1, 1])
        self.ply_depth = rng.uniform(0.0, 0.55) if self.plies > 1 else rng.uniform(0.0, 0.2)
        self.fibre_angle = np.deg2rad(rng.uniform(0, 35)) * rng.choice([-1, 1])
        self.fibre_depth = rng.uniform(0.0, 0.45)
        self.fibres = _noise1d(rng, 4096, rng.uniform(0.4, 1.6) * pitch / 16)
        self.slub = _noise1d(rng, 4096, rng.uniform(1, 4) * pitch)
        self.slub_depth = rng.uniform(0.0, 0.25)
        self.crimp = rng.uniform(0.25, 0.9)  # how dark a yarn gets where it dips fully under
        self.profile = rng.uniform(0.3, 2.0)  # exponent of the cross-section's roundness

    def centres(self, along: np.ndarray) -> np.ndarray:
        """(count, len(along)) each yarn's centre at each position along the yarns."""
        k = np.arange(self.count)[:, None]
        return ((k + 0.5) * self.pitch + self.offset[:, None]
                + self.wobble[:, None] * np.sin(2 * np.pi * along[None] / self.wave + self.phase[:, None]))

    def height(self, up: np.ndarray, along: np.ndarray, k: np.ndarray) -> np.ndarray:
        """The yarn's height (0 under, 1 on top) at ``along`` for yarn ``k``: ``up`` (count, cells)
        the yarn's state at each crossing, interpolated with a cosine between cell centres."""
        t = along / self.pitch - 0.5
        i0 = np.floor(t).astype(np.int64)
        f = t - i0
        n = up.shape[1]
        a = up[k, np.clip(i0, 0, n - 1)]
        b = up[k, np.clip(i0 + 1, 0, n - 1)]
        w = 0.5 - 0.5 * np.cos(np.pi * f)
        return (a * (1 - w) + b * w).astype(np.float32)

    def texture(self, k: np.ndarray, d: np.ndarray, along: np.ndarray) -> np.ndarray:
        """Multiplicative texture of the yarn at each pixel: plies, fibres and slubs."""
        half = 0.5 * self.width[k]
        u = d * half  # pixels across, from the centre
        shade = np.ones(d.shape, np.float32)
        if self.plies > 1 or self.ply_depth > 0:
            period = max(2.0, 2 * half.mean() / self.plies / max(0.35, abs(np.tan(self.ply_angle))))
            z = (along + u * np.tan(self.ply_angle) + 37.0 * k) / period
            groove = np.abs(np.cos(np.pi * z)) ** 0.5
            shade *= 1 - self.ply_depth * (1 - groove)
        w = u * np.cos(self.fibre_angle) - along * np.sin(self.fibre_angle) + 97.0 * k
        shade *= 1 + self.fibre_depth * 0.5 * _lookup(self.fibres, w * 16 / self.pitch * 4)
        shade *= 1 + self.slub_depth * _lookup(self.slub, along + 523.0 * k)
        return np.clip(shade, 0.05, 2.0)


def _hairs(rng: np.random.Generator, image: np.ndarray, pitch: float, density: float) -> None:
    """Draw thin curved hairs over ``image`` (H, W, 3) in place: about ``density`` a cell,
    0.3–2 pitches long, each the colour of the image where it starts, lighter or darker."""
    h, w = image.shape[:2]
    count = int(density * h * w / pitch ** 2)
    if count == 0:
        return
    overlay = image.copy()
    for _ in range(count):
        x, y = rng.uniform(0, w), rng.uniform(0, h)
        angle = rng.uniform(0, 2 * np.pi)
        length = rng.uniform(0.3, 2.0) * pitch
        steps = 8
        bend = rng.normal(0, 0.35)
        pts = []
        for s in range(steps + 1):
            pts.append((x, y))
            angle += bend / steps * 3
            x += np.cos(angle) * length / steps
            y += np.sin(angle) * length / steps
        colour = image[int(np.clip(pts[0][1], 0, h - 1)), int(np.clip(pts[0][0], 0, w - 1))] * rng.uniform(0.7, 1.6)
        cv2.polylines(overlay, [np.round(np.array(pts) * 4).astype(np.int32)], False,
                      tuple(float(c) for c in np.clip(colour, 0, 1.5)), thickness=max(1, int(rng.integers(1, 3))),
                      lineType=cv2.LINE_AA, shift=2)
    alpha = rng.uniform(0.4, 0.9)
    image *= 1 - alpha
    image += alpha * overlay


def render_weave(rng: np.random.Generator, states: np.ndarray, pitch: float) -> np.ndarray:
    """A woven image of ``states`` ((n_e, n_a) 0/1, 1 = weft on top; weft i a row, warp j a
    column) at ``pitch`` render pixels per yarn, every look drawn at random (module
    docstring): (n_e * pitch, n_a * pitch, 3) float32 linear RGB, before the camera."""
    n_e, n_a = states.shape
    h, w = int(round(n_e * pitch)), int(round(n_a * pitch))
    y, x = np.mgrid[0:h, 0:w].astype(np.float32) + 0.5
    same = rng.random()
    warp_base = _colour(rng)
    weft_base = warp_base if same < 0.35 else (
        np.clip(warp_base * rng.uniform(0.6, 1.4, 3), 0, 1).astype(np.float32) if same < 0.6 else _colour(rng))
    warps = _Family(rng, n_a, pitch, warp_base)
    wefts = _Family(rng, n_e, pitch, weft_base)
    # warps run along y: across is x
    ka, da = _locate_vertical(warps, x, y)
    ke, de = _locate_vertical(wefts, y.T, x.T)
    ke, de = ke.T, de.T
    warp_up = (1 - states).T.astype(np.float32)  # (n_a, n_e): the warp's state at each crossing
    weft_up = states.astype(np.float32)  # (n_e, n_a)
    ha = warps.height(warp_up, y, ka)
    he = wefts.height(weft_up, x, ke)
    in_a, in_e = np.abs(da) < 1, np.abs(de) < 1
    # where both cover a point, the higher is seen (the state decides at the crossing itself)
    show_weft = in_e & (~in_a | (he > ha) | ((he == ha) & (states[np.clip((y / pitch).astype(int), 0, n_e - 1),
                                                                        np.clip((x / pitch).astype(int), 0, n_a - 1)] == 1)))
    show_warp = in_a & ~show_weft
    light = rng.normal(0, 1, 3)
    light[2] = abs(light[2]) + 0.6
    light /= np.linalg.norm(light)
    spec_strength = rng.choice([0.0, rng.uniform(0.0, 0.6)])
    shininess = rng.uniform(4, 40)
    image = np.zeros((h, w, 3), np.float32)
    for fam, k, d, hgt, mask, axis in ((warps, ka, da, ha, show_warp, 0), (wefts, ke, de, he, show_weft, 1)):
        dd = np.clip(d, -0.999, 0.999)
        nz = np.sqrt(1 - dd ** 2) ** fam.profile
        # the normal leans across the yarn by d, and along it where the yarn dips
        slope = np.gradient(hgt, axis=axis) * fam.pitch * 0.6
        if axis == 0:  # warp: across is x, along is y
            nx, ny = dd, -slope
        else:
            nx, ny = -slope, dd
        norm = np.sqrt(nx ** 2 + ny ** 2 + nz ** 2) + 1e-6
        lambert = np.clip((nx * light[0] + ny * light[1] + nz * light[2]) / norm, 0, None)
        ambient = 0.25
        occlusion = 1 - fam.crimp * (1 - hgt)
        along = y if axis == 0 else x
        albedo = fam.colours[k] * fam.texture(k, d, along)[..., None]
        highlight = spec_strength * np.clip(nz / norm, 0, 1) ** shininess * occlusion
        shade = ((ambient + (1 - ambient) * lambert) * occlusion)[..., None]
        image = np.where(mask[..., None], albedo * shade + highlight[..., None], image)
    # cast shadows: a point lies in shadow where the surface a little towards the light
    # (along its direction in the plane) stands higher than it by more than the light's slope
    surface = np.where(show_warp, 1.0 + ha, np.where(show_weft, 1.0 + he, 0.0)).astype(np.float32)
    lean = np.hypot(light[0], light[1])
    if lean > 0.2:
        reach = 0.25 * pitch * lean / max(light[2], 0.3)
        shift = np.float32([[1, 0, -light[0] / lean * reach], [0, 1, -light[1] / lean * reach]])
        towards = cv2.warpAffine(surface, shift, (w, h), borderMode=cv2.BORDER_REFLECT)
        shadow = np.clip(towards - surface - 0.3, 0, 1)
        image *= (1 - rng.uniform(0.3, 0.8) * shadow)[..., None]
    gap = ~(show_warp | show_weft)
    if rng.random() < 0.75:  # front light: the gaps are shadow, a little of the yarns' colour
        gap_colour = 0.5 * (warp_base + weft_base) * rng.uniform(0.0, 0.25)
    else:  # back light through the gaps
        gap_colour = np.full(3, rng.uniform(0.6, 1.3), np.float32)
    image = np.where(gap[..., None], gap_colour[None, None], image)
    # yarn edges: a soft dark line where a yarn on top meets what is below
    if rng.random() < 0.7:
        edge = np.clip(np.maximum(np.where(show_warp, np.abs(da), 0), np.where(show_weft, np.abs(de), 0)) - 0.8, 0, 1) / 0.2
        image *= (1 - rng.uniform(0.2, 0.7) * edge)[..., None]
    _hairs(rng, image, pitch, rng.choice([0.0, rng.uniform(0, 0.8), rng.uniform(0.8, 3.0)]))
    return image


def _locate_vertical(fam: _Family, across: np.ndarray, along: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:meth:`_Family` location for yarns running along axis 0 of ``across``/``along`` (H, W):
    the nearest of the three yarns about each pixel and the signed position within it."""
    h = across.shape[0]
    centres = fam.centres(along[:, 0])  # (count, H)
    k0 = np.clip(np.floor(across / fam.pitch).astype(np.int64), 0, fam.count - 1)
    rows = np.broadcast_to(np.arange(h)[:, None], across.shape)
    best_k, best_d = k0.copy(), np.full(across.shape, np.inf, np.float32)
    for dk in (-1, 0, 1):
        k = np.clip(k0 + dk, 0, fam.count - 1)
        d = (across - centres[k, rows]) / (0.5 * fam.width[k])
        closer = np.abs(d) < np.abs(best_d)
        best_k, best_d = np.where(closer, k, best_k), np.where(closer, d, best_d)
    return best_k, best_d.astype(np.float32)


# ----------------------------------------------------------------------------- camera

def cell_sample(rng: np.random.Generator, *, cells: tuple[int, int] = (16, 16), cell_px: int = 16,
                weave: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """One training example: a woven image (:func:`render_weave`) on a cell canvas
    (:func:`photographed`) and its cells' states.

    Parameters
    ----------
    cells : (wefts, warps) of the canvas; cell_px : canvas pixels a cell.
    weave : a repeat to tile (default :func:`random_weave`).

    Returns
    -------
    (canvas (cells[0] * cell_px, cells[1] * cell_px, 3) float32 linear RGB in [0, 1],
    labels (cells) float32: 1 = weft on top, 0 = warp; between where the canvas is half a cell
    off the crossings and a cell covers several — the share of its centre the weft tops).
    """
    weave = random_weave(rng) if weave is None else np.asarray(weave, np.uint8)
    states = tiled(weave, (cells[0] + 2 * MARGIN, cells[1] + 2 * MARGIN))
    pitch = cell_px * float(np.exp(rng.uniform(np.log(0.5), np.log(1.7))))
    return photographed(rng, render_weave(rng, states, pitch), states, pitch, cells=cells, cell_px=cell_px)


def tiled(weave: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """``weave`` tiled from its first cell to ``shape`` (wefts, warps)."""
    reps = (-(-shape[0] // weave.shape[0]), -(-shape[1] // weave.shape[1]))
    return np.tile(np.asarray(weave, np.uint8), reps)[: shape[0], : shape[1]]


def photographed(rng: np.random.Generator, image: np.ndarray, states: np.ndarray, pitch: float, *,
                 cells: tuple[int, int], cell_px: int) -> tuple[np.ndarray, np.ndarray]:
    """A woven ``image`` (linear RGB, cell (i, j) of ``states`` at rows i·pitch.., columns
    j·pitch..; :data:`MARGIN` cells beyond the canvas on each side) as a photo's cell canvas:
    an uneven light, the grid registered a little off (sometimes half a cell), resampled to
    ``cell_px`` a cell, defocus, exposure and clipping, noise, JPEG. Returns (canvas, labels)
    as :func:`cell_sample`."""
    n_e, n_a = cells
    margin = MARGIN
    big = states.shape
    scale = pitch / cell_px
    image = np.array(image, np.float32)
    # an uneven illumination field
    h, w = image.shape[:2]
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    field = 1 + rng.uniform(-0.35, 0.35) * (xx / w - 0.5) + rng.uniform(-0.35, 0.35) * (yy / h - 0.5)
    field -= rng.uniform(0, 0.5) * (((xx / w - 0.5) ** 2 + (yy / h - 0.5) ** 2) * 2)
    image *= np.clip(field, 0.2, 2)[..., None]
    # the canvas's grid: registered a little off (offset, scale, turn) on the image, and a
    # fifth of the time half a cell off along one axis or both (the cells' centres between
    # crossings, each labelled with the mean of the states it covers: nothing sure)
    off = rng.uniform(-0.15, 0.15, 2)
    if rng.random() < OFF_PHASE:
        off += 0.5 * np.array([[1, 0], [0, 1], [1, 1]][int(rng.integers(0, 3))])
    s = 1 + rng.uniform(-0.03, 0.03, 2)
    turn = np.deg2rad(rng.uniform(-1.5, 1.5))

    def to_image(gy: np.ndarray, gx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """canvas position (cells) → image position (cells)."""
        gy, gx = gy - n_e / 2, gx - n_a / 2
        ry = (np.cos(turn) * gy + np.sin(turn) * gx) * s[0]
        rx = (-np.sin(turn) * gy + np.cos(turn) * gx) * s[1]
        return ry + n_e / 2 + margin + off[0], rx + n_a / 2 + margin + off[1]

    cy, cx = (np.arange(n_e * cell_px) + 0.5) / cell_px, (np.arange(n_a * cell_px) + 0.5) / cell_px
    iy, ix = to_image(*np.meshgrid(cy, cx, indexing="ij"))
    map_y, map_x = (iy * pitch - 0.5).astype(np.float32), (ix * pitch - 0.5).astype(np.float32)
    if scale > 1.5:
        image = cv2.GaussianBlur(image, (0, 0), 0.5 * np.sqrt(scale ** 2 - 1))
    canvas = cv2.remap(image, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)
    blur = rng.choice([0.0, rng.uniform(0.3, 1.0), rng.uniform(1.0, 2.0)])
    if blur > 0:
        canvas = cv2.GaussianBlur(canvas, (0, 0), blur)
    exposure = float(np.exp(rng.uniform(np.log(0.4), np.log(2.5)))) / max(1e-3, float(np.percentile(canvas, 99)))
    canvas = linear_to_srgb(np.clip(canvas * exposure * rng.uniform(0.5, 1.1), 0, 1))
    canvas = canvas + rng.uniform(0, 0.04) * rng.standard_normal(canvas.shape)
    if rng.random() < 0.7:
        q = int(rng.integers(35, 96))
        ok, buf = cv2.imencode(".jpg", (np.clip(canvas, 0, 1) * 255 + 0.5).astype(np.uint8), [cv2.IMWRITE_JPEG_QUALITY, q])
        canvas = cv2.imdecode(buf, cv2.IMREAD_UNCHANGED).astype(np.float32) / 255
    # each cell's label: the mean state over its central half (4 × 4 points)
    t = ((np.arange(4) + 0.5) / 4 - 0.5) * 0.5
    py = np.arange(n_e)[:, None, None, None] + 0.5 + t[None, None, :, None]
    px = np.arange(n_a)[None, :, None, None] + 0.5 + t[None, None, None, :]
    sy, sx = to_image(*np.broadcast_arrays(py, px))
    covered = states[np.clip(np.floor(sy).astype(int), 0, big[0] - 1), np.clip(np.floor(sx).astype(int), 0, big[1] - 1)]
    labels = covered.mean(axis=(2, 3))
    return srgb_to_linear(np.clip(canvas, 0, 1)), labels.astype(np.float32)
