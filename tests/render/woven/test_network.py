"""The network's shapes, encodings and losses (Chen et al. §4.2, Eq. 9–11)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from weavecap.render.woven import network as net
from weavecap.render.woven import terms
from weavecap.render.woven.encoding import ENCODER_CHANNELS, ENCODER_SIZE, N_PARAMS
from weavecap.render.woven.footprint import FEATURES


def _batch(q=64, b=2, seed=0):
    g = torch.Generator().manual_seed(seed)
    image = torch.rand(b, len(ENCODER_CHANNELS), ENCODER_SIZE, ENCODER_SIZE, generator=g)
    params = torch.rand(b, N_PARAMS, generator=g)
    material = torch.arange(q) % b
    inputs = torch.rand(q, 9, generator=g)
    d = torch.randn(q, 2, 3, generator=g)
    d = d / d.norm(dim=2, keepdim=True)
    d[:, 0, 2] = d[:, 0, 2].abs()
    inputs[:, 3:6], inputs[:, 6:9] = d[:, 0], d[:, 1]
    features = torch.rand(q, len(FEATURES), generator=g)
    baseline = torch.rand(q, net.N_OUT, generator=g)
    return image, params, material, inputs, features, baseline


@pytest.mark.parametrize("use_baseline", [True, False])
def test_shapes(use_baseline):
    model = net.WovenNet(use_baseline=use_baseline)
    image, params, material, inputs, features, baseline = _batch()
    assert model.encoder(image, params).shape == (2, net.LATENT)
    out = model(image, params, material, inputs, features, baseline)
    assert out.shape == (64, len(terms.CHANNELS))
    values = net.to_values(out, inputs, use_baseline=use_baseline)
    assert values.shape == (64, 14) and (values >= 0).all()


def test_untrained_residual_network_returns_the_baseline():
    """The correction's last layer starts at zero: the output is the prefiltered guess."""
    model = net.WovenNet(use_baseline=True)
    image, params, material, inputs, features, baseline = _batch()
    values = net.to_values(model(image, params, material, inputs, features, baseline), inputs)
    torch.testing.assert_close(values, baseline * net.reflection_mask(inputs), rtol=1e-5, atol=1e-6)


def test_loss_is_zero_at_the_truth_and_ignores_impossible_channels():
    _, _, _, inputs, _, _ = _batch(q=128)
    targets = torch.rand(128, 14) * net.reflection_mask(inputs)
    out = torch.log1p(net.log_k(inputs) * targets)
    total, spec, body = net.loss(out, targets, inputs)
    assert total.item() == pytest.approx(0.0, abs=1e-10)
    # garbage where a reflection cannot have light changes nothing
    noisy = out + 5.0 * (1.0 - net.reflection_mask(inputs))
    assert net.loss(noisy, targets, inputs)[0].item() == pytest.approx(0.0, abs=1e-10)
    # an error on a specular channel is scored in log space with the paper's weights
    wrong = out.clone()
    wrong[:, net.SPEC] += 0.1
    total, spec, body = net.loss(wrong, targets, inputs)
    assert spec.item() == pytest.approx(0.01, rel=1e-4) and body.item() == pytest.approx(0.0, abs=1e-10)
    assert total.item() == pytest.approx(net.LAMBDA_S * 0.01, rel=1e-4)
    # k is 100 for a light on the viewer's side, 1000 below
    k = net.log_k(inputs)[:, net.SPEC[0]]
    assert set(k[inputs[:, 8] > 0].tolist()) == {net.K_BRDF} and set(k[inputs[:, 8] < 0].tolist()) == {net.K_BTDF}


def test_one_blob_is_periodic_in_position():
    x = torch.tensor([0.01, 0.99, 0.5])
    blob = net.one_blob(x, periodic=True)
    torch.testing.assert_close(net.one_blob(x + 1.0, periodic=True), blob)
    assert blob[0].argmax().item() == 0 and blob[1].argmax().item() == net.BLOB_BINS - 1
    # 0.01 and 0.99 are neighbours around the circle
    assert torch.dot(blob[0], blob[1]) > torch.dot(blob[0], blob[2])


def test_finite_values_and_gradients_at_extremes():
    """Points, huge footprints, grazing directions, zero and huge baselines: finite."""
    model = net.WovenNet()
    image, params, material, inputs, features, baseline = _batch(q=8)
    inputs[:, 2] = torch.tensor([0.0, 1e-9, 1e6, 1e30, 0.5, 2.0, 3.0, 4.0])
    inputs[:, 3:6] = torch.tensor([1.0, 0.0, 0.0])  # grazing view
    inputs[:, 6:9] = torch.tensor([0.0, -1.0, 0.0])  # grazing light
    baseline[:4] = 0.0
    baseline[4:] = 1e6
    out = model(image, params, material, inputs, features, baseline)
    total, _, _ = net.loss(out, torch.rand(8, 14) * 100, inputs)
    total.backward()
    assert torch.isfinite(out).all() and torch.isfinite(net.to_values(out, inputs)).all()
    assert all(torch.isfinite(p.grad).all() for p in model.parameters() if p.grad is not None)
