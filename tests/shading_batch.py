"""Batches of BYSDF parameter sets as Dr.Jit columns, shared by the lobe tests of the forward
model (``model/test_bysdf.py``) and of the surface model (``render/test_surface_bsdf.py``)."""

from __future__ import annotations

import dataclasses

import numpy as np

from weavecap.backend import mitsuba

mi = mitsuba()
import drjit as dr  # noqa: E402  (after the backend chose libLLVM)

from weavecap.model import bysdf as b  # noqa: E402


class ShadingBatch:
    """Parameter sets ``configs`` (dicts over :data:`weavecap.model.bysdf.DEFAULTS`), each
    repeated over ``lanes`` lanes: ``p`` the :class:`~weavecap.model.bysdf.Shading` of all of
    them, ``column(key)`` any one key as a Float or Color3f; with ``grad`` every column is a
    leaf of the AD graph, listed in ``leaves`` as (key, value)."""

    def __init__(self, configs: list[dict], lanes: int, *, grad: bool = False):
        self.count, self.lanes, self.grad = len(configs), lanes, grad
        self.values = [{**b.DEFAULTS, **c} for c in configs]
        self.leaves = []
        self.p = b.Shading(**{f.name: self.column(f.name) for f in dataclasses.fields(b.Shading)})

    def column(self, key: str):
        data = np.repeat(np.array([v[key] for v in self.values], dtype=np.float32), self.lanes)
        x = mi.Color3f(data, data, data) if key in b.COLOUR_KEYS else mi.Float(data)
        if self.grad:
            dr.enable_grad(x)
            self.leaves.append((key, x))
        return x

    def per_config(self, x) -> np.ndarray:
        """(configs, lanes) array of a Float, or of a colour's first channel."""
        a = np.asarray(x)
        return (a[0] if a.ndim == 2 else a).reshape(self.count, self.lanes)


def uniform_sphere(n: int, seed: int) -> "mi.Vector3f":
    """``n`` directions drawn uniformly over the sphere (seeded)."""
    rng = np.random.default_rng(seed)
    return mi.warp.square_to_uniform_sphere(mi.Point2f(rng.random(n, dtype=np.float32),
                                                       rng.random(n, dtype=np.float32)))


def mean_se(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-row mean and standard error of the mean."""
    return x.mean(axis=1), x.std(axis=1) / np.sqrt(x.shape[1])
