"""The fabric for the tools practitioners use (``weavecap export``; DESIGN.md, "Commands").

One module per format, each a writer of plain data:

- :mod:`weavecap.wif` — the weave as a WIF draft (weaving software, looms);
- :mod:`.maps` — :class:`~.maps.PbrMaps`, the material every other format writes, and how a
  map is stored as an image; :mod:`.pbr` — the maps as PNG/EXR files with their physical size;
- :mod:`.u3m` — U3M 1.1 for CLO 3D and Browzwear; :mod:`.gltf` — a glTF 2.0 swatch;
- :mod:`.mitsuba` — a Mitsuba 3 scene of a swatch.

:func:`export` plans every file first, refuses to overwrite any of them without ``force``
(nothing is written then), and writes each atomically.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from ..errors import InputError
from ..io import refuse_overwrite
from ..params import Fabric


@dataclass(frozen=True)
class ExportOptions:
    """What ``weavecap export`` writes.

    Attributes
    ----------
    formats : names from :data:`FORMATS`, in the order given
    name : file name stem of every output
    force : overwrite existing outputs
    """

    formats: tuple[str, ...]
    name: str
    force: bool = False


@dataclass(frozen=True)
class Plan:
    """What one format will write: every file, and the call that writes them."""

    paths: list[Path]
    write: Callable[[], object]


def _wif(fabric: Fabric, out: Path, options: ExportOptions) -> Plan:
    from ..wif import save_wif

    path = out / f"{options.name}.wif"
    return Plan([path], lambda: save_wif(fabric, path, force=True))


#: format name → planner ``(fabric, out, options) → Plan``
FORMATS: dict[str, Callable[[Fabric, Path, ExportOptions], Plan]] = {"wif": _wif}


def default_name(params_path: str | os.PathLike) -> str:
    """The output stem for a params file: its stem, or its folder's name for ``params.json``
    (what ``weavecap fit`` writes)."""
    p = Path(params_path).resolve()
    return p.parent.name if p.stem == "params" and p.parent.name else p.stem


def export(fabric: Fabric, out: str | os.PathLike, options: ExportOptions) -> list[Path]:
    """Write the fabric in each of ``options.formats`` under the folder ``out``.

    Returns
    -------
    list of Path
        The files written, in order.

    Raises
    ------
    InputError
        (exit 2) An unknown format, ``out`` is a file, or an output exists and ``force`` is
        false — checked for every output before anything is written.
    """
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InputError(f"{out}: exists and is not a folder; give a folder for -o")
    unknown = [f for f in options.formats if f not in FORMATS]
    if unknown:
        raise InputError(f"unknown export format {unknown[0]!r}; choose from {', '.join(FORMATS)}")
    plans = [FORMATS[f](fabric, out, options) for f in dict.fromkeys(options.formats)]
    for plan in plans:
        for path in plan.paths:
            refuse_overwrite(path, force=options.force)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for plan in plans:
        plan.write()
        written.extend(plan.paths)
    return written
