"""The BLIDF network (Son et al.): local inter-reflection from fold, light and material descriptors.

For a light of irradiance E from direction ω_i, the local outgoing radiance at x_o is

    L_local(x_o) = E · ρ(x_o) · Σ_s V̄_s(x_o, ω_i) · gain_θ,s(φ_S, φ_L, φ_M, ω_i)

(the supplement's integral over ω_i for a directional light; ρ(x_o) is the albedo the fabric
shows at x_o — its texture, at render time; S_θ = ρ(x_o) · gain the BLIDF). V̄_s are four
shares (:data:`SHARES`, each :func:`.visibility.lit_share`): of the neighbourhood x_o's side
sees, the part lit on the side facing x_o (s = 0) and on its far side, whose light a
translucent fabric lets through (s = 1); and the same two of the neighbourhood the *other* side
of x_o sees (s = 2, 3) — light that reaches x_o's back and comes through the fabric to the side
seen. That last pair is what lights the convex side of a fold (a crest sees no neighbourhood of
its own; the valley behind it does): on the training data 15 % of LocalPT's local light lies on
samples whose own two shares are 0, and 97.5 % of that where the other side's are not. The
gain is factorised (supplement §3.1, Table 3, "Factorized, SH (Ord 3)"):

- intensity: ρ_N · softplus(MLP_I(φ_S, φ_L, φ_M)) — 12 → 32 → 16 → 4 (one per share), SiLU;
  ρ_N, the neighbourhood's albedo (φ_M, one channel at a time), makes a black fabric return
  nothing;
- directional part: max(0, 1 + Σ_{l=1,2} a_lm Y_lm(ω_i) / Y_00), the eight a_lm from
  MLP_D(φ_S, φ_L) — 11 → 24 → 8, SiLU: real spherical harmonics of three bands (l ≤ 2, "order
  3" in the supplement's count, whose Table 3 gives orders 3 and 2 the same 1.4K parameters)
  of the light's direction in the fold's own frame, normalised so that the intensity is the
  mean over directions. Over ω_i, not ω_o: the fabric at x_o is taken to reflect the light its
  neighbours send it as its albedo says (the fold light arrives from all around).

1500 parameters. Inputs, per vertex, side and light (:func:`inputs`):

- φ_S (9): φ_hv of the side, and φ_poly's eight coefficients in the fold's frame
  (:func:`canonical_frame`: x across the fold, whatever the mesh's parametrisation);
- φ_L (2): cos between ω_i and the side's normal n, and between ω_i and its n_N;
- φ_M (1): the neighbourhood's albedo in the channel (the network runs once per channel).

Evaluation is plain numpy (no torch at render time); :mod:`weavecap.training.fold` fits the same
network in torch and writes its arrays to a JSON file (no pickle).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from .descriptors import Descriptors

FEATURES = ("hv", "c0", "cz", "cxx", "cyy", "czz", "cxy", "cxz", "cyz", "cos_n", "cos_nN")
SHARES = ("seen_facing", "seen_through", "behind_facing", "behind_through")  # V̄'s columns (module docstring)
INTENSITY_LAYERS = (len(FEATURES) + 1, 32, 16, len(SHARES))  # one gain per share
DIRECTION_LAYERS = (len(FEATURES), 24, 8)
ISOTROPIC = 0.1  # a tangent block less anisotropic than this (relative) is turned by the rise alone
INPUT_CLIP = 6.0  # standardised inputs are clipped to ± this (unseen meshes stay in range)
FORMAT = "weavecap.fold-blidf/2"  # /2: four shares (both sides of x_o)
WEIGHTS_FILE = "blidf.json"
Y00 = 0.28209479177387814


def weights_path() -> Path:
    """The shipped weights: ``weavecap/render/fold/weights/blidf.json``."""
    return Path(__file__).resolve().parent / "weights" / WEIGHTS_FILE


# --------------------------------------------------------------------------- inputs

def side_quadratic(poly: np.ndarray, side: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """φ_poly of one side as (c0 (N,), g (N, 3), Q (N, 3, 3)) with f = c0 + g·q + qᵀQq.

    The back side's frame is (t, −b, −n) and its function −f, so its gradient is its normal.
    """
    c = poly.astype(np.float64)
    g = c[:, 1:4].copy()
    Q = np.empty((len(c), 3, 3))
    Q[:, 0, 0], Q[:, 1, 1], Q[:, 2, 2] = c[:, 4], c[:, 5], c[:, 6]
    Q[:, 0, 1] = Q[:, 1, 0] = c[:, 7] / 2
    Q[:, 0, 2] = Q[:, 2, 0] = c[:, 8] / 2
    Q[:, 1, 2] = Q[:, 2, 1] = c[:, 9] / 2
    c0 = c[:, 0].copy()
    if side == 1:
        D = np.array([1.0, -1.0, -1.0])
        c0, g, Q = -c0, -(g * D), -(Q * D[:, None] * D[None, :])
    return c0, g, Q


def side_frame(desc: Descriptors, side: int, at) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t, b, n) of a side at vertices ``at``: the front's (t, n × t, n), the back's (t, −b, −n)."""
    n = desc.normals[at].astype(np.float64)
    t = desc.tangents[at].astype(np.float64)
    b = np.cross(n, t)
    if side == 1:
        return t, -b, -n
    return t, b, n


def canonical_frame(desc: Descriptors, side: int, at) -> tuple[np.ndarray, np.ndarray, np.ndarray, tuple]:
    """A frame of the side fixed by its fold, and φ_poly in it: (x, y, n, (c0, g, Q)).

    x is the direction of the largest curvature of φ_poly's tangent block (across a fold),
    signed so that the neighbourhood rises towards +x (the xz coefficient ≥ 0); where the block
    is nearly isotropic (a bowl, a plane), x follows that rise alone. So the frame turns with
    the fold, not with the mesh's parametrisation, and the same fold gives the same
    coefficients on any mesh.
    """
    at = np.asarray(at)
    t, b, n = side_frame(desc, side, at)
    c0, g, Q = side_quadratic(desc.poly[at], side)
    aniso_x, aniso_y = Q[:, 0, 0] - Q[:, 1, 1], 2 * Q[:, 0, 1]
    rise_x, rise_y = 2 * Q[:, 0, 2], 2 * Q[:, 1, 2]
    anisotropy = np.hypot(aniso_x, aniso_y)
    anisotropic = anisotropy > ISOTROPIC * (np.abs(Q[:, 0, 0] + Q[:, 1, 1]) + anisotropy + 1e-12)
    theta = np.where(anisotropic, 0.5 * np.arctan2(aniso_y, aniso_x), np.arctan2(rise_y, rise_x))
    along = np.cos(theta) * rise_x + np.sin(theta) * rise_y
    theta = np.where(anisotropic & (along < 0), theta + np.pi, theta)
    ca, sa = np.cos(theta), np.sin(theta)
    R = np.zeros((len(at), 3, 3))  # columns: the frame's axes in the side frame
    R[:, 0, 0], R[:, 1, 0], R[:, 0, 1], R[:, 1, 1], R[:, 2, 2] = ca, sa, -sa, ca, 1.0
    g = np.einsum("nji,nj->ni", R, g)
    Q = np.einsum("nji,njk,nkl->nil", R, Q, R)
    x = ca[:, None] * t + sa[:, None] * b
    y = -sa[:, None] * t + ca[:, None] * b
    return x, y, n, (c0, g, Q)


@dataclass(frozen=True)
class SideInputs:
    """What :func:`inputs` needs of a side at some vertices, whatever the light: the fold's
    frame (x, y, n; (N, 3) each), the neighbourhood normal n_N (N, 3) and φ_S (N, 9)."""

    x: np.ndarray
    y: np.ndarray
    n: np.ndarray
    n_nbr: np.ndarray
    shape: np.ndarray


def side_inputs(desc: Descriptors, side: int, at) -> SideInputs:
    """The light-independent part of :func:`inputs` for vertices ``at`` on ``side`` (computed
    once a side, then indexed for every light)."""
    at = np.asarray(at)
    x, y, n, (c0, g, Q) = canonical_frame(desc, side, at)
    sign = 1.0 if side == 0 else -1.0
    hv = desc.hill_valley[at, side].astype(np.float64)
    shape = np.column_stack([hv, c0, g[:, 2], Q[:, 0, 0], Q[:, 1, 1], Q[:, 2, 2], 2 * Q[:, 0, 1], 2 * Q[:, 0, 2],
                             2 * Q[:, 1, 2]])
    return SideInputs(x, y, n, sign * desc.neighbourhood_normal[at].astype(np.float64), shape)


def light_inputs(side: SideInputs, rows, to_light: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`inputs` of rows ``rows`` (M,) of ``side`` lit from ``to_light`` (M, 3)."""
    l = np.asarray(to_light, np.float64)
    x, y, n, n_nbr = side.x[rows], side.y[rows], side.n[rows], side.n_nbr[rows]
    features = np.column_stack([side.shape[rows], np.einsum("nk,nk->n", l, n), np.einsum("nk,nk->n", l, n_nbr)])
    light_local = np.column_stack([np.einsum("nk,nk->n", l, x), np.einsum("nk,nk->n", l, y),
                                   np.einsum("nk,nk->n", l, n)])
    return features, light_local


def inputs(desc: Descriptors, side: int, at, to_light: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Network inputs for vertices ``at`` on ``side`` lit from ``to_light``.

    Parameters
    ----------
    desc : the mesh's descriptors; side : 0 front, 1 back; at : (N,) vertex indices (repeats allowed)
    to_light : (N, 3) unit world directions towards the light

    Returns
    -------
    features : (N, 11) in :data:`FEATURES` order (φ_S in the fold's frame, φ_L)
    light_local : (N, 3) ω_i in that frame (:func:`canonical_frame`)
    """
    at = np.asarray(at)
    return light_inputs(side_inputs(desc, side, at), np.arange(len(at)), to_light)


def sh_basis(w: np.ndarray) -> np.ndarray:
    """Real spherical harmonics of bands 1 and 2 at unit directions w (N, 3) → (N, 8), over Y_00."""
    x, y, z = w[:, 0], w[:, 1], w[:, 2]
    c1, c2, c20, c22 = 0.4886025119029199, 1.0925484305920792, 0.31539156525252005, 0.5462742152960396
    return np.column_stack([c1 * y, c1 * z, c1 * x, c2 * x * y, c2 * y * z, c20 * (3 * z * z - 1), c2 * x * z,
                            c22 * (x * x - y * y)]) / Y00


# --------------------------------------------------------------------------- the network

@lru_cache(maxsize=1)
def _blas():
    """threadpoolctl's controller of the BLAS libraries, made once (finding them reads files: ~5 ms)."""
    from threadpoolctl import ThreadpoolController

    return ThreadpoolController()


def _silu(x):
    return x / (1.0 + np.exp(-np.clip(x, -60, 60)))


def _softplus(x):
    return np.logaddexp(0.0, x)


def _mlp(arrays: dict, prefix: str, x: np.ndarray) -> np.ndarray:
    """The network ``prefix`` ("i" or "d") on rows ``x`` (N, inputs), in the dtype of ``x``."""
    k = 0
    while f"{prefix}.w{k + 1}" in arrays:
        x = _silu(x @ arrays[f"{prefix}.w{k}"].astype(x.dtype) + arrays[f"{prefix}.b{k}"].astype(x.dtype))
        k += 1
    return x @ arrays[f"{prefix}.w{k}"].astype(x.dtype) + arrays[f"{prefix}.b{k}"].astype(x.dtype)


@dataclass(frozen=True)
class BLIDF:
    """A trained BLIDF: its arrays (weights, input standardisation) and the record of its training."""

    arrays: dict
    record: dict

    @property
    def parameters(self) -> int:
        return int(sum(a.size for k, a in self.arrays.items() if k.startswith(("i.", "d."))))

    def standardise(self, features: np.ndarray) -> np.ndarray:
        """Features in units of the training data's spread, clipped to ± INPUT_CLIP (NaN → the mean)."""
        x = np.clip(np.nan_to_num(np.asarray(features, np.float64), nan=0.0), -1e12, 1e12)
        x = np.where(np.isnan(features), self.arrays["mean"], x)
        return np.clip((x - self.arrays["mean"]) / self.arrays["std"], -INPUT_CLIP, INPUT_CLIP)

    def __call__(self, features: np.ndarray, light_local: np.ndarray, albedo: np.ndarray,
                 vbar: np.ndarray) -> np.ndarray:
        """S_θ · V̄ (N, C) of a uniform fabric of albedos (N, C) with shares ``vbar`` (N, 4) (:data:`SHARES`)."""
        albedo = np.asarray(albedo, np.float64)
        return albedo * np.einsum("nck,nk->nc", self.gain(features, light_local, albedo), vbar)

    def gain(self, features: np.ndarray, light_local: np.ndarray, albedo: np.ndarray) -> np.ndarray:
        """(N, C, 4): the light the neighbourhood sends x_o per unit irradiance and unit share
        (:data:`SHARES`: of the neighbourhood the side seen sees, lit facing x_o and through it;
        of the one behind x_o, the same), for neighbourhood albedos (N, C), one column per colour
        channel: ρ_N · softplus(MLP_I) · max(0, 1 + Σ a_lm Y_lm(ω_i)).
        The albedo of x_o itself (its texture, at render time) multiplies it.
        """
        x = self.standardise(np.asarray(features, np.float64)).astype(np.float32)  # float32: 2x faster, ample
        albedo = np.asarray(albedo, np.float64)
        n, channels = albedo.shape
        # one BLAS thread: these products are narrow (≤ 32 columns) and two threads only wait on each other —
        # side by side under load ~3, 3,000 / 21,000 / 100,000 rows: 0.039 / 0.099 / 0.38 s with two, 0.010 /
        # 0.059 / 0.16 s with one
        with _blas().limit(limits=1):
            direction = np.maximum(1.0 + np.einsum("nk,nk->n", sh_basis(light_local), _mlp(self.arrays, "d", x)), 0.0)
            rows = np.concatenate([np.column_stack([x, albedo[:, c].astype(np.float32)]) for c in range(channels)])
            intensity = _softplus(_mlp(self.arrays, "i", rows).astype(np.float64)).reshape(channels, n, len(SHARES))
        return albedo[..., None] * intensity.transpose(1, 0, 2) * direction[:, None, None]

    def to_json(self) -> dict:
        return {"format": FORMAT, "record": self.record,
                "arrays": {k: {"shape": list(a.shape), "values": a.ravel().tolist()} for k, a in self.arrays.items()}}

    @classmethod
    def from_json(cls, data: dict, *, source: str = "weights") -> "BLIDF":
        if data.get("format") != FORMAT:
            raise ValueError(f"{source}: not a fold BLIDF ({data.get('format')!r}, expected {FORMAT!r})")
        arrays = {k: np.asarray(v["values"], np.float64).reshape(v["shape"]) for k, v in data["arrays"].items()}
        return cls(arrays=arrays, record=data.get("record", {}))

    def save(self, path: Path) -> None:
        from ...io import atomic_write_text

        atomic_write_text(path, json.dumps(self.to_json(), indent=None, separators=(",", ":")) + "\n")

    @classmethod
    def load(cls, path: Path | None = None) -> "BLIDF":
        """The weights in ``path`` (the shipped ones by default), parsed once per file version
        (``weavecap render`` loads them for every frame; the parse took ~5 ms)."""
        path = Path(path) if path is not None else weights_path()
        stat = path.stat()
        return _parsed(cls, str(path), stat.st_mtime_ns, stat.st_size)


@lru_cache(maxsize=4)
def _parsed(cls, path: str, mtime_ns: int, size: int) -> BLIDF:
    """:meth:`BLIDF.load`'s parse, cached by the file's path, modification time and size."""
    return cls.from_json(json.loads(Path(path).read_text()), source=path)
