"""The fabric for the tools practitioners use (``weavecap export``; docs/design.md, "Commands").

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

import functools
import os
from collections.abc import Callable
from dataclasses import dataclass, replace
from datetime import datetime, timezone
from pathlib import Path

from .. import __version__
from ..errors import InputError
from ..io import inside, plain_name, refuse_overwrite
from ..params import Fabric
from .maps import PbrMaps


#: the U3M preview: one tile rendered at this many pixels a side and samples per pixel
PREVIEW_PIXELS, PREVIEW_SPP = 256, 32

#: formats whose files carry the PBR material (they need the surface model's bake and a pitch)
MATERIAL_FORMATS = ("pbr", "u3m", "gltf", "mitsuba")


@dataclass(frozen=True)
class ExportOptions:
    """What ``weavecap export`` writes.

    Attributes
    ----------
    formats : names from :data:`FORMATS`, in the order given
    name : file name stem of every output
    force : overwrite existing outputs
    pitch_mm : yarn spacing in millimetres, in place of the params' ``scale.pitch_mm``
    texels_per_yarn : map resolution; repeats : weave repeats per tile side
    bits : 8 or 16 bits per channel of PNG maps; map_format : ``png`` or ``exr`` (PBR maps)
    normal_convention : ``opengl`` or ``directx`` (PBR maps; U3M and glTF are OpenGL by spec)
    swatch_mm : side of the glTF and Mitsuba swatches
    seed : of the material fit's samples; created : time stamp written into U3M
    source : bytes that identify the input (the U3M material id is hashed from them)
    """

    formats: tuple[str, ...]
    name: str
    force: bool = False
    pitch_mm: float | None = None
    texels_per_yarn: int = 16
    repeats: int = 1
    bits: int = 8
    map_format: str = "png"
    normal_convention: str = "opengl"
    swatch_mm: float = 100.0
    seed: int = 0
    created: datetime | None = None
    source: bytes = b""


@dataclass(frozen=True)
class Plan:
    """What one format will write: every file, and the call that writes them."""

    paths: list[Path]
    write: Callable[[], object]


class Material:
    """The fabric's PBR material, fitted on first use (:func:`.material.pbr_maps`) and shared
    by every format of one export."""

    def __init__(self, fabric: Fabric, options: ExportOptions):
        self.fabric, self.options = fabric, options

    @functools.cached_property
    def maps(self) -> PbrMaps:
        from .material import pbr_maps

        o = self.options
        return pbr_maps(self.fabric, pitch_mm=pitch_of(self.fabric, o.pitch_mm), texels_per_yarn=o.texels_per_yarn,
                        repeats=o.repeats, seed=o.seed)

    def about(self) -> dict:
        """What the maps were made from, for the files' metadata."""
        from ..estimate.weave_name import weave_name

        return {"generator": f"weavecap {__version__}", "weave": weave_name(self.fabric.pattern),
                "pattern": list(self.fabric.shape), "pitch_mm": pitch_of(self.fabric, self.options.pitch_mm)}


def pitch_of(fabric: Fabric, pitch_mm: float | None) -> float:
    """The yarn pitch in millimetres: ``pitch_mm`` if given, else the params' ``scale.pitch_mm``.

    Raises
    ------
    InputError
        Neither is known (the maps' physical size depends on it).
    """
    pitch = pitch_mm if pitch_mm is not None else (fabric.scale or {}).get("pitch_mm")
    if pitch is None:
        raise InputError("scale.pitch_mm: the params file does not say how far apart the yarns are, and the maps' "
                         "physical size depends on it; pass --pitch-mm (e.g. --pitch-mm 0.3), or --format wif for "
                         "the draft alone (nothing was written)")
    return float(pitch)


def _wif(fabric: Fabric, out: Path, options: ExportOptions, material: Material) -> Plan:
    from ..wif import save_wif

    path = out / f"{options.name}.wif"
    return Plan([path], lambda: save_wif(fabric, path, force=True))


def _pbr(fabric: Fabric, out: Path, options: ExportOptions, material: Material) -> Plan:
    from .pbr import pbr_files, save_pbr

    folder = out / "pbr"
    files = pbr_files(options.name, ext=f".{options.map_format}")
    return Plan([folder / f for f in files.values()],
                lambda: save_pbr(material.maps, folder, name=options.name, fmt=options.map_format, bits=options.bits,
                                 normal_convention=options.normal_convention, about=material.about()))


def _u3m(fabric: Fabric, out: Path, options: ExportOptions, material: Material) -> Plan:
    from .u3m import save_u3m, u3m_files

    folder = out / "u3m"

    def write():
        maps = material.maps
        return save_u3m(maps, folder, name=options.name, description=f"{material.about()['weave']}, made by weavecap",
                        material_key=options.source + repr(options).encode(), created=_created(options),
                        preview=_preview(maps), bits=options.bits, custom=material.about())

    return Plan([folder / f for f in u3m_files(options.name).values()], write)


def _gltf(fabric: Fabric, out: Path, options: ExportOptions, material: Material) -> Plan:
    from .gltf import save_gltf

    path = out / f"{options.name}.glb"
    return Plan([path], lambda: save_gltf(material.maps, path, name=options.name, swatch_mm=options.swatch_mm,
                                          extras=material.about()))


def _mitsuba(fabric: Fabric, out: Path, options: ExportOptions, material: Material) -> Plan:
    from . import mitsuba

    folder = out / "mitsuba"
    files = mitsuba.scene_files(options.name, fabric)
    return Plan([folder / f for f in files.values()],
                lambda: mitsuba.save_scenes(material.maps, fabric, folder, name=options.name,
                                            swatch_mm=options.swatch_mm, texels_per_yarn=options.texels_per_yarn))


#: format name → planner ``(fabric, out, options, material) → Plan``
FORMATS: dict[str, Callable[[Fabric, Path, ExportOptions, Material], Plan]] = {
    "wif": _wif, "pbr": _pbr, "u3m": _u3m, "gltf": _gltf, "mitsuba": _mitsuba}


def _created(options: ExportOptions) -> datetime:
    return options.created or datetime.now(timezone.utc)


def _preview(maps: PbrMaps):
    """The U3M preview: the maps on plain Mitsuba's principled BSDF, one tile seen from above."""
    import tempfile

    from . import mitsuba

    with tempfile.TemporaryDirectory() as tmp:
        textures = {key: str(Path(tmp) / f"{key}.png") for key in mitsuba.TEXTURES}
        mitsuba.write_textures(maps, Path(tmp), textures)
        scene = mitsuba.swatch_scene(maps, textures, swatch_mm=maps.size_mm[0], size=(PREVIEW_PIXELS, PREVIEW_PIXELS),
                                     spp=PREVIEW_SPP)
        return mitsuba.render_scene(scene)


def default_name(params_path: str | os.PathLike) -> str:
    """The output stem for a params file: its stem, or its folder's name for ``params.json``
    (what ``weavecap fit`` writes), made a plain name (:func:`weavecap.io.folder_name`: a
    params file ``...json`` gives ``fabric``)."""
    from ..io import folder_name

    p = Path(params_path).resolve()
    return folder_name(p.parent.name if p.stem == "params" and p.parent.name else p.stem, fallback="fabric")


def export(fabric: Fabric, out: str | os.PathLike, options: ExportOptions) -> list[Path]:
    """Write the fabric in each of ``options.formats`` under the folder ``out``.

    Returns
    -------
    list of Path
        The files written, in order.

    Raises
    ------
    InputError
        (exit 2) An unknown format, ``out`` is a file, ``options.name`` is not a plain file
        name (:func:`weavecap.io.plain_name`: every file stays under ``out``), or an output
        exists and ``force`` is false — checked for every output before anything is written.
    """
    out = Path(out)
    plain_name(options.name, what="the output name")
    if out.exists() and not out.is_dir():
        raise InputError(f"{out}: exists and is not a folder; give a folder for -o")
    unknown = [f for f in options.formats if f not in FORMATS]
    if unknown:
        raise InputError(f"unknown export format {unknown[0]!r}; choose from {', '.join(FORMATS)}")
    if any(f in MATERIAL_FORMATS for f in options.formats):
        pitch_of(fabric, options.pitch_mm)  # before any work
    material = Material(fabric, options)
    plans = [FORMATS[f](fabric, out, options, material) for f in dict.fromkeys(options.formats)]
    for plan in plans:
        for path in plan.paths:
            inside(out, path)
            refuse_overwrite(path, force=options.force)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for plan in plans:
        plan.write()
        written.extend(plan.paths)
    return written


def export_file(params_file: str | os.PathLike, out: str | os.PathLike, options: ExportOptions, *,
                pattern=None) -> list[Path]:
    """``weavecap export``: the fabric of ``params_file`` (with ``pattern``, (wefts, warps)
    uint8, in place of its own when given) written by :func:`export` into the folder ``out``,
    found writable before any work and held for the run (:func:`weavecap.io.folder_lock`).
    The U3M material's time stamp and id come from the file: its modification time, its fabric.

    Raises
    ------
    InputError
        ``out`` cannot be written or another run holds it, a bad params file or pattern, or
        what :func:`export` refuses.
    """
    from .. import params as wparams
    from ..io import check_writable, folder_lock

    check_writable(out, folder=True)
    fabric = wparams.load(params_file)
    if pattern is not None:
        fabric = fabric.replace({"pattern": pattern})
    options = replace(options, created=datetime.fromtimestamp(Path(params_file).stat().st_mtime, timezone.utc),
                      source=wparams.dumps(fabric).encode())
    with folder_lock(out):
        return export(fabric, out, options)
