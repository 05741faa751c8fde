"""Fixtures of the pre-estimation tests: fabrics with known answers."""

from __future__ import annotations

import numpy as np
import pytest
from estimate_data import FIXTURES

from weavecap import params


@pytest.fixture(scope="session")
def twill_fabric():
    return params.load(FIXTURES / "twill_2_1.json")


@pytest.fixture(scope="session")
def custom_fabric():
    """A 10 × 5 pattern no training family makes (random, larger than the training's 8)."""
    pattern = np.array([[1, 1, 0, 1, 0], [0, 1, 1, 0, 0], [1, 0, 0, 1, 1], [0, 0, 1, 1, 0], [1, 1, 0, 0, 1],
                        [0, 1, 0, 1, 1], [1, 0, 1, 1, 0], [0, 0, 1, 0, 1], [1, 1, 1, 0, 0], [0, 1, 0, 0, 1]],
                       dtype=np.uint8)
    return params.load(FIXTURES / "custom_4x6.json").replace({"pattern": pattern})
