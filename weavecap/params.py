"""The fabric: typed parameters of ``params.schema.json``, loaded, validated and saved.

One fabric is the parameter set of Table 1 in Wu et al. 2025 (§3.3, §3.4): a binary weave
pattern, the numbers of plies and fibres, yarn radii, and the BYSDF appearance parameters.
Names follow the schema (snake_case); colours are linear RGB in [0, 1].

Two kinds of range live here, each in one place:

- validity: what the schema allows (``weavecap/schemas/params.schema.json``, a copy of the
  contract); every message names the field, the value and the allowed range;
- :data:`FIT_RANGES`: Table 1's empirical ranges, used for sampling training data, for the
  initializer's output scaling and for the barrier and clamping of the fit (§5.3, §6.1).
"""

from __future__ import annotations

import dataclasses
import functools
import json
import math
import os
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any, Union

import numpy as np

from .errors import ParamsError

FORMAT = "weavecap.params/1"

RGB = tuple[float, float, float]
Colour = Union[RGB, str]  # an RGB colour, or an absolute path to a texture image

#: Table 1 of Wu et al. 2025: the empirical range of every fitted parameter, by dotted key.
#: Colours are per channel. Discrete ones are inclusive integer ranges.
FIT_RANGES: dict[str, tuple[float, float]] = {
    "plies": (1, 7),
    "fibers": (20, 50),
    "specular.coefficient": (0.2, 0.8),
    "specular.reflection": (0.0, 1.0),
    "specular.transmission": (0.0, 1.0),
    "specular.transmission_exit": (0.0, 1.0),
    "specular.roughness": (0.0, 1.0),
    "specular.roughness_exit": (0.0, 1.0),
    "specular.ior": (1.4, 1.6),
    "specular.ior_exit": (1.4, 1.6),
    "specular.attenuation": (9.0, 11.0),
    "body_attenuation": (0.1, 0.7),
    "warp.body_reflection": (0.0, 1.0),
    "weft.body_reflection": (0.0, 1.0),
    "warp.body_subsurface": (0.0, 1.0),
    "weft.body_subsurface": (0.0, 1.0),
    "warp.radius": (1.0, 5.0),
    "weft.radius": (1.0, 5.0),
    "shadowing.ply": (0.0, 1.0),
    "shadowing.fiber": (0.0, 1.0),
}

#: The continuous parameters (Table 1, lower block), in a fixed order.
CONTINUOUS_KEYS: tuple[str, ...] = tuple(k for k in FIT_RANGES if k not in ("plies", "fibers"))


@dataclass(frozen=True)
class Yarn:
    """Warp or weft yarn: radius r_a / r_e (Algorithm 1 units) and body colours R^B, S^B."""

    radius: float
    body_reflection: Colour
    body_subsurface: RGB


@dataclass(frozen=True)
class Specular:
    """The specular (rough dielectric) part of the BYSDF, §3.3 Eq. 1–2."""

    coefficient: float  # m_r
    reflection: RGB  # R^S
    transmission: RGB  # T^S
    transmission_exit: RGB  # T^S_y
    roughness: float  # alpha^S
    roughness_exit: float  # alpha^S_y
    ior: float  # eta^S
    ior_exit: float  # eta^S_y
    attenuation: float  # A^S


@dataclass(frozen=True)
class Shadowing:
    """Ply and fibre self-shadowing strengths G_p, G_f (§3.3)."""

    ply: float
    fiber: float


@dataclass(frozen=True)
class PaletteEntry:
    """One yarn colour of a colour order: body reflection R^B and subsurface colour S^B (§3.3)."""

    body_reflection: RGB
    body_subsurface: RGB


@dataclass(frozen=True)
class ThreadColours:
    """The colour order of one yarn family over its colour repeat (yarn-dyed stripes, checks,
    plaids; a WIF's ``COLOR TABLE`` with ``WARP COLORS`` / ``WEFT COLORS``).

    ``sequence[k]`` is the palette entry of the k-th end (warp) or pick (weft) of the colour
    repeat, counted like the pattern's columns (rows): thread ``j`` of the tiled fabric has
    entry ``sequence[j mod len(sequence)]``. The colour repeat tiles on its own, so the fabric
    repeats every lcm of the weave's and the colours' repeats.
    """

    palette: tuple[PaletteEntry, ...]
    sequence: tuple[int, ...]

    @property
    def repeat(self) -> int:
        """Threads in the colour repeat."""
        return len(self.sequence)

    def per_thread(self, key: str) -> np.ndarray:
        """(repeat, 3) float64: ``key`` (``"body_reflection"`` or ``"body_subsurface"``) of
        each thread of the colour repeat."""
        table = np.array([getattr(entry, key) for entry in self.palette], dtype=np.float64)
        return table[np.asarray(self.sequence, dtype=np.int64)]


@dataclass(frozen=True)
class Threads:
    """Per-thread colours of a yarn-dyed fabric: a colour order for the warp, the weft or both;
    a family without one has its own body colours on every thread."""

    warp: ThreadColours | None = None
    weft: ThreadColours | None = None

    def family(self, name: str) -> ThreadColours | None:
        """The colour order of ``"warp"`` or ``"weft"``, or None."""
        return getattr(self, name)


@dataclass(frozen=True)
class Fabric:
    """One woven fabric (Table 1). ``pattern`` is (wefts, warps) uint8; 1 = weft over warp."""

    pattern: np.ndarray
    plies: int
    fibers: int
    warp: Yarn
    weft: Yarn
    specular: Specular
    body_attenuation: float
    shadowing: Shadowing
    noise: dict | None = None
    scale: dict | None = None
    extra: dict = field(default_factory=dict)
    threads: Threads | None = None

    @property
    def shape(self) -> tuple[int, int]:
        """(wefts, warps) of the minimum repeat."""
        return (int(self.pattern.shape[0]), int(self.pattern.shape[1]))

    @property
    def full_repeat(self) -> tuple[int, int]:
        """(wefts, warps) over which the fabric repeats with its thread colours: each side the
        lcm of the weave's repeat and that family's colour repeat (the weave's without them)."""
        out = []
        for n, name in zip(self.shape, ("weft", "warp")):
            order = self.threads.family(name) if self.threads is not None else None
            out.append(n if order is None else math.lcm(n, order.repeat))
        return (out[0], out[1])

    def with_threads(self, threads: Threads | None) -> "Fabric":
        """A copy with these thread colours (None: the family colours on every thread), validated."""
        doc = to_dict(self)
        doc.pop("threads", None)
        if threads is not None and (threads.warp is not None or threads.weft is not None):
            doc["threads"] = _threads_doc(threads)
        return from_dict(doc)

    def get(self, key: str) -> Any:
        """Value of a dotted key, e.g. ``get("specular.ior")``."""
        obj: Any = self
        for part in key.split("."):
            obj = getattr(obj, part)
        return obj

    def replace(self, values: dict[str, Any]) -> "Fabric":
        """A copy with dotted keys replaced, e.g. ``replace({"warp.radius": 2.5})``.

        The replaced values are validated (the rest already was): an out-of-range value raises
        :class:`ParamsError`.
        """
        doc, valid = to_dict(self), True
        for key, value in values.items():
            node = doc
            parts = key.split(".")
            for part in parts[:-1]:
                node = node[part]
            if parts[-1] not in node:
                raise ParamsError("no such parameter", field=key)
            node[parts[-1]] = np.asarray(value).tolist() if not isinstance(value, str) else value
            valid = valid and _field_valid(key, node[parts[-1]])
        if not valid:
            return from_dict(doc)  # the whole document: raises naming the field (or passes: a key under extra)
        if "pattern" in values:
            _check_pattern_shape(doc, None)
        return _build(doc)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Fabric) and to_dict(self) == to_dict(other)

    __hash__ = None  # mutable numpy member


# ---------------------------------------------------------------------------------------------
# validation


def _schema() -> dict:
    with resources.files("weavecap").joinpath("schemas/params.schema.json").open() as fh:
        return json.load(fh)


def _dotted(path) -> str:
    out = ""
    for part in path:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out


def _allowed(schema: dict) -> str:
    """The allowed range or values of one schema node, for a message."""
    if "$ref" in schema:
        root = _schema()
        return _allowed(root["$defs"][schema["$ref"].rsplit("/", 1)[-1]])
    if schema.get("type") == "object" and schema.get("required"):
        return "an object with " + ", ".join(schema["required"])
    if "oneOf" in schema:
        return " or ".join(_allowed(option) for option in schema["oneOf"])
    if "enum" in schema:
        return "one of " + ", ".join(json.dumps(v) for v in schema["enum"])
    if "const" in schema:
        return f"exactly {json.dumps(schema['const'])}"
    lo = schema.get("minimum", schema.get("exclusiveMinimum"))
    hi = schema.get("maximum", schema.get("exclusiveMaximum"))
    lo_s = "(" if "exclusiveMinimum" in schema else "["
    hi_s = ")" if "exclusiveMaximum" in schema else "]"
    kind = schema.get("type", "number")
    a_kind = f"{'an' if str(kind)[0] in 'aeiou' else 'a'} {kind}"
    if lo is not None and hi is not None:
        return f"{a_kind} in {lo_s}{lo}, {hi}{hi_s}"
    if lo is not None:
        return f"{a_kind} {'>' if lo_s == '(' else '>='} {lo}"
    if hi is not None:
        return f"{a_kind} {'<' if hi_s == ')' else '<='} {hi}"
    if "minItems" in schema or "maxItems" in schema:
        if schema.get("minItems") == schema.get("maxItems") == 3 and schema.get("items", {}).get("maximum") == 1:
            return "an RGB colour: 3 numbers [r, g, b] in [0, 1]"
        return f"a list of {schema.get('minItems', 0)} to {schema.get('maxItems', 'any number of')} items"
    return a_kind if isinstance(kind, str) else "a valid value"


def _non_finite(doc: Any, path: tuple = ()) -> tuple | None:
    """Path of the first NaN or infinity in a parsed JSON document, or None."""
    if isinstance(doc, float) and not math.isfinite(doc):
        return path
    if isinstance(doc, dict):
        items = doc.items()
    elif isinstance(doc, list):
        items = enumerate(doc)
    else:
        return None
    for key, value in items:
        found = _non_finite(value, path + (key,))
        if found is not None:
            return found
    return None


def _schema_at(schema: dict, path: tuple) -> dict:
    """The schema node that governs ``path`` (colours: the RGB branch), for a message."""

    def deref(node: dict) -> dict:
        while "$ref" in node:
            node = schema["$defs"][node["$ref"].rsplit("/", 1)[-1]]
        return node["oneOf"][0] if "oneOf" in node else node

    node = deref(schema)
    for part in path:
        node = deref(node.get("items", {}) if isinstance(part, int) else node.get("properties", {}).get(part, {}))
    return deref(node)


@functools.lru_cache(maxsize=None)
def _field_validator(key: str):
    """A validator of the schema's node at dotted ``key`` (its ``$defs`` along), or None where
    the key has no node of its own (under ``extra``)."""
    import jsonschema

    schema = _schema()
    node = schema
    for part in key.split("."):
        while "$ref" in node:
            node = schema["$defs"][node["$ref"].rsplit("/", 1)[-1]]
        node = node.get("properties", {}).get(part)
        if node is None:
            return None
    return jsonschema.Draft202012Validator({"$defs": schema["$defs"], **node})


def _field_valid(key: str, value: Any) -> bool:
    """Whether one field's JSON value is finite and allowed by the schema (a fabric's other
    fields were validated when it was made: :meth:`Fabric.replace` checks only what changed,
    a whole document taking about 0.6 ms, a fit replacing values a thousand times)."""
    validator = _field_validator(key)
    if validator is None or _non_finite(value) is not None or not validator.is_valid(value):
        return False
    if key in VALUE_RANGES:
        lo, hi, _ = VALUE_RANGES[key]
        return lo <= value <= hi
    return key.split(".")[0] not in ("noise", "scale")  # checked whole (check_values)


def validate(doc: Any, *, path: str | None = None) -> None:
    """Check a parsed params document against the schema; raise :class:`ParamsError` naming
    the field, the value and the allowed range of the first problem found."""
    import jsonschema

    schema = _schema()
    bad = _non_finite(doc)
    if bad is not None:
        raise ParamsError(f"NaN and infinity are not allowed; expected {_allowed(_schema_at(schema, bad))}",
                          field=_dotted(bad), path=path)
    validator = jsonschema.Draft202012Validator(schema)
    errors = sorted(validator.iter_errors(doc), key=lambda e: (len(e.absolute_path), list(map(str, e.absolute_path))))
    if not errors:
        _check_pattern_shape(doc, path)
        _check_thread_sequences(doc, path)
        check_values(doc, path=path)
        return
    err = errors[0]
    # for oneOf (colour or texture path), report the deepest sub-error: it names the channel
    # (a sub-error's absolute_path already includes its parent's path)
    if err.validator == "oneOf" and err.context:
        err = max(err.context, key=lambda e: len(e.relative_path))
    err_path = list(err.absolute_path)
    fld = _dotted(err_path) or "(top level)"
    if err.validator == "required":
        missing = err.message.split("'")[1] if "'" in err.message else err.message
        name = f"{fld}.{missing}" if err_path else missing
        raise ParamsError(f"missing required field (allowed: {_allowed(err.schema.get('properties', {}).get(missing, {}))})",
                          field=name, path=path)
    if err.validator == "additionalProperties":
        raise ParamsError(f"{err.message}; extra keys belong under 'extra'", field=fld, path=path)
    raise ParamsError(f"{json.dumps(err.instance)[:60]} is not allowed; expected {_allowed(err.schema)}",
                      field=fld, path=path)


def _check_pattern_shape(doc: dict, path: str | None) -> None:
    rows = doc["pattern"]
    width = len(rows[0])
    for i, row in enumerate(rows):
        if len(row) != width:
            raise ParamsError(f"row {i} has {len(row)} cells but row 0 has {width}; the pattern must be rectangular",
                              field=f"pattern[{i}]", path=path)


def _check_thread_sequences(doc: dict, path: str | None) -> None:
    """Every entry of a colour order's ``sequence`` names an entry of its ``palette``."""
    for name, order in (doc.get("threads") or {}).items():
        size = len(order["palette"])
        for k, entry in enumerate(order["sequence"]):
            if entry >= size:
                raise ParamsError(f"palette entry {entry} does not exist; the palette has {size} "
                                  f"(entries 0 to {size - 1})", field=f"threads.{name}.sequence[{k}]", path=path)


# ---------------------------------------------------------------------------------------------
# values the schema leaves open: finite ranges, the noise block (docs/reliability.md)

#: dotted key → (lowest, highest, why): the range of a value the schema bounds on one side
#: only, so that no value overflows the renderer or makes it loop. Inclusive.
VALUE_RANGES: dict[str, tuple[float, float, str]] = {
    **{f"{yarn}.radius": (0.1, 10.0, "in Algorithm 1's units, where the yarn pitch is 10: 5 closes the gaps, 10 "
                          "overlaps the neighbours whole, under 0.1 the yarn is a hundredth of its spacing")
       for yarn in ("warp", "weft")},
    "specular.attenuation": (0.0, 1000.0, "per unit of Algorithm 1's length; at 1000 the light is gone within 0.005 "
                             "units, a larger value renders alike"),
    "body_attenuation": (0.0, 1000.0, "at 1000 the body is opaque; a larger value renders alike"),
    "scale.pitch_mm": (0.001, 1000.0, "the distance between neighbouring yarns, from 1 µm to 1 m (0 or less "
                       "is no fabric; 1e-300 made the renderer's texture coordinates overflow)"),
}

#: the noise block (§6.3): at most this many Gaussians; the weights are variances of relative
#: brightness (summing to the residual's variance; at most 1, a standard deviation of the
#: brightness itself); means in
#: cycles per yarn pitch; covariances positive definite with eigenvalues in this range
NOISE_GAUSSIANS = 64
NOISE_MEAN = 1.0e4
NOISE_EIGENVALUES = (1.0e-12, 1.0e8)


def check_values(doc: dict, *, path: str | None = None) -> None:
    """Check what a schema-valid document's schema leaves open (:data:`VALUE_RANGES`, the
    noise block); raise :class:`ParamsError` naming the field, the value, the range and why.

    A noise Gaussian's covariance must be symmetric and positive definite (a singular one made
    the synthesis raise, an indefinite one an all-NaN image), its weight within [0, 1] and the
    weights' sum at most 1 (a weight of 1e6 made pixel values of 2981)."""
    for key, (lo, hi, why) in VALUE_RANGES.items():
        node = doc
        for part in key.split("."):
            node = node.get(part) if isinstance(node, dict) else None
        if node is not None and not lo <= node <= hi:
            raise ParamsError(f"{node!r} is out of range; expected a number in [{lo:g}, {hi:g}] ({why})",
                              field=key, path=path)
    gaussians = (doc.get("noise") or {}).get("gaussians", [])
    if len(gaussians) > NOISE_GAUSSIANS:
        raise ParamsError(f"{len(gaussians)} Gaussians; at most {NOISE_GAUSSIANS} (weavecap fit writes 4)",
                          field="noise.gaussians", path=path)
    for i, g in enumerate(gaussians):
        _check_gaussian(g, f"noise.gaussians[{i}]", path)
    total = sum(g["weight"] for g in gaussians)
    if total > 1.0:
        raise ParamsError(f"the weights sum to {total:.4g}; at most 1 (each weight is a variance of relative brightness, "
                          "their sum the photo's residual variance)", field="noise.gaussians", path=path)


def _check_gaussian(g: dict, fld: str, path: str | None) -> None:
    """One noise Gaussian: weight in [0, 1], mean within ±NOISE_MEAN, covariance symmetric
    positive definite with eigenvalues in NOISE_EIGENVALUES."""
    if not 0.0 <= g["weight"] <= 1.0:
        raise ParamsError(f"{g['weight']!r} is out of range; expected a number in [0, 1] (a variance of "
                          "relative brightness)", field=f"{fld}.weight", path=path)
    if max(abs(v) for v in g["mean"]) > NOISE_MEAN:
        raise ParamsError(f"{g['mean']!r} is out of range; expected frequencies within ±{NOISE_MEAN:g} cycles per "
                          "yarn pitch", field=f"{fld}.mean", path=path)
    cov = np.asarray(g["cov"], dtype=np.float64)
    lo, hi = NOISE_EIGENVALUES
    scale = max(float(np.abs(cov).max()), 1e-300)
    if abs(cov[0, 1] - cov[1, 0]) > 1e-9 * scale:
        raise ParamsError(f"{g['cov']!r} is not symmetric; a covariance has cov[0][1] == cov[1][0]",
                          field=f"{fld}.cov", path=path)
    eig = np.linalg.eigvalsh(cov)
    if not (lo <= eig[0] and eig[1] <= hi):
        what = "not positive definite" if eig[0] <= 0 else "out of range"
        raise ParamsError(f"{g['cov']!r} is {what} (eigenvalues {eig[0]:.3g}, {eig[1]:.3g}); a covariance needs "
                          f"eigenvalues in [{lo:g}, {hi:g}] (cycles per yarn pitch, squared)",
                          field=f"{fld}.cov", path=path)


# ---------------------------------------------------------------------------------------------
# conversion


def _rgb(value: Any) -> RGB:
    return (float(value[0]), float(value[1]), float(value[2]))


def _colour(value: Any, base: Path | None, fld: str, path: str | None) -> Colour:
    if isinstance(value, str):
        tex = Path(value)
        if not tex.is_absolute() and base is not None:
            tex = base / tex
        check_texture(tex, fld, path)
        return str(tex.resolve())
    return _rgb(value)


def check_texture(tex: Path, fld: str, path: str | None) -> None:
    """Refuse a body-colour texture that is not a readable image file, with :class:`ParamsError`
    (exit 2: the params file is what is wrong, not a photo) naming the field and why.

    Decoded here, so that a texture fails when its params file is read, not in the middle of
    a render (where an unreadable one was a "photo rejected", exit 3); once per file version
    (a fit replaces values thousands of times)."""
    fix = "give a path relative to the params file or an RGB colour [r, g, b] in [0, 1]"
    if not tex.exists():
        raise ParamsError(f"texture file {str(tex)!r} does not exist; {fix}", field=fld, path=path)
    if not tex.is_file():
        kind = "a folder" if tex.is_dir() else "not a regular file (a device or a pipe)"
        raise ParamsError(f"texture {str(tex)!r} is {kind}; {fix}", field=fld, path=path)
    stat = tex.stat()
    problem = _texture_problem(str(tex), stat.st_mtime_ns, stat.st_size)
    if problem:
        raise ParamsError(f"the texture cannot be used: {problem}", field=fld, path=path)


@functools.lru_cache(maxsize=64)
def _texture_problem(tex: str, mtime_ns: int, size: int) -> str:
    """Why the image file ``tex`` (of this modification time and size) cannot be read, or ``""``."""
    from .errors import PhotoError
    from .photo import load_photo

    try:
        load_photo(tex)
    except PhotoError as exc:
        return str(exc)
    return ""


def from_dict(doc: Any, *, base: Path | None = None, path: str | None = None) -> Fabric:
    """Validate a parsed document and build a :class:`Fabric`. ``base``: folder for textures."""
    validate(doc, path=path)
    return _build(doc, base=base, path=path)


def _build(doc: dict, *, base: Path | None = None, path: str | None = None) -> Fabric:
    """The :class:`Fabric` of a valid document."""

    def yarn(d: dict, name: str) -> Yarn:
        return Yarn(radius=float(d["radius"]),
                    body_reflection=_colour(d["body_reflection"], base, f"{name}.body_reflection", path),
                    body_subsurface=_rgb(d["body_subsurface"]))

    s = doc["specular"]
    return Fabric(
        pattern=np.asarray(doc["pattern"], dtype=np.uint8),
        plies=int(doc["plies"]),
        fibers=int(doc["fibers"]),
        warp=yarn(doc["warp"], "warp"),
        weft=yarn(doc["weft"], "weft"),
        specular=Specular(
            coefficient=float(s["coefficient"]), reflection=_rgb(s["reflection"]),
            transmission=_rgb(s["transmission"]), transmission_exit=_rgb(s["transmission_exit"]),
            roughness=float(s["roughness"]), roughness_exit=float(s["roughness_exit"]),
            ior=float(s["ior"]), ior_exit=float(s["ior_exit"]), attenuation=float(s["attenuation"])),
        body_attenuation=float(doc["body_attenuation"]),
        shadowing=Shadowing(ply=float(doc["shadowing"]["ply"]), fiber=float(doc["shadowing"]["fiber"])),
        noise=doc.get("noise"),
        scale=doc.get("scale"),
        extra=dict(doc.get("extra", {})),
        threads=_threads(doc.get("threads")),
    )


def _threads(doc: dict | None) -> Threads | None:
    """The :class:`Threads` of a valid ``threads`` document (None when absent or empty)."""
    if not doc:
        return None

    def order(d: dict | None) -> ThreadColours | None:
        if d is None:
            return None
        return ThreadColours(palette=tuple(PaletteEntry(_rgb(e["body_reflection"]), _rgb(e["body_subsurface"]))
                                           for e in d["palette"]),
                             sequence=tuple(int(k) for k in d["sequence"]))

    return Threads(warp=order(doc.get("warp")), weft=order(doc.get("weft")))


def _threads_doc(threads: Threads) -> dict:
    """The ``threads`` document of a :class:`Threads` (a family without a colour order left out)."""
    return json.loads(json.dumps({name: dataclasses.asdict(order) for name in ("warp", "weft")
                                  if (order := threads.family(name)) is not None}))


def to_dict(fabric: Fabric) -> dict:
    """The JSON document of a fabric (texture paths stay absolute; :func:`save` relativises)."""
    doc: dict[str, Any] = {"format": FORMAT, "pattern": fabric.pattern.astype(int).tolist()}
    for f in dataclasses.fields(fabric):
        if f.name == "pattern":
            continue
        value = getattr(fabric, f.name)
        if value is None:
            continue
        if f.name == "threads":
            doc[f.name] = _threads_doc(value)
            continue
        doc[f.name] = dataclasses.asdict(value) if dataclasses.is_dataclass(value) else value
    # tuples → lists so that the document equals its JSON round trip
    return json.loads(json.dumps(doc))


#: the largest params file read (a fabric with 64 noise Gaussians is a few KiB)
MAX_FILE_BYTES = 1 << 20


def load(path: str | os.PathLike) -> Fabric:
    """Read and validate a params file. Raises :class:`ParamsError` (exit 2) for anything wrong."""
    from .io import loads_json

    p = Path(path)
    if p.is_dir():
        raise ParamsError("is a folder; give the path of a params.json file", path=str(p))
    if not p.exists():
        raise ParamsError("file not found; give the path of a params.json file", path=str(p))
    if not p.is_file():
        raise ParamsError("is not a regular file (a device or a pipe); give the path of a params.json file",
                          path=str(p))
    try:
        if p.stat().st_size > MAX_FILE_BYTES:
            raise ParamsError(f"{p.stat().st_size} bytes is too large for a params file (at most {MAX_FILE_BYTES}); "
                              "give the params.json weavecap fit wrote", path=str(p))
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ParamsError(f"cannot read the file as UTF-8 text ({exc})", path=str(p)) from exc
    try:
        doc = loads_json(text)
    except json.JSONDecodeError as exc:
        raise ParamsError(f"not valid JSON at line {exc.lineno}, column {exc.colno}: {exc.msg}", path=str(p)) from exc
    except ValueError as exc:
        raise ParamsError(f"not a params document: {exc}", path=str(p)) from exc
    return from_dict(doc, base=p.parent, path=str(p))


def dumps(fabric: Fabric, *, base: Path | None = None) -> str:
    """JSON text of a fabric, with texture paths relative to ``base`` where possible."""
    doc = to_dict(fabric)
    if base is not None:
        for yarn in ("warp", "weft"):
            tex = doc[yarn]["body_reflection"]
            if isinstance(tex, str):
                doc[yarn]["body_reflection"] = os.path.relpath(tex, base)
    validate(doc)
    return json.dumps(doc, indent=1) + "\n"


def save(fabric: Fabric, path: str | os.PathLike) -> None:
    """Write a params file atomically (temporary name, then rename)."""
    from .io import atomic_write_text

    p = Path(path)
    atomic_write_text(p, dumps(fabric, base=p.parent.resolve()))
