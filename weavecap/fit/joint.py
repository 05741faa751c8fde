"""Joint fitting of discrete and continuous parameters (§6.1–6.2 of Wu et al. 2025).

The loss is the MSE between the render of one repeat and the photo's repeat (§6). Continuous
parameters take Adam steps on their gradients (reverse-mode AD through the forward model) plus
the range barrier of Eq. 5, and are clamped to Table 1 after every step. Between gradient
steps, simulated annealing proposes a discrete move — change the number of plies or fibres, or
(``radius_mode="anneal"``) nudge a yarn radius — and accepts it by the Metropolis rule at a
temperature that starts at T₀ = 100 and decays by 0.98 per proposal (§6.2). The pattern is
re-annealed at T = 0 with §5.1's batched sweeps (one complement render, then batches of the
most promising flips) at fixed points of the fit, once the continuous values have settled —
a flip judged against badly fitted colours is a coin toss; at the same points every number of
plies is tried (:func:`scan_plies`). The body colours, in which the render is linear, are
also solved in closed form with the rest fixed, once late in each round (:func:`solve_colours`):
gradient steps alone can leave them stuck at black. The radii, by default, follow a greedy
pattern search (:class:`_RadiusSearch`).

Adam works on each parameter scaled to its range ([0, 1]), so one learning rate fits all; the
rate follows a cosine from ``learning_rate`` down to a tenth of it over the iterations.
Eq. 5 as printed penalises values *inside* the range; the intent, and what is used here, is
``λ (max(0, a − x)² + max(0, x − b)²)`` on the raw value x with range [a, b].
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import torch

from ..model.render import (as_photographed, blur, blurred_mse, gbuffer, mse_and_gradients, render_numpy,
                            white_level)
from ..model.scene import GEOMETRY_KEYS, FabricScene, LightRig, View, build_scene
from ..params import CONTINUOUS_KEYS, FIT_RANGES, Fabric
from ..photo import CLIPPED_SHARE
from .config import FitConfig

DISCRETE_STEPS = {"plies": (1, 1), "fibers": (1, 4)}  # smallest and largest |change| of a proposal
BODY_COLOUR_KEYS = ("warp.body_reflection", "warp.body_subsurface", "weft.body_reflection", "weft.body_subsurface")
#: the highlights' colours: a rise of the rig's gain must not brighten them
SPECULAR_COLOUR_KEYS = ("specular.reflection", "specular.transmission", "specular.transmission_exit")
#: the photo determines a channel of the rig's gain when its standard error is at most this share
GAIN_DETERMINED = 0.05
#: ... from at least this many pixels that are wholly gap in the render and unclipped in the photo
GAIN_MIN_PIXELS = 12


@dataclass
class FitResult:
    """What :func:`fit` found.

    Attributes
    ----------
    fabric : the best fabric seen (lowest loss)
    loss : its MSE
    history : (steps,) MSE at each gradient step
    iterations : gradient steps taken
    seconds : wall time
    stopped : "converged", "budget" or "iterations"
    moves : proposals and acceptances per kind of discrete move
    rig : the light rig of the best fabric, with its fitted gain (the photo's exposure and
        white balance; :class:`weavecap.model.scene.LightRig`)
    """

    fabric: Fabric
    loss: float
    history: list[float]
    iterations: int
    seconds: float
    stopped: str
    moves: dict = field(default_factory=dict)
    rig: LightRig | None = None


class _Vector:
    """The continuous parameters being fitted as one vector scaled to [0, 1] by Table 1."""

    def __init__(self, fs: FabricScene, keys: list[str]):
        self.keys = keys
        self.slices, lo, hi, start = {}, [], [], 0
        for key in keys:
            n = np.atleast_1d(np.asarray(fs.fabric.get(key), dtype=np.float64)).size
            self.slices[key] = slice(start, start + n)
            lo += [FIT_RANGES[key][0]] * n
            hi += [FIT_RANGES[key][1]] * n
            start += n
        self.lo, self.hi = np.array(lo), np.array(hi)

    def read(self, fabric: Fabric) -> np.ndarray:
        raw = np.concatenate([np.atleast_1d(np.asarray(fabric.get(k), dtype=np.float64)) for k in self.keys])
        return (raw - self.lo) / (self.hi - self.lo)

    def raw(self, unit: np.ndarray) -> np.ndarray:
        return self.lo + unit * (self.hi - self.lo)

    def write(self, fs: FabricScene, unit: np.ndarray) -> None:
        raw = self.raw(unit)
        for key in self.keys:
            v = raw[self.slices[key]]
            fs.set(key, tuple(v) if v.size == 3 else float(v[0]))

    def gather(self, grads: dict[str, np.ndarray]) -> np.ndarray:
        """d loss / d unit-scaled parameter."""
        g = np.concatenate([np.atleast_1d(grads[k]) for k in self.keys])
        return g * (self.hi - self.lo)


def barrier(raw: np.ndarray, lo: np.ndarray, hi: np.ndarray, lam: float) -> tuple[float, np.ndarray]:
    """Eq. 5 (read as a penalty outside [lo, hi]): value and gradient with respect to ``raw``."""
    below, above = np.maximum(0.0, lo - raw), np.maximum(0.0, raw - hi)
    return float(lam * np.sum(below**2 + above**2)), lam * 2.0 * (above - below)


class _Annealer:
    """Discrete proposals and the Metropolis rule of §6.2."""

    def __init__(self, fs: FabricScene, config: FitConfig, rng: np.random.Generator, *, radius_mode: str,
                 fixed: frozenset[str]):
        self.fs, self.config, self.rng = fs, config, rng
        self.temperature = config.anneal_t0
        self.kinds = [k for k in ("plies", "fibers") if k not in fixed]
        if radius_mode == "anneal":
            self.kinds += [k for k in GEOMETRY_KEYS if k not in fixed]
        self.moves = {k: [0, 0] for k in self.kinds}

    def _propose(self, kind: str):
        lo, hi = FIT_RANGES[kind]
        if kind in DISCRETE_STEPS:
            current = int(round(float(np.asarray(self.fs.values[kind]).ravel()[0])))
            a, b = DISCRETE_STEPS[kind]
            step = int(self.rng.integers(a, b + 1)) * int(self.rng.choice([-1, 1]))
            return int(np.clip(current + step, lo, hi))
        return float(np.clip(self._current(kind) + self.rng.choice([-1, 1]) * self.config.radius_step, lo, hi))

    def _current(self, kind: str):
        if kind in DISCRETE_STEPS:
            return float(np.asarray(self.fs.values[kind]).ravel()[0])
        return float(self.fs.fabric.get(kind))

    def step(self, measure: Callable[[], float]) -> float:
        """Propose one move; ``measure()`` is the loss of the scene's current state. Returns the
        loss of the state kept."""
        loss = measure()
        if not self.kinds:
            return loss
        kind = self.kinds[self.rng.integers(len(self.kinds))]
        old, new = self._current(kind), self._propose(kind)
        self.moves[kind][0] += 1
        self.fs.set(kind, new)
        new_loss = measure()
        rise = 1e4 * (new_loss - loss) / max(loss, 1e-12)  # basis points of the loss
        accept = rise <= 0 or self.rng.random() < math.exp(-rise / max(self.temperature, 1e-9))
        self.temperature *= self.config.anneal_decay
        if accept:
            self.moves[kind][1] += 1
            return new_loss
        self.fs.set(kind, old)
        return loss


def scan_plies(fs: FabricScene, measure: Callable[[], float]) -> dict:
    """A T = 0 global move on the number of plies: try every count of Table 1's range with
    everything else fixed and keep the lowest loss. ``measure()`` is the loss of the scene's
    current state. Returns the renders made, whether the count changed, and the loss's range
    over the counts relative to its minimum (how much the photo tells them apart).

    The Metropolis proposals of :class:`_Annealer` change the count by one at a time; from a
    start far off (the initializer barely sees plies) it takes several accepted moves to
    arrive, and meanwhile the continuous values adapt to the wrong count. With the other values
    right, the loss over plies has one clear minimum at the truth (bench photos: within 1).
    Fibres are not scanned: a yarn's ~30 fibre grooves are finer than a pixel at the fit's
    16–24 px a cell, and the loss over fibres is flat but for a spike at the exact count
    (measured on forward-model renders at 16 and 32 px a cell) — nothing a scan could home in on.
    """
    lo, hi = FIT_RANGES["plies"]
    current = int(round(float(np.asarray(fs.values["plies"]).ravel()[0])))
    tried = {current: measure()}
    for n in range(int(lo), int(hi) + 1):
        if n not in tried:
            fs.set("plies", n)
            tried[n] = measure()
    best = min(tried, key=tried.get)
    fs.set("plies", best)
    spread = (max(tried.values()) - tried[best]) / max(tried[best], 1e-12)
    return {"renders": len(tried) - 1, "changed": int(best != current), "range": float(spread)}


def _range_scale(systems: list, k_now: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> float:
    """The common factor s on the gain of channels the photo does not pin: the smallest s
    (from 1 / max k, i.e. a gain of at least 1, up to 64) at which the colours, within their
    range, explain those channels as well as colours without an upper bound would (within
    0.1 % of the loss; bisection between factors 1.25 apart). The colour-free light (k × the
    rest) is held at the current gain meanwhile: let it grow with s, and a specular term could
    stand in for the colours at any gain (a fabric photographed a stop darker came out with a
    higher gain and black yarns).

    ``systems``: per channel (colour bases a, colour-free part d, target t).
    """
    from scipy.optimize import lsq_linear

    # ||k f a x - b||² = ||k f r x - qᵀb||² + (||b||² - ||qᵀb||²) with a = q r: each loss below
    # solves an (n, n) problem in place of one over every pixel
    reduced = []
    for (a, d, t), k in zip(systems, k_now):
        b = t - k * d
        q, r = np.linalg.qr(a)
        qb = q.T @ b
        reduced.append((k * r, qb, max(float(b @ b - qb @ qb), 0.0)))

    def loss(f: float, upper) -> float:
        total = 0.0
        for kr, qb, rest in reduced:
            x = lsq_linear(f * kr, qb, bounds=(lo, upper), method="bvls").x
            total += float(np.sum((f * kr @ x - qb) ** 2)) + rest
        return total

    unbounded = loss(1.0, np.inf)
    good = unbounded + 1e-3 * abs(unbounded) + 1e-15
    factors = float(1.0 / k_now.max()) * 1.25 ** np.arange(0, 64)
    factors = factors[factors <= 64.0]
    i = next((n for n, f in enumerate(factors) if loss(f, hi) <= good), None)
    if i is None:
        return float(factors[-1])
    if i == 0:
        return float(factors[0])
    lo_f, hi_f = float(factors[i - 1]), float(factors[i])  # the smallest good factor, by bisection
    for _ in range(12):
        mid = 0.5 * (lo_f + hi_f)
        lo_f, hi_f = (lo_f, mid) if loss(mid, hi) <= good else (mid, hi_f)
    return hi_f


def solve_colours(fs: FabricScene, target: np.ndarray, measure: Callable[[], float], *, spp: int,
                  blur_px: float, keys: tuple[str, ...] = BODY_COLOUR_KEYS, gain: bool = False) -> dict:
    """A T = 0 global move on the body colours R^B and S^B of warp and weft (§3.3), and with
    ``gain`` on the rig's gain (the photo's exposure and white balance,
    :class:`weavecap.model.scene.LightRig`): solve them all at once in closed form with
    everything else fixed, and keep the result if it lowers the loss. ``measure()`` is the
    loss of the scene's current state. Returns the renders made, whether anything changed,
    and the gain and how it was decided.

    The render is linear in the body colours (the rest of the light does not depend on them),
    so one render with every body colour black and one per colour set to white give, channel
    by channel, a linear least-squares problem, solved on the target's unclipped pixels.
    Gradient steps can leave the colours stuck: once the render glows above the camera's white
    level (a back-lit clear yarn) or a colour sits at 0 with the specular terms standing in
    for it, the gradient that would bring it back is zero or points away. A random 2×3 of the
    fit bench, started from an initializer guess with a black warp, ended with both body
    colours black at 31.2 dB; with one solve at 70% of each round it reaches 35.2 dB.

    The gain k multiplies the whole render. Only what depends on no fitted value fixes k_c:
    the back light seen through the gaps, on the pixels that are wholly gap in the render and
    not clipped in the photo (highlights and transmitted light carry R^S and T^S, which the
    gradient steps fit; a gap's edge moves with the radii), and only under a rig lit from the
    back (:attr:`weavecap.model.scene.LightRig.backdrop_is_reference`): a front-lit rig's
    backdrop is the room, of no known colour, and on dense real cloth its "gaps" show fibres
    and shadows — read as the light's colour, they gave 35 of the real-photo bench's 141
    captures (all under ``front``) a coloured light and the fabric the opposite cast. Where
    there are too few such pixels (:data:`GAIN_MIN_PIXELS`: dark, clipped or thin gaps) or they
    spread too much (a standard error of k_c over :data:`GAIN_DETERMINED` of it), or the rig is
    front-lit, the photo does not determine k_c: those channels' gain is scaled evenly by the
    smallest factor (a gain of at least 1 in the largest channel) whose colours, within their
    Table 1 range, explain the photo as well as any (:func:`_range_scale`) — a photo brighter
    than the rig's white fabric gets the exposure that brings it within reach instead of
    colours at the clamp.
    """
    from scipy.optimize import lsq_linear

    keys = [k for k in keys if k in fs.values and k not in fs.textures]
    if not keys:
        return {"renders": 0, "changed": 0}
    before = {k: fs.to_fabric().get(k) for k in keys}
    rig_before = fs.rig
    current = measure()

    def shown() -> np.ndarray:  # the render as photographed, before the camera's clipping
        return blur(render_numpy(fs, spp=spp), blur_px).astype(np.float64)

    k_now = np.asarray(fs.rig.gain, np.float64)
    if gain:
        fs.rig = fs.rig.with_gain(1.0)  # the bases at unit gain; k is solved for
    for k in keys:
        fs.set(k, (0.0, 0.0, 0.0))
    dark = shown()
    g = gbuffer(fs, spp=spp, seed=0)
    seen_gap = 1.0 - np.array(g.hit, dtype=np.float64).reshape(*g.shape, g.spp).mean(axis=2)
    basis = []
    for k in keys:
        fs.set(k, (1.0, 1.0, 1.0))
        basis.append(shown() - dark)
        fs.set(k, (0.0, 0.0, 0.0))
    target = np.asarray(target, dtype=np.float64)
    seen = target < CLIPPED_SHARE * white_level(target)  # clipped: no word on a colour that only brightens
    lo, hi = (np.array(bounds) for bounds in zip(*(FIT_RANGES[k] for k in keys)))
    systems = []  # per channel: (colour bases, colour-free part, target) where unclipped
    for ch in range(3):
        m = seen[..., ch].ravel() & np.isfinite(target[..., ch].ravel())
        systems.append(None if m.sum() < len(keys) + 2 else
                       (np.stack([b[..., ch].ravel()[m] for b in basis], axis=1), dark[..., ch].ravel()[m],
                        target[..., ch].ravel()[m]))
    k_new, determined = k_now.copy(), np.zeros(3, bool)
    if gain:
        # only what no fitted value shapes fixes k_c: the back light seen through the gaps, on
        # the pixels that are wholly gap in the render (a radius a little off moves the rest)
        # and not clipped in the photo; the robust spread of photo / backdrop there gives its error
        from scipy.ndimage import binary_erosion

        pure = binary_erosion(seen_gap >= 1.0, iterations=1 + int(np.ceil(2 * blur_px)), border_value=1)
        for ch in range(3):
            where = pure & seen[..., ch] & np.isfinite(target[..., ch])
            if not fs.rig.backdrop_is_reference or where.sum() < GAIN_MIN_PIXELS:
                continue
            ratio = target[..., ch][where] / fs.rig.backdrop
            k_c = float(np.median(ratio))
            spread = 1.4826 * float(np.median(np.abs(ratio - k_c)))
            se = spread / np.sqrt(where.sum() / (2 * blur_px + 1) ** 2)
            if k_c > 0 and se <= GAIN_DETERMINED * k_c:
                k_new[ch], determined[ch] = k_c, True
        free = ~determined & np.array([sy is not None for sy in systems])
        if free.any():  # not fixed by the photo: one scale over those channels, set by the range
            k_new[free] = k_now[free] * _range_scale([systems[ch] for ch in np.flatnonzero(free)], k_now[free],
                                                     lo, hi)

    def solved(ch: int) -> np.ndarray:  # the colours within their range at the gain k_new
        if systems[ch] is None:
            return np.array([np.mean(before[k][ch]) for k in keys])
        a, d, t = systems[ch]
        scale = k_new[ch] if gain else 1.0  # without ``gain`` the bases carry the rig's gain
        return lsq_linear(scale * a, t - scale * d, bounds=(lo, hi)).x

    colours = np.stack([solved(ch) for ch in range(3)], axis=1)
    colours = np.clip(colours, lo[:, None], hi[:, None])
    if gain:
        fs.rig = fs.rig.with_gain(k_new)
    for k, colour in zip(keys, colours):
        fs.set(k, tuple(colour))
    changed = measure() < current
    if not changed:
        fs.rig = rig_before
        for k, colour in before.items():
            fs.set(k, colour)
    out = {"renders": len(keys) + 2, "changed": int(changed)}
    if gain:
        out.update(gain=[round(float(v), 4) for v in fs.rig.gain], gain_determined=[bool(v) for v in determined])
    return out


def match_family_colours(fs: FabricScene, target: np.ndarray, measure: Callable[[], float], *, spp: int,
                         blur_px: float, gain: bool = False) -> dict:
    """End on the photo's own yarn colours (§5.2): scale each family's body colours (R^B and
    S^B together, per channel) so that the render's mean colour over the centres of the cells
    where that family is on top equals the photo's there
    (:func:`weavecap.fit.fidelity.family_masks`, the masks the fidelity figures use).

    The MSE weighs every pixel alike, so a fit can trade the yarn centres' colour for the gaps,
    the edges or the highlights; what a person sees of a yarn is its colour where it lies on
    top. The render is linear in each family's colours, so three renders (both families black,
    each alone at its colour) give a 2 × 2 system per channel. Colours stay within [0, 1];
    with ``gain`` a colour that would pass 1 raises the rig's gain (all channels alike)
    instead, and every colour comes down by as much — the highlights' colours too
    (:data:`SPECULAR_COLOUR_KEYS`), which the gain would otherwise brighten (on a bench photo
    with its warp at the clamp, a cyan warp's colour had gone into the highlight). Returns
    the renders made, the loss before and after, and the scales.
    """
    from .fidelity import family_masks

    pattern = fs.fabric.pattern
    masks = family_masks(pattern, target.shape[:2])
    families = [f for f in ("warp", "weft") if masks[f].any()]
    keys = {f: [k for k in (f"{f}.body_reflection", f"{f}.body_subsurface") if k in fs.values and k not in fs.textures]
            for f in families}
    before = {k: fs.to_fabric().get(k) for f in families for k in keys[f]}
    loss_before = measure()

    def shown() -> np.ndarray:
        return blur(render_numpy(fs, spp=spp), blur_px).astype(np.float64)

    # each colour scales along its own direction, or white where it is (nearly) black
    direction = {k: np.where(np.asarray(v, np.float64) > 0.02, np.asarray(v, np.float64), 1.0)
                 for k, v in before.items()}
    target = np.asarray(target, np.float64)

    def wanted() -> tuple[dict, np.ndarray]:
        """The body colours that match the photo at the centres, at the current rig and
        highlights (the render is linear in each family's colours: a 2 × 2 system per channel)."""
        for k in before:
            fs.set(k, (0.0, 0.0, 0.0))
        dark = shown()
        parts = {}
        for f in families:
            for k in keys[f]:
                fs.set(k, tuple(direction[k]))
            parts[f] = shown() - dark
            for k in keys[f]:
                fs.set(k, (0.0, 0.0, 0.0))
        scale = np.ones((len(families), 3))
        for ch in range(3):
            a = np.array([[parts[g][..., ch][masks[f]].mean() for g in families] for f in families])
            b = np.array([target[..., ch][masks[f]].mean() - dark[..., ch][masks[f]].mean() for f in families])
            if abs(np.linalg.det(a)) > 1e-12:
                scale[:, ch] = np.clip(np.linalg.solve(a, b), 0.0, None)
        return {k: direction[k] * scale[i] for i, f in enumerate(families) for k in keys[f]}, scale

    colours, scale = wanted()
    renders = 1 + len(families)
    over = max(1.0, max(float(v.max()) for v in colours.values())) if gain else 1.0
    if over > 1.0:
        fs.rig = fs.rig.with_gain(np.asarray(fs.rig.gain) * over)
        for k in SPECULAR_COLOUR_KEYS:
            if k in fs.values and k not in fs.textures:
                fs.set(k, tuple(np.asarray(fs.to_fabric().get(k), np.float64) / over))
        # the transmitted highlights share the light with the body lobes: dimmer, they leave
        # the bodies brighter, so the colours are solved again at the new gain
        colours, scale = wanted()
        renders += 1 + len(families)
    for k, v in colours.items():
        fs.set(k, tuple(np.clip(v, 0.0, 1.0)))
    return {"renders": renders + 1, "loss_before": loss_before, "loss_after": measure(),
            "scale": {f: [round(float(v), 4) for v in scale[i]] for i, f in enumerate(families)}}


def end_on_family_colours(fabric: Fabric, rig: LightRig, target: np.ndarray, *, config: FitConfig, blur_px: float,
                          gain: bool, by_look: bool) -> tuple[Fabric, LightRig, float | None, dict]:
    """``fabric`` under ``rig`` ended on the photo's own yarn colours (:func:`match_family_colours`,
    §5.2), the match kept when the loss rises by at most ``config.family_colour_tolerance``, or,
    with ``by_look``, by more when the capture looks more like the photo for it
    (:func:`weavecap.fit.fidelity.more_faithful`). ``target`` (H, W, 3) the photo's repeat,
    ``gain``: the match may raise the rig's gain. Returns the fabric and rig kept, the loss
    after the match (None when it was not kept) and the report's note (with ``by_look``, the
    fidelity figures before and after; without, none are rendered)."""
    from .fidelity import fidelity, more_faithful

    h, w = target.shape[:2]
    fs = build_scene(fabric, View(tiles=(1, 1), size=max(h, w), spp=config.spp), light=rig)
    white = white_level(target)

    def measure() -> float:
        return blurred_mse(render_numpy(fs, spp=config.spp), target, blur_px)

    def faithful():  # the figures the report gives, on the scene's current state
        return fidelity(target, as_photographed(render_numpy(fs, spp=config.spp), blur_px, white), fs.fabric.pattern)

    was = faithful() if by_look else None  # the look only matters when it may keep the match
    matched = match_family_colours(fs, target, measure, spp=config.spp, blur_px=blur_px, gain=gain)
    rise = matched["loss_after"] / max(matched["loss_before"], 1e-12) - 1
    note = {"renders": matched["renders"], "scale": matched["scale"], "loss_rise": round(rise, 4),
            "judged_by_look": by_look}
    kept = rise <= config.family_colour_tolerance
    if by_look:
        now = faithful()
        kept = kept or more_faithful(now, was, min_sharpness=config.faithful_sharpness,
                                     max_delta_e=config.faithful_delta_e)
        note.update(renders=matched["renders"] + 2,
                    delta_e_before={k: round(v, 2) for k, v in was.delta_e.items() if np.isfinite(v)},
                    delta_e_after={k: round(v, 2) for k, v in now.delta_e.items() if np.isfinite(v)},
                    sharpness=[round(was.sharpness, 3), round(now.sharpness, 3)],
                    structure=[round(was.structure, 3), round(now.structure, 3)])
    note["kept"] = kept
    if kept:
        return fs.to_fabric(), fs.rig, matched["loss_after"], note
    return fabric, rig, None, note


def _pattern_sweep(fs: FabricScene, target: np.ndarray, *, spp: int, blur_px: float,
                   locked: np.ndarray | None = None) -> dict:
    """Re-run §5.1's batched T = 0 pattern annealing with the fit's current values, and keep
    its pattern (it only accepts flips that lower the error); ``locked`` cells keep their state."""
    from ..estimate.forward import RepeatRenderer
    from ..estimate.pattern import anneal_pattern
    from ..estimate.sampling import interlaces

    before = fs.fabric.pattern.copy()
    c = target.shape[0] // before.shape[0]
    renderer = RepeatRenderer(fs.to_fabric(), cell_px=c, light=fs.rig, spp=spp, blur_cells=blur_px / c,
                              white=white_level(target))
    result = anneal_pattern(target, renderer, start=before, match_colour=False, locked=locked)
    # a woven fabric interlaces: a yarn that is on top (or under) across the whole repeat would
    # not be held in place, so such a sweep result is a fit artefact and is not kept
    keep = not np.array_equal(result.pattern, before) and (interlaces(result.pattern) or not interlaces(before))
    if keep:
        fs.set("pattern", result.pattern)
    else:
        result = dataclasses.replace(result, pattern=before)
    return {"changed": int(np.sum(result.pattern != before)), "renders": result.renders}


class _RadiusSearch:
    """Greedy pattern search on the yarn radii, which no rendering gradient reaches smoothly:
    try ±δ on each radius, keep an improvement, halve δ when neither side helps."""

    def __init__(self, fs: FabricScene, config: FitConfig, keys: list[str]):
        self.fs, self.keys = fs, keys
        self.step_size = {k: config.radius_step for k in keys}
        self.min_step = config.radius_min_step
        self.moves = {k: [0, 0] for k in keys}

    def step(self, measure: Callable[[], float]) -> float:
        """One round over the radii; ``measure()`` is the loss of the scene's current state."""
        loss = measure()
        for key in self.keys:
            delta = self.step_size[key]
            if delta < self.min_step:
                continue
            r0 = float(self.fs.fabric.get(key))
            lo, hi = FIT_RANGES[key]
            best_r, best_loss = r0, loss
            for r in (min(hi, r0 + delta), max(lo, r0 - delta)):
                if r == r0:
                    continue
                self.moves[key][0] += 1
                self.fs.set(key, r)
                trial = measure()
                if trial < best_loss:
                    best_r, best_loss = r, trial
            if best_r != r0:
                self.moves[key][1] += 1
            else:
                self.step_size[key] = delta / 2
            self.fs.set(key, best_r)
            loss = best_loss
        return loss


def fit(target: np.ndarray, start: Fabric, *, config: FitConfig = FitConfig(), light: str | LightRig = "both",
        seed: int = 0, budget_s: float | None = None, fixed: frozenset[str] = frozenset(), blur_px: float = 0.0,
        radius_mode: str = "search", votes: np.ndarray | None = None, by_look: bool = True,
        progress: Callable[[int, int, float], None] | None = None) -> FitResult:
    """Fit ``start`` to ``target``, one repeat of the photo (§6).

    Parameters
    ----------
    target : (n_e * c, n_a * c, 3) float32 linear RGB, the cell canvas of one repeat of the
        photo (:func:`weavecap.estimate.cells.cell_canvas`, c = :func:`.config.cell_px_for`)
    start : the pre-estimate (pattern, colours, initializer's values)
    config : hyper-parameters (see :data:`weavecap.fit.config.PRESETS`)
    light : the light rig (§6.4): a name, or a :class:`~weavecap.model.scene.LightRig` whose
        gain (the photo's exposure and white balance) is fitted with the body colours unless
        ``"light.gain"`` is in ``fixed``
    blur_px : σ (canvas px) of the smoothing the target went through (§4.2's regularization);
        renders are blurred alike before they are compared (:func:`weavecap.model.render.blur`)
    seed : seeds the annealing; the same seed gives the same result
    budget_s : stop after this many seconds (the best state so far is returned)
    fixed : names not to fit: ``"pattern"``, ``"plies"``, ``"fibers"``, radii or continuous keys
    votes : (n_e, n_a) model-free votes on the target (:func:`weavecap.estimate.orientation.cell_votes`,
        > 0: weft on top); cells voted at least ``config.vote_lock`` either way take the
        vote's state and keep it (the pattern sweeps do not flip them)
    by_look : the end's family-colour match may be kept for the look as well as for the loss
        (:func:`end_on_family_colours`)
    radius_mode : how the radii are fitted: ``"search"`` (greedy pattern search every
        ``config.radius_every`` steps), ``"anneal"`` (Metropolis proposals among the discrete
        moves) or ``"gradient"`` (finite-difference gradients inside Adam)
    progress : called after each step with (step, iterations, loss)
    """
    t0 = time.perf_counter()
    target = np.asarray(target, dtype=np.float64)
    h, w = target.shape[:2]
    locked = None
    if votes is not None and "pattern" not in fixed:
        from ..estimate.orientation import vote_pattern
        from ..estimate.sampling import interlaces

        locked = np.abs(np.asarray(votes)) >= config.vote_lock
        voted = np.where(locked, vote_pattern(votes), start.pattern).astype(np.uint8)
        if not locked.any() or not (interlaces(voted) or not interlaces(start.pattern)):
            locked = None
        elif not np.array_equal(voted, start.pattern):
            start = start.replace({"pattern": voted})
    fs = build_scene(start, View(tiles=(1, 1), size=max(h, w), spp=config.spp), light=light)
    if fs.frame.shape != (h, w):
        raise ValueError(f"target is {h}x{w} px but a repeat of the {start.shape} pattern renders at "
                         f"{fs.frame.shape[0]}x{fs.frame.shape[1]}")
    free_radii = [k for k in GEOMETRY_KEYS if k not in fixed]
    geometry = free_radii if radius_mode == "gradient" else []
    keys = [k for k in CONTINUOUS_KEYS if k not in fixed and k not in fs.textures
            and (k not in GEOMETRY_KEYS or k in geometry)]
    vec = _Vector(fs, keys)

    def measure() -> float:
        return blurred_mse(render_numpy(fs, spp=config.spp), target, blur_px)

    unit = torch.tensor(np.clip(vec.read(start), 0.0, 1.0), dtype=torch.float64, requires_grad=True)
    adam = torch.optim.Adam([unit], lr=config.learning_rate)
    # the step shrinks along a cosine to a tenth: big moves first, then settling into the minimum
    schedule = torch.optim.lr_scheduler.CosineAnnealingLR(adam, T_max=config.iterations,
                                                          eta_min=0.1 * config.learning_rate)
    annealer = _Annealer(fs, config, np.random.default_rng(seed), radius_mode=radius_mode, fixed=fixed)
    search = _RadiusSearch(fs, config, free_radii if radius_mode == "search" else [])
    pattern_free = config.pattern_moves and "pattern" not in fixed and start.pattern.size > 1
    sweep_steps = {max(1, int(f * config.iterations)) for f in config.pattern_sweeps} if pattern_free else set()
    sweeps: list[dict] = []
    scan_steps = {max(1, int(f * config.iterations)) for f in config.plies_scans} if "plies" not in fixed else set()
    scans: list[dict] = []
    colour_keys = tuple(k for k in BODY_COLOUR_KEYS if k in keys)
    solve_steps = {max(1, int(f * config.iterations)) for f in config.colour_solves} if colour_keys else set()
    solves: list[dict] = []

    fit_gain = "light.gain" not in fixed
    best_loss, best_fabric, best_rig, history, stopped = math.inf, start, fs.rig, [], "iterations"
    step = 0
    for step in range(1, config.iterations + 1):
        loss, grads, _ = mse_and_gradients(fs, target, keys, spp=config.spp, blur_px=blur_px)
        if loss < best_loss:
            best_loss, best_fabric, best_rig = loss, fs.to_fabric(), fs.rig
        history.append(loss)
        raw = vec.raw(unit.detach().numpy())
        _, g_barrier = barrier(raw, vec.lo, vec.hi, config.barrier_lambda)
        unit.grad = torch.from_numpy(vec.gather(grads) + g_barrier * (vec.hi - vec.lo))
        adam.step()
        schedule.step()
        with torch.no_grad():
            unit.clamp_(0.0, 1.0)
        vec.write(fs, unit.detach().numpy())
        if step % config.anneal_every == 0:
            annealer.step(measure)
        if step in sweep_steps:
            sweeps.append(_pattern_sweep(fs, target, spp=config.spp, blur_px=blur_px, locked=locked))
        if step in scan_steps:
            scans.append(scan_plies(fs, measure))
            if len(scans) == 1 and scans[0]["range"] < config.plies_flat:
                # the photo does not tell the count apart: hold the start's, spend nothing more on it
                fs.set("plies", start.plies)
                scan_steps = set()
                annealer.kinds = [k for k in annealer.kinds if k != "plies"]
        if step in solve_steps:
            solves.append(solve_colours(fs, target, measure, spp=config.spp, blur_px=blur_px, keys=colour_keys,
                                        gain=fit_gain))
            if solves[-1]["changed"]:  # Adam goes on from the solved colours, its momentum there spent
                moved = np.concatenate([np.arange(vec.slices[k].start, vec.slices[k].stop) for k in colour_keys])
                with torch.no_grad():
                    unit[moved] = torch.from_numpy(np.clip(vec.read(fs.to_fabric()), 0.0, 1.0)[moved])
                    state = adam.state.get(unit, {})
                    if "exp_avg" in state:
                        state["exp_avg"][moved] = 0.0
        if search.keys and (step - 1) % config.radius_every == 0:
            search.step(measure)
        if progress is not None:
            progress(step, config.iterations, loss)
        if budget_s is not None and time.perf_counter() - t0 > budget_s:
            stopped = "budget"
            break
        window = config.converge_window
        if len(history) > window and min(history[-window:]) > min(history[:-window]) * (1 - config.converge_tol):
            stopped = "converged"
            break
    final = measure()
    if final < best_loss:
        best_loss, best_fabric, best_rig = final, fs.to_fabric(), fs.rig
    moves = {k: {"proposed": v[0], "accepted": v[1]} for k, v in {**annealer.moves, **search.moves}.items()}
    if config.family_colours and colour_keys:  # end on the photo's own yarn colours
        pinned = bool(solves) and any(solves[-1].get("gain_determined", []))  # the gaps fixed the gain
        best_fabric, best_rig, matched_loss, moves["family_colours"] = end_on_family_colours(
            best_fabric, best_rig, target, config=config, blur_px=blur_px, gain=fit_gain and not pinned,
            by_look=by_look)
        best_loss = best_loss if matched_loss is None else matched_loss
    if sweeps:
        moves["pattern"] = {"sweeps": len(sweeps), "cells_changed": sum(s["changed"] for s in sweeps),
                            "renders": sum(s["renders"] for s in sweeps),
                            "cells_locked_by_votes": int(locked.sum()) if locked is not None else 0}
    if solves:
        moves["colour_solve"] = {"solves": len(solves), "changed": sum(s["changed"] for s in solves),
                                 "renders": sum(s["renders"] for s in solves)}
        if fit_gain:
            moves["colour_solve"]["gain_determined"] = solves[-1]["gain_determined"]
    if scans:
        moves["plies_scan"] = {"scans": len(scans), "changed": sum(s["changed"] for s in scans),
                               "renders": sum(s["renders"] for s in scans),
                               "loss_range": round(scans[0]["range"], 4), "flat": scans[0]["range"] < config.plies_flat}
    return FitResult(fabric=best_fabric, loss=best_loss, history=history, iterations=step,
                     seconds=time.perf_counter() - t0, stopped=stopped, moves=moves, rig=best_rig)
