"""The bake cache (weavecap.render.bake_cache): a fabric baked once is read back, unchanged,
and any change to the fabric or the texel count bakes again."""

from __future__ import annotations

import dataclasses

import numpy as np

from weavecap import params
from weavecap.fixtures import path as fixture_path
from weavecap.render.bake_cache import bake_key, cached_bake


def test_a_bake_is_read_back_and_a_changed_fabric_bakes_again(tmp_path):
    fabric = params.load(fixture_path("params", "plain.json"))
    first, cached = cached_bake(fabric, 16, cache_dir=tmp_path)
    again, cached_again = cached_bake(fabric, 16, cache_dir=tmp_path)
    assert not cached and cached_again
    for f in dataclasses.fields(first):
        assert np.array_equal(np.asarray(getattr(first, f.name)), np.asarray(getattr(again, f.name))), f.name
    assert again.pattern_shape == first.pattern_shape and again.texels_per_yarn == 16
    thicker = fabric.replace({"warp.radius": fabric.warp.radius * 1.2})
    assert bake_key(thicker, 16) != bake_key(fabric, 16) != bake_key(fabric, 32)
    (path,) = tmp_path.glob("*.npz")
    path.write_bytes(b"not an npz")  # a damaged entry is baked again
    maps, cached = cached_bake(fabric, 16, cache_dir=tmp_path)
    assert not cached and np.array_equal(maps.coverage, first.coverage)
