"""The woven network (Chen et al. 2024, §4.2, Fig. 3) in PyTorch: encoder, decoder, losses.

- **Encoder**: the repeat's maps (:func:`.encoding.encoder_image`: coverage, warp share, normal,
  height, grooves, horizon, through — the paper's normal and orientation textures, and what our
  surface model adds) through a small ResNet (a stem and three stride-2 basic blocks, circular
  padding: the image is periodic), global mean pooling, concatenated with the non-colour
  parameters (:data:`.encoding.ENCODER_PARAMS`), one residual block of two FC layers of 128, and
  a 64-d material latent ``z``. The paper uses a ResNet-18 without its last block; this one is
  ~8× smaller (measured in docs/woven.md).
- **Decoder**: one-blob encoding (Müller et al. 2021) of the footprint's centre (periodic
  over the repeat) and size (log₂ of its side in yarn pitches), ``BLOB_BINS`` bins each; with
  the footprint's box-filtered map statistics (:data:`.footprint.FEATURES`, our addition);
  fused with ``z`` by two FC layers into a spatial feature; then, with the directions (ω_i's
  x, y; ω_o's x, y, z), an angular decoder of five FC layers with one skip connection, to the
  14 colour-free channels of :mod:`.terms`. The specular channels come out in the loss's
  log space ``g = ln(k x + 1)`` (k = K_BRDF or K_BTDF by the light's side); :func:`to_values`
  inverts it.
- **Losses** (Eq. 9–11): MSE on ``g`` for the specular channels, MSE on the value for the
  body (diffuse) channels, weighted λ_S = 0.4, λ_C = 0.1; channels that are exactly zero for a
  light on the viewer's side (:data:`.terms.REFLECTION_CHANNELS`) are not scored there.

Every activation is LeakyReLU(0.01), as the paper's. The decoder's first layer is linear in
``z``, so at render time ``W_z z`` is folded into its bias once per fabric (:mod:`.infer`).
"""

from __future__ import annotations

import math

import torch
from torch import nn

from . import terms as _terms
from .encoding import ENCODER_CHANNELS, N_PARAMS
from .footprint import FEATURES

LATENT = 64
WIDTH = 64  # decoder layers
ENCODER_WIDTHS = (16, 32, 64, 64)  # stem, then the three blocks
ENCODER_FC = 128
BLOB_BINS = 8
SIZE_LOG2_RANGE = (-5.0, 6.0)  # log2 of the footprint side in yarn pitches mapped to [0, 1]
K_BRDF, K_BTDF = 100.0, 1000.0
K_BODY = 100.0  # the log mapping of the body channels (only with the baseline)
G_MAX = math.log(1e6)  # outputs are clamped here before exp
LAMBDA_S, LAMBDA_C = 0.4, 0.1
#: the body channels' values are scored (and, without the baseline, predicted) times this
#: (1: the paper's MSE on the value; 10 trained faster, docs/woven.md)
BODY_SCALE = 10.0
SLOPE = 0.01
N_OUT = len(_terms.CHANNELS)
N_ANGLES = 5
SPEC = list(_terms.SPECULAR_CHANNELS)
BODY = list(_terms.BODY_CHANNELS)


def _act():
    return nn.LeakyReLU(SLOPE)


class BasicBlock(nn.Module):
    """ResNet basic block: two 3×3 convolutions, the shortcut a strided 1×1 when the shape
    changes; circular padding."""

    def __init__(self, cin: int, cout: int, stride: int):
        super().__init__()
        self.conv1 = nn.Conv2d(cin, cout, 3, stride, 1, padding_mode="circular")
        self.conv2 = nn.Conv2d(cout, cout, 3, 1, 1, padding_mode="circular")
        self.short = nn.Conv2d(cin, cout, 1, stride) if (stride != 1 or cin != cout) else nn.Identity()
        self.act = _act()

    def forward(self, x):
        return self.act(self.conv2(self.act(self.conv1(x))) + self.short(x))


class ResidualFC(nn.Module):
    """Two FC layers and a skip connection before the last activation (Fig. 3)."""

    def __init__(self, width: int):
        super().__init__()
        self.fc1 = nn.Linear(width, width)
        self.fc2 = nn.Linear(width, width)
        self.act = _act()

    def forward(self, x):
        return self.act(self.fc2(self.act(self.fc1(x))) + x)


class Encoder(nn.Module):
    """(B, C, S, S) maps and (B, N_PARAMS) parameters → (B, LATENT) material latents."""

    def __init__(self, widths=ENCODER_WIDTHS):
        super().__init__()
        self.stem = nn.Conv2d(len(ENCODER_CHANNELS), widths[0], 3, 1, 1, padding_mode="circular")
        self.blocks = nn.Sequential(*[BasicBlock(widths[i], widths[i + 1], 2) for i in range(len(widths) - 1)])
        self.fc_in = nn.Linear(widths[-1] + N_PARAMS, ENCODER_FC)
        self.res = ResidualFC(ENCODER_FC)
        self.fc_out = nn.Linear(ENCODER_FC, LATENT)
        self.act = _act()

    def forward(self, image, params):
        x = self.blocks(self.act(self.stem(image)))
        x = torch.cat([x.mean(dim=(2, 3)), params], dim=1)
        return self.fc_out(self.res(self.act(self.fc_in(x))))


def one_blob(x, bins: int = BLOB_BINS, periodic: bool = False):
    """One-blob encoding of (...,) values in [0, 1] → (..., bins): a Gaussian of σ = 1/bins
    at bin centres; ``periodic`` measures distance around the unit circle."""
    centres = (torch.arange(bins, dtype=x.dtype, device=x.device) + 0.5) / bins
    d = x[..., None] - centres
    if periodic:
        d = d - torch.round(d)
    return torch.exp(-0.5 * (d * bins) ** 2)


def size_coordinate(size):
    """Footprint side (yarn pitches, 0 for a point) → [0, 1] (log₂ over SIZE_LOG2_RANGE)."""
    lo, hi = SIZE_LOG2_RANGE
    return ((torch.log2(torch.clamp(size, min=2.0 ** lo)) - lo) / (hi - lo)).clamp(0.0, 1.0)


def spatial_inputs(inputs, features, *, use_features: bool = True):
    """(Q, 3·BLOB_BINS [+ len(FEATURES)]): the one-blob footprint and its map statistics."""
    s, t = inputs[:, 0] - torch.floor(inputs[:, 0]), inputs[:, 1] - torch.floor(inputs[:, 1])
    parts = [one_blob(s, periodic=True), one_blob(t, periodic=True), one_blob(size_coordinate(inputs[:, 2]))]
    if use_features:
        parts.append(features)
    return torch.cat(parts, dim=1)


def angular_inputs(inputs):
    """(Q, 5): ω_i's x, y and ω_o's x, y, z (the paper's five angular channels)."""
    return torch.cat([inputs[:, 3:5], inputs[:, 6:9]], dim=1)


def log_k(inputs):
    """(Q, 14) each channel's k of the log mapping ``g = ln(k x + 1)``: K_BODY for the body
    channels, K_BRDF / K_BTDF for the specular ones by the light's side."""
    k = torch.full((inputs.shape[0], N_OUT), K_BODY, dtype=inputs.dtype, device=inputs.device)
    k[:, SPEC] = torch.where(inputs[:, 8:9] > 0.0, K_BRDF, K_BTDF)
    return k


class Decoder(nn.Module):
    """(Q, LATENT) latents, (Q, 9) inputs, (Q, 16) features, (Q, 14) baseline channels →
    (Q, 14) outputs in log space ``g`` (:func:`to_values` turns them into channel values).

    ``use_baseline`` (ours): the surface model at the footprint's mean maps
    (:func:`.footprint.baseline_channels`) enters the angular decoder as ``g(baseline)`` and
    the output is ``g(baseline) +`` the network's correction (its last layer starts at zero,
    so an untrained network is the prefiltered guess). Without it (the paper's decoder), the
    network's outputs are ``g`` for the specular channels and the values of the body ones.
    """

    def __init__(self, *, use_features: bool = True, use_baseline: bool = True, width: int = WIDTH):
        super().__init__()
        self.use_features = use_features
        self.use_baseline = use_baseline
        n_spatial = 3 * BLOB_BINS + (len(FEATURES) if use_features else 0)
        self.fuse1 = nn.Linear(LATENT + n_spatial, width)
        self.fuse2 = nn.Linear(width, width)
        self.ang1 = nn.Linear(width + N_ANGLES + (N_OUT if use_baseline else 0), width)
        self.ang2 = nn.Linear(width, width)
        self.ang3 = nn.Linear(width, width)
        self.ang4 = nn.Linear(width, width)
        self.ang5 = nn.Linear(width, N_OUT)
        if use_baseline:
            nn.init.zeros_(self.ang5.weight)
            nn.init.zeros_(self.ang5.bias)
        self.act = _act()

    def forward(self, z, inputs, features, baseline):
        a = self.act
        x = torch.cat([z, spatial_inputs(inputs, features, use_features=self.use_features)], dim=1)
        h = a(self.fuse2(a(self.fuse1(x))))
        angular = [h, angular_inputs(inputs)]
        if self.use_baseline:
            g_base = torch.log1p(log_k(inputs) * torch.clamp(baseline, min=0.0))
            angular.append(g_base)
        x1 = a(self.ang1(torch.cat(angular, dim=1)))
        x2 = a(self.ang2(x1))
        x3 = a(self.ang3(x2) + x1)  # the skip connection
        x4 = a(self.ang4(x3))
        out = self.ang5(x4)
        return out + g_base if self.use_baseline else out


class WovenNet(nn.Module):
    """Encoder and decoder together; ``forward(image, params, material, inputs, features)``
    with ``material`` (Q,) indexing the B materials of ``image``/``params``."""

    def __init__(self, *, use_features: bool = True, use_baseline: bool = True, encoder_widths=ENCODER_WIDTHS,
                 width: int = WIDTH):
        super().__init__()
        self.encoder = Encoder(encoder_widths)
        self.decoder = Decoder(use_features=use_features, use_baseline=use_baseline, width=width)

    def forward(self, image, params, material, inputs, features, baseline):
        z = self.encoder(image, params)
        return self.decoder(z[material], inputs, features, baseline)


def reflection_mask(inputs):
    """(Q, 14) 1 where a channel can be non-zero (all channels under transmission; only
    REFLECTION_CHANNELS when the light is on the viewer's side)."""
    mask = torch.ones(inputs.shape[0], N_OUT, dtype=inputs.dtype, device=inputs.device)
    off = [i for i in range(N_OUT) if i not in _terms.REFLECTION_CHANNELS]
    mask[:, off] = torch.where(inputs[:, 8:9] > 0.0, 0.0, 1.0).expand(-1, len(off))
    return mask


def to_values(out, inputs, *, use_baseline: bool = True):
    """Decoder outputs → channel values (Q, 14): the log mapping inverted (all channels with
    the baseline; the specular ones only without), negative values and channels a reflection
    cannot have set to 0."""
    k = log_k(inputs)
    g = torch.clamp(out, max=G_MAX)
    values = torch.expm1(g) / k
    if not use_baseline:
        values[:, BODY] = out[:, BODY] / BODY_SCALE
    return torch.clamp(values, min=0.0) * reflection_mask(inputs)


def loss(out, targets, inputs, *, use_baseline: bool = True):
    """Eq. 9–11: λ_S · MSE(g_pred, ln(k x + 1)) over the specular channels + λ_C · MSE of the
    body channels' values (scaled by BODY_SCALE), over the channels that can be non-zero;
    returns (total, specular part, body part)."""
    mask = reflection_mask(inputs)
    k = log_k(inputs)
    g = torch.log1p(k[:, SPEC] * torch.clamp(targets[:, SPEC], min=0.0))
    spec = (((out[:, SPEC] - g) ** 2) * mask[:, SPEC]).sum() / mask[:, SPEC].sum().clamp(min=1.0)
    if use_baseline:
        body_pred = torch.expm1(torch.clamp(out[:, BODY], max=G_MAX)) / k[:, BODY]
    else:
        body_pred = out[:, BODY] / BODY_SCALE
    body_err = BODY_SCALE * (body_pred - targets[:, BODY])
    body = ((body_err ** 2) * mask[:, BODY]).sum() / mask[:, BODY].sum().clamp(min=1.0)
    return LAMBDA_S * spec + LAMBDA_C * body, spec, body
