"""The surface maps of a fabric, kept between runs (``$WEAVECAP_CACHE_DIR/bake``).

:func:`weavecap.render.surface.bake` casts the forward model's rays over the repeat: 1–4 s at
16 texels a yarn, 15 s at 64, on the loaded 2-core machine, for every render of a fabric. The
maps depend only on the fabric and the texel count — and on the code that bakes them — so
:func:`cached_bake` keys an entry on all three: the fabric's JSON, the texels per yarn and the
source of the modules the bake runs (:data:`BAKE_MODULES`; a change to any of them bakes
again). Entries are plain ``.npz`` arrays read without pickle and written atomically; a
damaged one is baked again; the folder may be deleted at any time.
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib
from pathlib import Path

import numpy as np

from ..io import atomic_path, user_cache_dir
from ..params import Fabric, dumps
from .surface import SurfaceMaps, bake

#: the modules whose code shapes the maps (their source is part of the key)
BAKE_MODULES = ("weavecap.render.surface", "weavecap.model.geometry", "weavecap.model.render", "weavecap.model.bysdf",
                "weavecap.model.scene", "weavecap.params")


def _source_digest() -> bytes:
    h = hashlib.sha256()
    for name in BAKE_MODULES:
        h.update(Path(importlib.import_module(name).__file__).read_bytes())
    return h.digest()


def bake_key(fabric: Fabric, texels_per_yarn: int) -> str:
    """The cache key of a bake: a hash of the fabric, the texel count and the bake's code."""
    h = hashlib.sha256(_source_digest())
    h.update(dumps(fabric).encode())
    h.update(str(int(texels_per_yarn)).encode())
    return h.hexdigest()[:32]


def cached_bake(fabric: Fabric, texels_per_yarn: int, *, cache_dir: Path | None = None) -> tuple[SurfaceMaps, bool]:
    """:func:`weavecap.render.surface.bake` through the cache: (maps, whether they were cached)."""
    folder = Path(cache_dir) if cache_dir is not None else user_cache_dir("bake")
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{bake_key(fabric, texels_per_yarn)}.npz"
    names = [f.name for f in dataclasses.fields(SurfaceMaps)]
    if path.is_file():
        try:
            with np.load(path, allow_pickle=False) as data:
                values = {n: np.array(data[n]) for n in names}
            values["pattern_shape"] = tuple(int(v) for v in values["pattern_shape"])
            values["texels_per_yarn"] = int(values["texels_per_yarn"])
            return SurfaceMaps(**values), True
        except (OSError, KeyError, ValueError, EOFError):
            pass  # damaged or foreign entry: bake again
    maps = bake(fabric, texels_per_yarn=texels_per_yarn)
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as fh:
            np.savez(fh, **{n: np.asarray(getattr(maps, n)) for n in names})
    return maps, False
