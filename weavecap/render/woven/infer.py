"""Inference where the rays are (Chen et al. 2024, §4.3): the encoder once per fabric, the
decoder per shading point, compiled into the render kernel.

- :func:`load_weights` reads the shipped weights (plain arrays, ``numpy.load`` without
  pickle) and :func:`encoder_model` builds the PyTorch encoder from them;
  :class:`FabricLatents` runs it once per fabric and side (the latent is cached; colours are
  not in it, so a colour change needs no new encoding — a pattern or roughness change does).
- :class:`BoxFilter` is the Dr.Jit side of :mod:`.footprint`: a periodic image's mean over
  any square box from its summed-area table, as a texture (the decoder's map statistics, the
  noise gain).
- :class:`Decoder` is the decoder as ``drjit.nn`` layers evaluated on ``CoopVec`` inputs, so
  the MLP is traced into the same LLVM kernel as the ray queries (no Python per pixel). The
  latent enters the first layer linearly, so ``W_z z + b`` of the face and of the back are
  folded into two weight columns selected by a one-hot side input.
"""

from __future__ import annotations

import json
from importlib import resources
from pathlib import Path

import numpy as np

from ..bsdf import opaque
from ..surface import BACK, FACE, SurfaceMaps
from . import network as _net
from . import terms as _terms
from .encoding import encoder_image, encoder_params
from .footprint import MIN_HALF_TEXELS, feature_image, periodic_sat

WEIGHTS = "woven.npz"


def weights_path() -> Path:
    """The shipped weights (package data ``weavecap/render/woven/weights/woven.npz``)."""
    return Path(str(resources.files("weavecap.render.woven").joinpath("weights", WEIGHTS)))


def load_weights(path: str | Path | None = None) -> tuple[dict, dict]:
    """(arrays by PyTorch state-dict name, the JSON record beside them). No pickle."""
    path = Path(path) if path is not None else weights_path()
    with np.load(path, allow_pickle=False) as z:
        arrays = {k: np.asarray(z[k], dtype=np.float32) for k in z.files}
    record_path = path.with_suffix(".json")
    record = json.loads(record_path.read_text()) if record_path.exists() else {}
    return arrays, record


def torch_model(arrays: dict, record: dict | None = None):
    """The PyTorch :class:`~.network.WovenNet` holding ``arrays``."""
    import torch

    train = (record or {}).get("train", {})
    model = _net.WovenNet(use_features=bool(train.get("use_features", True)),
                          use_baseline=bool(train.get("use_baseline", True)),
                          encoder_widths=tuple(train.get("encoder_widths", _net.ENCODER_WIDTHS)),
                          width=int(train.get("width", _net.WIDTH)))
    model.load_state_dict({k: torch.from_numpy(v) for k, v in arrays.items()})
    model.eval()
    return model


class FabricLatents:
    """The encoder, run once per (maps, fabric) and side; latents cached by the maps object."""

    def __init__(self, arrays: dict, record: dict | None = None):
        self.model = torch_model(arrays, record)
        self._cache: dict = {}

    def encode(self, maps: SurfaceMaps, fabric) -> np.ndarray:
        """(2, LATENT) float32: the latents of the face and the back."""
        import torch

        key = (id(maps), encoder_params(fabric).tobytes())
        if key not in self._cache:
            image = np.stack([encoder_image(maps, FACE), encoder_image(maps, BACK)])
            params = np.repeat(encoder_params(fabric)[None], 2, axis=0)
            threads = torch.get_num_threads()
            torch.set_num_threads(1)  # a small network: more threads only contend (8× slower on 2 busy cores)
            try:
                with torch.no_grad():
                    z = self.model.encoder(torch.from_numpy(image), torch.from_numpy(params)).numpy()
            finally:
                torch.set_num_threads(threads)
            self._cache = {key: z.astype(np.float32)}
        return self._cache[key]


# ---------------------------------------------------------------------------------------------
# Dr.Jit: footprints and the decoder


def _backend():
    return _terms._backend()


class BoxFilter:
    """Means of a periodic image (one repeat, (H, W, C)) over square boxes, in Dr.Jit.

    The zero-mean summed-area table of :func:`.footprint.periodic_sat` is a linearly
    interpolated texture of (H + 1) × (W + 1) nodes: bilinear interpolation of it is exact for
    an image constant per texel, and the periodic extension is the formula of
    :mod:`.footprint` (the box's centre is first brought into the repeat, so the extension's
    extra lookups happen only for boxes that cross its edge). Boxes under MIN_HALF_TEXELS in
    half-side are points: the image itself, interpolated (as
    :func:`.footprint.footprint_features`). ``images``: one per side (face, back), stacked in
    one texture so a lookup serves either side.
    """

    def __init__(self, images: list[np.ndarray]):
        mi, dr = _backend()
        self.shape = images[0].shape[:2]
        self.sides = len(images)
        self.channels = images[0].shape[-1]
        tables, means, padded = [], [], []
        for image in images:
            sat, mean = periodic_sat(image)
            tables.append(sat)
            means.append(mean)
            padded.append(np.concatenate([image[-1:], image, image[:1]], axis=0))  # wrapped rows
        self.table = mi.Texture2f(mi.TensorXf(np.ascontiguousarray(np.concatenate(tables), dtype=np.float32)),
                                  filter_mode=dr.FilterMode.Linear, wrap_mode=dr.WrapMode.Clamp)
        self.image = mi.Texture2f(mi.TensorXf(np.ascontiguousarray(np.concatenate(padded), dtype=np.float32)),
                                  filter_mode=dr.FilterMode.Linear, wrap_mode=dr.WrapMode.Repeat)
        # read from memory, not compiled in: another fabric or texel count reuses the kernels
        self.size = tuple(opaque(n) for n in self.shape)
        self.means = [[opaque(m) for m in mean] for mean in means]

    def _table(self, x, y, row0, active):
        """The stacked table at node coordinates (x, y) of the side starting at ``row0``."""
        mi, _ = _backend()
        h, w = self.size
        pos = mi.Point2f((x + 0.5) / (w + 1.0), (row0 + y + 0.5) / (self.sides * (h + 1.0)))
        return self.table.eval(pos, active)

    def _extended(self, x, y, row0, active):
        mi, dr = _backend()
        h, w = self.size
        qx, qy = dr.floor(x / w), dr.floor(y / h)
        rx, ry = x - qx * w, y - qy * h
        base = self._table(rx, ry, row0, active)
        col = self._table(mi.Float(w), ry, row0, active & (qx != 0.0))
        row = self._table(rx, mi.Float(h), row0, active & (qy != 0.0))
        return [b + dr.select(qx != 0.0, qx * c, 0.0) + dr.select(qy != 0.0, qy * r, 0.0)
                for b, c, r in zip(base, col, row)]

    def mean(self, x, y, half, side=None, active=True):
        """Box means (list of C Floats) at texel coordinates (x, y), half side ``half``
        (texels); ``side``: Bool, True for the second image (the back)."""
        mi, dr = _backend()
        h, w = self.size
        active = mi.Bool(active)
        back = mi.Bool(False) if side is None or self.sides == 1 else side
        x = x - dr.floor(x / w) * w
        y = y - dr.floor(y / h) * h
        point = half < MIN_HALF_TEXELS
        half = dr.maximum(half, MIN_HALF_TEXELS)
        box = active & ~point
        row0 = dr.select(back, h + 1.0, 0.0)
        s11 = self._extended(x + half, y + half, row0, box)
        s01 = self._extended(x - half, y + half, row0, box)
        s10 = self._extended(x + half, y - half, row0, box)
        s00 = self._extended(x - half, y - half, row0, box)
        pad_row0 = dr.select(back, h + 2.0, 0.0)
        at = self.image.eval(mi.Point2f(x / w, (pad_row0 + 1.0 + y) / (self.sides * (h + 2.0))), active & point)
        norm = 1.0 / (4.0 * half * half)
        out = []
        for c in range(self.channels):
            mean = dr.select(back, self.means[-1][c], self.means[0][c])
            out.append(dr.select(point, at[c], mean + (s11[c] - s01[c] - s10[c] + s00[c]) * norm))
        return out


def footprint_filter(maps: SurfaceMaps) -> BoxFilter:
    """The decoder's map statistics (:data:`.footprint.FEATURES`) of both sides."""
    return BoxFilter([feature_image(maps, FACE), feature_image(maps, BACK)])


def coverage_filter(maps: SurfaceMaps) -> BoxFilter:
    """The coverage alone (the first of :data:`.footprint.FEATURES`), for null transmission."""
    return BoxFilter([maps.coverage[FACE][..., None], maps.coverage[BACK][..., None]])


def _blob(x, bins: int, periodic: bool):
    mi, dr = _backend()
    out = []
    for k in range(bins):
        d = x - (k + 0.5) / bins
        if periodic:
            d = d - dr.round(d)
        out.append(dr.exp(-0.5 * dr.square(d * bins)))
    return out


class Decoder:
    """The decoder of :class:`~.network.Decoder` in ``drjit.nn``, for one fabric (its face
    and back latents folded into the first layer)."""

    def __init__(self, arrays: dict, latents: np.ndarray, *, use_features: bool = True, use_baseline: bool = True):
        import drjit.nn as nn

        mi, dr = _backend()
        self.use_features = use_features
        self.use_baseline = use_baseline
        a = {k[len("decoder."):]: v for k, v in arrays.items() if k.startswith("decoder.")}
        w1, b1 = a["fuse1.weight"], a["fuse1.bias"]
        wz, wx = w1[:, :_net.LATENT], w1[:, _net.LATENT:]
        folded = np.stack([wz @ latents[FACE] + b1, wz @ latents[BACK] + b1], axis=1)  # (width, 2)
        first = np.concatenate([wx, folded], axis=1)

        def linear(weight, bias):
            layer = nn.Linear(weight.shape[1], weight.shape[0])
            layer.weights = mi.TensorXf(np.ascontiguousarray(weight, dtype=np.float32))
            layer.bias = mi.TensorXf(np.ascontiguousarray(bias, dtype=np.float32))
            return layer

        layers = [linear(first, np.zeros(first.shape[0], dtype=np.float32)), linear(a["fuse2.weight"], a["fuse2.bias"])]
        layers += [linear(a[f"ang{i}.weight"], a[f"ang{i}.bias"]) for i in range(1, 6)]
        self.layers = nn.pack(*layers, layout="inference")
        dr.eval(self.layers)  # packed once here, not traced into the render kernels
        self.act = nn.LeakyReLU(_net.SLOPE)

    def _log_k(self, wo):
        mi, dr = _backend()
        spec = dr.select(wo.z > 0.0, _net.K_BRDF, _net.K_BTDF)
        return [spec if i in _terms.SPECULAR_CHANNELS else mi.Float(_net.K_BODY) for i in range(_net.N_OUT)]

    def raw(self, s, t, size, wi, wo, features, back, baseline=None):
        """The network's outputs (list of 14 Floats, log space; see :class:`~.network.Decoder`)
        for footprints at fabric coordinates (s, t) (repeats) of side ``size`` (yarn pitches),
        directions ``wi``, ``wo`` (face frame), map statistics ``features``, side ``back``
        (Bool) and the prefiltered guess ``baseline`` (14 Floats, when the network uses it)."""
        import drjit.nn as nn

        mi, dr = _backend()
        lo, hi = _net.SIZE_LOG2_RANGE
        u = dr.clip((dr.log2(dr.maximum(size, 2.0 ** lo)) - lo) / (hi - lo), 0.0, 1.0)
        inputs = (_blob(s - dr.floor(s), _net.BLOB_BINS, True) + _blob(t - dr.floor(t), _net.BLOB_BINS, True)
                  + _blob(u, _net.BLOB_BINS, False))
        if self.use_features:
            inputs += list(features)
        inputs += [dr.select(back, 0.0, 1.0), dr.select(back, 1.0, 0.0)]
        act = self.act
        l1, l2, a1, a2, a3, a4, a5 = self.layers
        h = act(l2(act(l1(nn.CoopVec(*inputs)))))
        angular = [wi.x, wi.y, wo.x, wo.y, wo.z]
        if self.use_baseline:
            g_base = [dr.log(1.0 + k * dr.maximum(b, 0.0)) for k, b in zip(self._log_k(wo), baseline)]
            angular += g_base
        x1 = act(a1(nn.CoopVec(*h, *angular)))
        x2 = act(a2(x1))
        x3 = act(a3(x2) + x1)
        x4 = act(a4(x3))
        out = list(a5(x4))
        return [o + g for o, g in zip(out, g_base)] if self.use_baseline else out

    def values(self, s, t, size, wi, wo, features, back, baseline=None):
        """Channel values (list of 14 Floats, :data:`.terms.CHANNELS`): :meth:`raw` with the
        log mapping inverted (as :func:`.network.to_values`), clamped at 0, the channels a
        reflection cannot have set to 0 when the light is on the viewer's side."""
        mi, dr = _backend()
        raw = self.raw(s, t, size, wi, wo, features, back, baseline)
        out = []
        for i, (r, k) in enumerate(zip(raw, self._log_k(wo))):
            if self.use_baseline or i in _terms.SPECULAR_CHANNELS:
                v = (dr.exp(dr.minimum(r, _net.G_MAX)) - 1.0) / k
            else:
                v = r / _net.BODY_SCALE
            v = dr.maximum(v, 0.0)
            if i not in _terms.REFLECTION_CHANNELS:
                v = dr.select(wo.z > 0.0, 0.0, v)
            out.append(v)
        return out
