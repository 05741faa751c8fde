"""Random fabrics over Table 1 (Wu et al. 2025 §5.3): training and held-out data.

Patterns come from the named families (plain, twill, satin, basket, rib) and from random
binary matrices in which every yarn interlaces; parameters are uniform over
:data:`weavecap.params.FIT_RANGES`. Colours: body colours uniform per channel; the body
subsurface colour is the body colour with a ±20% tint per channel (a yarn's transmitted colour
follows its reflected one); specular colours are a grey level with a ±15% tint (dielectric
highlights are nearly white). Every draw comes from the ``numpy.random.Generator`` passed in.
"""

from __future__ import annotations

from math import gcd

import numpy as np

from ..params import FIT_RANGES, Fabric, from_dict
from .repeats import canonical, minimal_repeat

FAMILIES = ("plain", "twill", "satin", "basket", "rib", "random")


def twill(over: int, under: int, *, step: int = 1) -> np.ndarray:
    """Twill ``over``/``under``: each weft floats over ``over`` warps, shifted by ``step`` per row."""
    n = over + under
    row = np.array([1] * over + [0] * under, dtype=np.uint8)
    return np.stack([np.roll(row, step * i) for i in range(n)])


def satin(n: int, step: int) -> np.ndarray:
    """Weft-faced satin of ``n`` with move number ``step`` (coprime with ``n``)."""
    p = np.ones((n, n), dtype=np.uint8)
    p[np.arange(n), (np.arange(n) * step) % n] = 0
    return p


def regular_weaves(shape: tuple[int, int]) -> list[np.ndarray]:
    """Every named weave with a (wefts, warps) repeat of ``shape``, both faces, distinct up to
    a cyclic shift: plain (2×2), twills a/b in both directions and satins n/s (n×n), basket
    k/k (2k×2k), ribs (2k×2 and 2×2k). Empty for shapes no named weave has."""
    return [p for _, p in _distinct(_regular(shape))]


def _regular(shape: tuple[int, int]) -> list[tuple[str, np.ndarray]]:
    """:func:`regular_weaves`' constructions with their families, one face each."""
    n_e, n_a = shape
    plain = np.array([[1, 0], [0, 1]], dtype=np.uint8)
    found: list[tuple[str, np.ndarray]] = []
    if n_e == n_a:
        n = n_e
        if n == 2:
            found.append(("plain", plain))
        found += [("twill", twill(a, n - a, step=d)) for a in range(1, n) for d in (-1, 1)] if n >= 3 else []
        found += [("satin", satin(n, k)) for k in range(2, n - 1) if gcd(k, n) == 1]
        if n % 2 == 0 and n >= 4:
            found.append(("basket", np.kron(plain, np.ones((n // 2, n // 2), dtype=np.uint8))))
    for rows, cols in ((n_e // 2, 1), (1, n_a // 2)):
        if min(n_e, n_a) == 2 and max(n_e, n_a) >= 4 and (rows * 2, cols * 2) == shape:
            found.append(("rib", np.kron(plain, np.ones((rows, cols), dtype=np.uint8))))
    return found


def _distinct(tagged: list[tuple[str, np.ndarray]]) -> list[tuple[str, np.ndarray]]:
    """``tagged`` (family, pattern) and every pattern's other face, each pattern once up to a
    cyclic shift (the first family it came with)."""
    distinct: dict[tuple, tuple[str, np.ndarray]] = {}
    for family, p in tagged + [(f, 1 - p) for f, p in tagged]:
        distinct.setdefault(canonical(p), (family, p.astype(np.uint8)))
    return list(distinct.values())


def point_twill(base: np.ndarray, leg: int) -> np.ndarray:
    """A point (zigzag) twill: the twill ``base`` (n × n) runs one way for ``leg`` warps and back
    for ``leg`` − 2, mirrored about each turn: (n, 2 leg − 2) wefts × warps (leg ≥ 3)."""
    n = base.shape[1]
    if leg < 3:
        raise ValueError(f"a point twill's leg is at least 3 warps, got {leg}")
    cols = list(range(leg)) + list(range(leg - 2, 0, -1))
    return base[:, [c % n for c in cols]].copy()


def herringbone(base: np.ndarray, leg: int) -> np.ndarray:
    """A herringbone (broken twill): the twill ``base`` (n × n) for ``leg`` warps, then its
    mirror image for ``leg`` warps, cut at each turn (the mirror moved by half the twill's
    repeat, so that the floats oppose there): (n, 2 leg) wefts × warps (leg ≥ 2)."""
    n = base.shape[1]
    if leg < 2:
        raise ValueError(f"a herringbone's leg is at least 2 warps, got {leg}")
    right = base[:, [c % n for c in range(leg)]]
    left = np.roll(base[:, [(-c) % n for c in range(leg)]], n // 2, axis=0)
    return np.concatenate([right, left], axis=1)


def broken_twills(shape: tuple[int, int]) -> list[tuple[str, int, int, int, str, np.ndarray]]:
    """The herringbones and point twills of a (wefts, warps) repeat ``shape``, built on the
    twills a/b of 3 to 8 yarns with legs of at least half the twill's repeat: legs of warps
    (the repeat n × 2 leg for a herringbone, n × (2 leg − 2) for a point twill) and, transposed,
    legs of wefts. Returns (kind, a, b, leg, ``"warps"`` or ``"wefts"``, pattern) each; both
    faces (a/b and b/a)."""
    found = []
    for rows, cols, along in ((shape[0], shape[1], "warps"), (shape[1], shape[0], "wefts")):
        if not 3 <= rows <= 8 or cols % 2 or cols < 4:
            continue
        for make, leg, kind in ((herringbone, cols // 2, "herringbone"), (point_twill, (cols + 2) // 2, "point twill")):
            if leg < max(2 if make is herringbone else 3, rows // 2):
                continue
            for over in range(1, rows):
                q = make(twill(over, rows - over), leg)
                found.append((kind, over, rows - over, leg, along, q.T if along == "wefts" else q))
    return found


def named_weaves(shape: tuple[int, int]) -> list[np.ndarray]:
    """Every named weave with a (wefts, warps) repeat of ``shape``, both faces, distinct up to
    a cyclic shift: :func:`regular_weaves`, plus the broken twills (:func:`broken_twills`:
    herringbones and point twills, by leg length) and the unequal baskets (hopsacks of
    a × b blocks). The pattern decision's library (:mod:`weavecap.estimate.decide`); the fit's
    named-weave starts keep to :func:`regular_weaves`."""
    return [p for _, p in named_weave_families(shape)]


def named_weave_families(shape: tuple[int, int]) -> list[tuple[str, np.ndarray]]:
    """:func:`named_weaves` with the family each comes from: ``plain``, ``twill``, ``satin``,
    ``basket``, ``rib`` or ``broken twill``."""
    n_e, n_a = shape
    extra = [("broken twill", q) for *_, q in broken_twills(shape)]
    if n_e % 2 == 0 and n_a % 2 == 0 and min(n_e, n_a) >= 4 and n_e != n_a:
        extra.append(("basket", np.kron(np.array([[1, 0], [0, 1]], dtype=np.uint8),
                                        np.ones((n_e // 2, n_a // 2), dtype=np.uint8))))
    extra = [(f, p) for f, p in extra if interlaces(p) and minimal_repeat(p).shape == p.shape]
    return _distinct(_regular(shape) + extra)


def interlaces(pattern: np.ndarray) -> bool:
    """Every weft and every warp has both states (no yarn floats over the whole repeat)."""
    return bool(interlacing(pattern))


def interlacing(patterns: np.ndarray) -> np.ndarray:
    """:func:`interlaces` of each pattern of a stack (..., n_e, n_a): a bool array (...,)."""
    p = np.asarray(patterns)
    return ((p.min(axis=-1).max(axis=-1) == 0) & (p.max(axis=-1).min(axis=-1) == 1)
            & (p.min(axis=-2).max(axis=-1) == 0) & (p.max(axis=-2).min(axis=-1) == 1))


def descend_by_flips(pattern: np.ndarray, score) -> tuple[np.ndarray, float]:
    """Greedy single-cell flips from ``pattern`` (n_e, n_a), every weft and warp kept
    interlacing: the flip that lowers ``score`` most, until none does. ``score`` maps a stack
    of patterns (k, n_e, n_a) to their (k,) values. Returns (pattern uint8, its score)."""
    p = np.asarray(pattern, dtype=np.uint8).copy()
    current = float(score(p[None])[0])
    while True:
        flips = np.repeat(p[None], p.size, axis=0)
        flips.reshape(p.size, -1)[np.arange(p.size), np.arange(p.size)] ^= 1
        ok = interlacing(flips)
        if not ok.any():
            break
        scores = np.full(p.size, np.inf)
        scores[ok] = score(flips[ok])
        k = int(np.argmin(scores))
        if scores[k] >= current - 1e-12:
            break
        p, current = flips[k], float(scores[k])
    return p, current


def random_binary(rng: np.random.Generator, shape: tuple[int, int]) -> np.ndarray:
    """A random (wefts, warps) 0/1 pattern in which every yarn interlaces."""
    while True:
        p = (rng.random(shape) < rng.uniform(0.3, 0.7)).astype(np.uint8)
        if interlaces(p):
            return p


def random_pattern(rng: np.random.Generator, *, family: str | None = None, max_size: int = 8) -> tuple[str, np.ndarray]:
    """A pattern of ``family`` (random family if None), at most ``max_size`` yarns per side.

    Returns (family, (wefts, warps) uint8 array); weft- and warp-faced versions (the complement)
    and both twill directions are equally likely.
    """
    family = family or str(rng.choice(FAMILIES))
    if family == "plain":
        p = np.array([[1, 0], [0, 1]], dtype=np.uint8)
    elif family == "twill":
        n = int(rng.integers(3, min(8, max_size) + 1))
        over = int(rng.integers(1, n))
        p = twill(over, n - over, step=int(rng.choice([-1, 1])))
    elif family == "satin":
        n = int(rng.choice([k for k in (5, 7, 8) if k <= max_size] or [5]))
        steps = [s for s in range(2, n - 1) if gcd(s, n) == 1]
        p = satin(n, int(rng.choice(steps)))
    elif family == "basket":
        k = int(rng.integers(2, max(2, min(4, max_size // 2)) + 1))
        p = np.kron(np.array([[1, 0], [0, 1]], dtype=np.uint8), np.ones((k, k), dtype=np.uint8))
    elif family == "rib":
        k = int(rng.integers(2, max(2, min(4, max_size // 2)) + 1))
        block = np.ones((k, 1), dtype=np.uint8) if rng.random() < 0.5 else np.ones((1, k), dtype=np.uint8)
        p = np.kron(np.array([[1, 0], [0, 1]], dtype=np.uint8), block)
    elif family == "random":
        p = random_binary(rng, (int(rng.integers(2, max_size + 1)), int(rng.integers(2, max_size + 1))))
    else:
        raise ValueError(f"unknown pattern family {family!r}; one of {', '.join(FAMILIES)}")
    if rng.random() < 0.5:
        p = 1 - p
    return family, p.astype(np.uint8)


def _uniform(rng: np.random.Generator, key: str) -> float:
    lo, hi = FIT_RANGES[key]
    return float(rng.uniform(lo, hi))


def _tinted(rng: np.random.Generator, base, spread: float) -> list[float]:
    return np.clip(np.asarray(base) * rng.uniform(1 - spread, 1 + spread, 3), 0.0, 1.0).tolist()


def random_fabric(rng: np.random.Generator, pattern: np.ndarray) -> Fabric:
    """A fabric with ``pattern`` and every other parameter drawn over Table 1's ranges."""
    def yarn(name: str) -> dict:
        body = rng.uniform(0.0, 1.0, 3)
        return {"radius": _uniform(rng, f"{name}.radius"), "body_reflection": body.tolist(),
                "body_subsurface": _tinted(rng, body, 0.2)}

    def grey() -> list[float]:
        return _tinted(rng, [rng.uniform(0.0, 1.0)] * 3, 0.15)

    doc = {
        "format": "weavecap.params/1",
        "pattern": np.asarray(pattern).astype(int).tolist(),
        "plies": int(rng.integers(FIT_RANGES["plies"][0], FIT_RANGES["plies"][1] + 1)),
        "fibers": int(rng.integers(FIT_RANGES["fibers"][0], FIT_RANGES["fibers"][1] + 1)),
        "warp": yarn("warp"), "weft": yarn("weft"),
        "specular": {
            "coefficient": _uniform(rng, "specular.coefficient"), "reflection": grey(),
            "transmission": grey(), "transmission_exit": grey(),
            "roughness": _uniform(rng, "specular.roughness"), "roughness_exit": _uniform(rng, "specular.roughness_exit"),
            "ior": _uniform(rng, "specular.ior"), "ior_exit": _uniform(rng, "specular.ior_exit"),
            "attenuation": _uniform(rng, "specular.attenuation"),
        },
        "body_attenuation": _uniform(rng, "body_attenuation"),
        "shadowing": {"ply": _uniform(rng, "shadowing.ply"), "fiber": _uniform(rng, "shadowing.fiber")},
    }
    return from_dict(doc)
