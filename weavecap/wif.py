"""Weaving drafts in and out: the pattern as a WIF file (Weaving Information File 1.1).

WIF is the text format weaving software exchanges drafts in (Fiberworks, WeaveIt, AdaCAD,
ThunderLoom, loom controllers). Parsing, validation and the file text are the maintained
library ``dtx-to-wif``'s (:func:`dtx_to_wif.read_wif`, :class:`dtx_to_wif.PatternData`,
:func:`dtx_to_wif.write_wif`). What this module adds, because the library does not do it:

- the drawdown (which warp end is up on which pick) from threading × tie-up × treadling or
  threading × liftplan, with treadles that lift nothing allowed (the library's
  ``make_liftplan`` raises ``KeyError`` on them, e.g. on ``treadles_with_defaults.wif``) and
  sinking sheds;
- weavecap's convention on top of it and the reduction to the minimum repeat;
- the factoring of a pattern into a draft: distinct columns → shafts (threading), distinct
  rows → treadles (tie-up and treadling), and the liftplan;
- errors that name the WIF section to fix (the library raises bare ``RuntimeError`` /
  ``ValueError`` without saying where).

Conventions. WIF numbers ends (warp threads) and picks (weft threads) from 1; end ``e`` is
weavecap's warp column ``e - 1`` (left to right) and pick ``p`` its weft row ``p - 1`` (top to
bottom), so a pattern written and read back is the same array. With ``Rising Shed=true`` (the
usual jack-loom and dobby case) the tie-up and liftplan list the shafts that *rise*: a warp end
on a raised shaft lies over the weft on that pick, seen from the face that is up on the loom.
weavecap's ``pattern[i, j] = 1`` means weft ``i`` over warp ``j``, so

    pattern[p - 1, e - 1] = 1 - raised(p, e)          (rising shed)
    pattern[p - 1, e - 1] = sunk(p, e)                (sinking shed: the listed shafts sink)

An end on no shaft is never raised (rising shed) or never sunk (sinking shed).
"""

from __future__ import annotations

import configparser
import io
import math
import os
import re
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import InputError

#: The largest repeat a weavecap fabric holds, per side (``params.schema.json``'s pattern).
MAX_REPEAT = 64

#: Ends or picks a WIF file may draft before it is refused unread (a drawdown this size is
#: 64 MiB of cells; real drafts are a few hundred to a few thousand threads).
MAX_THREADS = 8192

#: The longest colour repeat a weavecap fabric holds (``params.schema.json``'s ``threads``).
MAX_COLOUR_REPEAT = 4096

#: Files larger than this are not WIF drafts (the largest real drafts are a few hundred KiB).
MAX_BYTES = 16 * 2**20

#: A pattern reduced to at most this many shafts and treadles is also written as threading +
#: tie-up + treadling, the form a floor loom is set up from (16 shafts is the largest common
#: floor loom); beyond it the liftplan alone (a dobby or computer-assisted loom's form).
TREADLE_LIMIT = 16

#: How each lifting section's lines look, for messages.
_LINE_FORMS = {
    "threading": "END=SHAFT[,SHAFT...]",
    "tieup": "TREADLE=SHAFT[,SHAFT...]",
    "treadling": "PICK=TREADLE[,TREADLE...]",
    "liftplan": "PICK=SHAFT[,SHAFT...]",
    "color_table": "INDEX=R,G,B",
    "warp_colors": "END=COLOR-INDEX",
    "weft_colors": "PICK=COLOR-INDEX",
    "warp_spacing": "END=NUMBER",
    "weft_spacing": "PICK=NUMBER",
    "warp_thickness": "END=NUMBER",
    "weft_thickness": "PICK=NUMBER",
}

#: Typed keys of the header sections, as the library reads them: key → the form of its value.
_HEADER_KEYS = {
    "warp": {"threads": "INTEGER", "spacing": "NUMBER", "thickness": "NUMBER"},
    "weft": {"threads": "INTEGER", "spacing": "NUMBER", "thickness": "NUMBER"},
    "weaving": {"shafts": "INTEGER", "treadles": "INTEGER", "rising shed": "true|false"},
}


def _wif_bool(value: str) -> bool:
    from dtx_to_wif.wif_reader import WifBoolDict

    return WifBoolDict[value.strip().lower()]


_VALUE_PARSERS = {"INTEGER": int, "NUMBER": float, "true|false": _wif_bool}


@dataclass(frozen=True)
class Draft:
    """A weaving draft read from a WIF file.

    Attributes
    ----------
    drawdown : numpy.ndarray
        ``(picks, ends)`` uint8 as drafted, in weavecap's convention (1 = weft over warp).
    pattern : numpy.ndarray
        ``(wefts, warps)`` uint8, the drawdown's minimum repeat (at most 64 × 64).
    title : str
        ``[TEXT] Title``, or the file name.
    lifting : str
        The sections the drawdown came from: ``"[LIFTPLAN]"`` or ``"[TIEUP] × [TREADLING]"``.
    threads : weavecap.params.Threads or None
        The colour orders of ``[WARP COLORS]`` / ``[WEFT COLORS]`` over ``[COLOR TABLE]``
        (:func:`colour_orders`): a family drafted in more than one colour has one; None when
        neither is.
    """

    drawdown: np.ndarray
    pattern: np.ndarray
    title: str
    lifting: str
    threads: object = None


# ---------------------------------------------------------------------------------------------
# reading


def _refuse(path: str, section: str, message: str) -> InputError:
    where = f"[{section.upper().replace('_', ' ')}]" if section else ""
    return InputError(f"{path}: {where + ': ' if where else ''}{message}")


def _wif_text(path: str) -> str:
    """The file's text from its ``[WIF]`` line on, prepared for the library's ConfigParser."""
    p = Path(path)
    if p.exists() and not p.is_file():
        what = "a folder" if p.is_dir() else "not a regular file (a device or a pipe)"
        raise InputError(f"{path}: is {what}; give the path of a .wif file")
    try:
        size = p.stat().st_size
        if size > MAX_BYTES:
            raise InputError(f"{path}: {size} bytes is too large for a WIF draft (at most {MAX_BYTES} bytes)")
        data = p.read_bytes()
    except OSError as exc:
        raise InputError(f"{path}: cannot read the WIF file ({exc.strerror}); check the path") from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        text = data.decode("latin-1")  # older Windows weaving programs write ANSI text
    lines = text.splitlines()
    start = next((i for i, line in enumerate(lines) if line.strip().lower() == "[wif]"), None)
    if start is None:  # checked here: the library's reader loops forever on a file without one
        raise _refuse(path, "wif", "not a WIF file: no [WIF] section; a WIF draft starts with a [WIF] line "
                      "(save or export the draft as WIF)")
    out = []
    for line in lines[start:]:
        header = re.fullmatch(r"\s*\[(.*)\]\s*", line)
        if header and not header.group(1).startswith("PRIVATE"):
            # the library's own section names; it renames others by re-setting their values,
            # which interpolates them twice
            line = f"[{header.group(1).strip().lower().replace(' ', '_')}]"
        out.append(line)
    _refuse_repeats(path, out)
    # WIF values are literal; the library's ConfigParser interpolates '%' (a title "50% wool"
    # would fail), so escape it
    return "\n".join(out).replace("%", "%%") + "\n"


def _refuse_repeats(path: str, lines: list[str]) -> None:
    """Refuse a section given twice, or a key given twice in one section: the library keeps
    one silently, so the draft read would not be the draft written."""
    seen: dict[str, set[str]] = {}
    section = None
    for number, line in enumerate(lines, 1):
        header = re.fullmatch(r"\s*\[(.*)\]\s*", line)
        if header:
            section = header.group(1)
            if section in seen:
                raise _refuse(path, section, "appears twice; keep one (the draft would depend on which is read)")
            seen[section] = set()
        elif section is not None and "=" in line and not line.lstrip().startswith(";"):
            key = line.split("=", 1)[0].strip().lower()
            if key in seen[section]:
                raise _refuse(path, section, f"the key {key!r} appears twice ({line.strip()!r}); keep one")
            seen[section].add(key)


def _raw_sections(text: str) -> configparser.ConfigParser | None:
    """The prepared text as the library's ConfigParser sees it, or None if it cannot parse it."""
    raw = configparser.ConfigParser(allow_no_value=True, strict=False)
    try:
        raw.read_string(text)
    except configparser.Error:
        return None
    return raw


def _bad_line(raw: configparser.ConfigParser) -> tuple[str, str, str] | None:
    """The first line the library cannot parse: (section, line, the form it should have)."""
    from dtx_to_wif.wif_reader import section_dispatcher

    for name in raw.sections():
        key = name.lower().replace(" ", "_")
        parse = section_dispatcher.get(key)
        typed = _HEADER_KEYS.get(key, {})
        for option, value in raw.items(name, raw=True):
            try:
                if parse is not None:
                    parse({option: value})
                elif option in typed and value is not None and value.strip():
                    _VALUE_PARSERS[typed[option]](value)
            except (ValueError, TypeError, AttributeError, KeyError, RuntimeError):
                form = _LINE_FORMS.get(key) or f"{option}={typed[option]}"
                return key, f"{option}={value}" if value is not None else option, form
    return None


def _first_line(raw: configparser.ConfigParser | None, section: str, bad) -> str:
    """`` (line KEY=VALUE)`` of the first line of ``section`` whose numbers ``bad`` flags, or ``""``."""
    if raw is None or not raw.has_section(section):
        return ""
    for key, value in raw.items(section, raw=True):
        try:
            numbers = [int(v) for v in (value or "").split(",") if v.strip()]
        except ValueError:
            continue
        if numbers and bad(numbers):
            return f" (line {key}={value})"
    return ""


def _filled(raw: configparser.ConfigParser | None, section: str) -> bool:
    return raw is not None and raw.has_section(section) and any(
        (v or "").strip() not in ("", "0") for _, v in raw.items(section, raw=True))


def _library_error(message: str, raw: configparser.ConfigParser | None) -> tuple[str, str]:
    """The section a ``dtx-to-wif`` error is about, and what to tell the user (with the fix)."""
    low = message.lower()
    if "must specify non-empty liftplan" in low:
        if _filled(raw, "treadling") and not _filled(raw, "tieup"):
            return "tieup", ("missing or empty: [TREADLING] names treadles but no tie-up says which shafts they "
                             "lift; add a [TIEUP] (TREADLE=SHAFT,...), or give a [LIFTPLAN] instead")
        if _filled(raw, "tieup") and not _filled(raw, "treadling"):
            return "treadling", ("missing or empty: there is a [TIEUP] but no treadling says which treadles each "
                                 "pick uses; add a [TREADLING] (PICK=TREADLE,...), or give a [LIFTPLAN] instead")
        return "liftplan", ("the draft has no drawdown: no pick lifts a shaft (no [LIFTPLAN], and no [TIEUP] with "
                            "[TREADLING]); add a [LIFTPLAN] (PICK=SHAFT,...) or a [TIEUP] and a [TREADLING]")
    if "max() arg is an empty" in low:  # the library's first max() is over the threading
        return "threading", "missing or empty: no end is threaded on a shaft; add a [THREADING] (END=SHAFT,...)"
    m = re.search(r"more treadles in treadling than in tieup: (\d+) > (\d+)", message)
    if m:
        line = _first_line(raw, "treadling", lambda t: max(t) > int(m[2]))
        return "treadling", (f"a pick uses treadle {m[1]}{line} but the draft has {m[2]} treadles ([WEAVING] "
                             "Treadles, [TIEUP]); tie that treadle up or use one of treadles 1 to " + m[2])
    m = re.search(r"(warp|weft)_colors=.*(>|<) (\d+)", message)
    if m:
        top = int(m[3])
        line = _first_line(raw, f"{m[1]}_colors", (lambda c: max(c) > top) if m[2] == ">" else (lambda c: min(c) < 1))
        return f"{m[1]}_colors", (f"a colour index{line} is not an entry of [COLOR TABLE]; use indices 1 to "
                                  f"{top if m[2] == '>' else 'the number of colours'}")
    m = re.search(r"(warp|weft)\.color (\S+)", message)
    if m:
        return m[1], (f"Color={m[2]} is not an entry of [COLOR TABLE]; give the index of one, or a colour for "
                      f"every thread in [{m[1].upper()} COLORS]")
    if re.search(r"colou?r table|parse color", low):
        return "color_table", f"{message.rstrip('; ')}; each line is INDEX=R,G,B within [COLOR PALETTE] Range"
    if re.search(r"colou?r range|color palette", low):
        return "color_palette", f"{message.rstrip('; ')}; give Range=MIN,MAX (e.g. Range=0,255)"
    return "", f"{message.rstrip('; ')}; fix the draft (or save it again from the weaving program)"


def _parse(path: str, text: str):
    """The library's :class:`dtx_to_wif.PatternData` of a prepared WIF text; InputError naming
    the section to fix."""
    from dtx_to_wif import read_wif

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            return read_wif(io.StringIO(text), os.path.basename(path))
        except configparser.Error as exc:
            lines = getattr(exc, "errors", None)
            detail = f" (line {lines[0][0]}: {lines[0][1].strip()})" if lines else ""
            raise _refuse(path, getattr(exc, "section", "") or "", f"malformed{detail}: {exc.message.splitlines()[0]}; "
                          "every line is KEY=VALUE under a [SECTION] header") from None
        except NameError as exc:  # the library's own bug on a section it needs and does not find
            raw = _raw_sections(text)
            if "color_range" in str(exc) or (raw is not None and not raw.has_section("color_palette")):
                raise _refuse(path, "color_palette", "missing: the draft has colours but no [COLOR PALETTE] saying "
                              "their range; add [COLOR PALETTE] with Range=0,255 (and Entries=N, Form=RGB)") from None
            raise _refuse(path, "", f"the WIF reader failed on it ({exc}); save the draft again from the "
                          "weaving program") from None
        except (ValueError, TypeError, AttributeError, KeyError, RuntimeError) as exc:
            raw = _raw_sections(text)
            parse_error = isinstance(exc, (ValueError, TypeError, AttributeError))
            bad = _bad_line(raw) if raw is not None and parse_error else None
            if bad is not None:
                section, line, form = bad
                raise _refuse(path, section, f"cannot read the line {line!r}; its lines look like {form}") from None
            # the library's KeyError on an unusable default colour comes after a warning that says why
            message = str(caught[-1].message) if isinstance(exc, KeyError) and caught else str(exc)
            raise _refuse(path, *_library_error(message, raw)) from None


def _check_numbers(path: str, data) -> tuple[int, int]:
    """Thread, shaft and treadle numbers the library lets through but a drawdown cannot use;
    the numbers of ends and picks."""
    for section, numbers, kind in (("threading", data.threading, "shaft"), ("tieup", data.tieup, "shaft"),
                                   ("treadling", data.treadling, "treadle"), ("liftplan", data.liftplan, "shaft")):
        for key, values in numbers.items():
            if key < 1 or min(values) < 0:
                raise _refuse(path, section, f"line {key}={','.join(map(str, sorted(values)))}: numbers start at 1 "
                              f"(a {kind} of 0 means none); negative numbers are not allowed")
    shafts = set().union(*data.threading.values(), *data.tieup.values(), *data.liftplan.values())
    if len(shafts) > MAX_THREADS:  # the drawdown holds a matrix of ends × shafts
        raise _refuse(path, "threading", f"{len(shafts)} different shafts is more than weavecap reads (at most "
                      f"{MAX_THREADS}); give one or a few repeats of the draft")
    ends = max([data.warp.threads, *data.threading])
    lift_keys = data.liftplan if data.liftplan else data.treadling
    picks = max([data.weft.threads, *lift_keys])
    for section, count, what in (("warp", ends, "ends"), ("weft", picks, "picks")):
        if count > MAX_THREADS:
            raise _refuse(path, section, f"{count} {what} is more than weavecap reads (at most {MAX_THREADS}); "
                          "give one or a few repeats of the draft")
    return ends, picks


def _check_declared(path: str, text: str, data) -> None:
    """Numbers that contradict what the draft declares: ``Threads`` of 0 or less, an end or
    pick beyond ``Threads``, a shaft beyond ``[WEAVING] Shafts``, a treadle beyond
    ``Treadles`` (the library lets them through and the drawdown silently changed: a 6 × 4
    draft with Threads=0 read as 6 × 2)."""
    raw = _raw_sections(text)
    declared = {}
    for section, key in (("warp", "threads"), ("weft", "threads"), ("weaving", "shafts"), ("weaving", "treadles")):
        if raw is not None and raw.has_option(section, key) and (raw.get(section, key, raw=True) or "").strip():
            declared[section, key] = int(raw.get(section, key, raw=True))
    for (section, key), value in declared.items():
        if value < 1:
            raise _refuse(path, section, f"{key.capitalize()}={value}: must be 1 or more; give the number of "
                          f"{'threads' if key == 'threads' else key}")
    ends, picks = declared.get(("warp", "threads")), declared.get(("weft", "threads"))
    shafts, treadles = declared.get(("weaving", "shafts")), declared.get(("weaving", "treadles"))
    checks = (("threading", data.threading, ends, "end", "[WARP] Threads", shafts, "shaft", "[WEAVING] Shafts"),
              ("liftplan", data.liftplan, picks, "pick", "[WEFT] Threads", shafts, "shaft", "[WEAVING] Shafts"),
              ("treadling", data.treadling, picks, "pick", "[WEFT] Threads", treadles, "treadle",
               "[WEAVING] Treadles"),
              ("tieup", data.tieup, treadles, "treadle", "[WEAVING] Treadles", shafts, "shaft", "[WEAVING] Shafts"))
    for section, lines, key_top, key_what, key_from, value_top, value_what, value_from in checks:
        for key, values in sorted(lines.items()):
            line = f"line {key}={','.join(map(str, sorted(values)))}"
            if key_top is not None and key > key_top:
                raise _refuse(path, section, f"{line}: {key_what} {key} is beyond {key_from}={key_top}; raise "
                              f"{key_from} or remove the line")
            if value_top is not None and values and max(values) > value_top:
                raise _refuse(path, section, f"{line}: {value_what} {max(values)} is beyond {value_from}="
                              f"{value_top}; raise {value_from} or use {value_what}s 1 to {value_top}")


def _lifts(data, picks: int) -> dict[str, list[set[int]]]:
    """The shafts each pick moves (raised, or sunk in a sinking shed), from the liftplan and
    from tie-up × treadling, whichever the draft has (1-based shafts, 0 dropped)."""
    out = {}
    if data.liftplan:
        out["[LIFTPLAN]"] = [data.liftplan.get(p, set()) - {0} for p in range(1, picks + 1)]
    if data.tieup and data.treadling:
        out["[TIEUP] × [TREADLING]"] = [
            set().union(*(data.tieup.get(t, set()) for t in data.treadling.get(p, set()))) - {0}
            for p in range(1, picks + 1)]
    return out


def _drawdown(threading: list[set[int]], lifts: list[set[int]], rising: bool) -> np.ndarray:
    """``(picks, ends)`` uint8 in weavecap's convention from per-end shafts and per-pick lifts."""
    shafts = sorted(set().union(*threading, *lifts) - {0})
    index = {s: k for k, s in enumerate(shafts)}
    threaded = np.zeros((len(threading), len(shafts)), dtype=bool)
    for e, on in enumerate(threading):
        threaded[e, [index[s] for s in on if s]] = True
    moved = np.zeros((len(lifts), len(shafts)), dtype=bool)
    for p, on in enumerate(lifts):
        moved[p, [index[s] for s in on]] = True
    moves = (moved.astype(np.int32) @ threaded.T.astype(np.int32)) > 0  # end e moves on pick p
    return (~moves if rising else moves).astype(np.uint8)


def _period(x: np.ndarray, axis: int) -> int:
    """The smallest period of a drawdown along ``axis``: the least ``k >= 1`` with
    ``x[k:] == x[:-k]`` (its length when none is shorter).

    The lines along ``axis`` are numbered by content (their bytes hashed), and the
    sequence's smallest period is its length less its longest proper border (Knuth–Morris–Pratt's
    failure function): time linear in the drawdown's cells. Trying every shift cost the cube
    of the thread count (4000 threads: 93 s)."""
    lines = np.ascontiguousarray(np.moveaxis(np.asarray(x), axis, 0).reshape(x.shape[axis], -1))
    numbers: dict[bytes, int] = {}
    ids = [numbers.setdefault(line.tobytes(), len(numbers)) for line in lines]
    n = len(ids)
    border = [0] * n
    for i in range(1, n):
        k = border[i - 1]
        while k and ids[i] != ids[k]:
            k = border[k - 1]
        border[i] = k + (ids[i] == ids[k])
    return n - border[-1] if n else 0


def repeat_of(drawdown: np.ndarray, *, path: str = "", sections: str = "[THREADING] and [LIFTPLAN]") -> np.ndarray:
    """The minimum repeat of a drawdown, as weavecap tiles it.

    Along each side, a drawdown whose smallest period divides its length is whole repeats
    and is reduced to one (as :func:`weavecap.estimate.weave_name.minimal_repeat` reduces a
    pattern cyclically), so that a pattern written as WIF reads back exactly. Along a side
    still over 64 it is taken as a draft cut mid-repeat, and its period (drafted at least
    twice) is used. Time linear in the drawdown's cells (:func:`_period`).

    Raises
    ------
    InputError
        The repeat is larger than 64 × 64 (the message names ``sections``).
    """
    p = np.asarray(drawdown, dtype=np.uint8)
    for axis in (0, 1):
        n, k = p.shape[axis], _period(p, axis)
        if n % k == 0 or (n > MAX_REPEAT and k <= n // 2):
            p = np.take(p, range(k), axis=axis)
    if max(p.shape) > MAX_REPEAT:
        raise InputError(f"{path}: {sections}: the drawdown's repeat is {p.shape[0]} picks × {p.shape[1]} ends; "
                         f"weavecap fabrics repeat over at most {MAX_REPEAT} × {MAX_REPEAT} yarns "
                         "(give a draft of one repeat)")
    return p


def read_wif(path: str | os.PathLike) -> Draft:
    """Read a WIF draft: its drawdown in weavecap's convention and its minimum repeat.

    Parameters
    ----------
    path : str or os.PathLike
        A ``.wif`` file (WIF 1.0 or 1.1; UTF-8 or Latin-1 text).

    Returns
    -------
    Draft

    Raises
    ------
    InputError
        (exit 2) The file cannot be read, is malformed, has no drawdown, has a liftplan and a
        treadling that disagree, or repeats over more than 64 × 64; the message names the
        section to fix, e.g. ``[TIEUP]``.
    """
    name = os.fspath(path)
    text = _wif_text(name)
    data = _parse(name, text)
    ends, picks = _check_numbers(name, data)
    _check_declared(name, text, data)
    threading = [data.threading.get(e, set()) for e in range(1, ends + 1)]
    drawdowns = {how: _drawdown(threading, lifts, data.is_rising_shed) for how, lifts in _lifts(data, picks).items()}
    (lifting, drawdown), *others = drawdowns.items()
    for how, other in others:
        if not np.array_equal(other, drawdown):
            pick = int(np.flatnonzero((other != drawdown).any(axis=1))[0]) + 1
            raise InputError(f"{name}: [LIFTPLAN] and [TIEUP] × [TREADLING] weave different cloth from pick {pick} "
                             "on; keep one of them (or make them agree)")
    pattern = repeat_of(drawdown, path=name, sections=f"[THREADING] and {lifting}")
    return Draft(drawdown=drawdown, pattern=pattern, title=data.name if data.name != "?" else Path(name).name,
                 lifting=lifting, threads=colour_orders(data, ends, picks, path=name))


# ---------------------------------------------------------------------------------------------
# thread colours ([COLOR TABLE], [WARP COLORS], [WEFT COLORS])


def colour_period(indices: list[int]) -> int:
    """The colour repeat of a family's per-thread colour indices as drafted: the smallest
    period that tiles them exactly (the draft is whole colour repeats), else the smallest
    drafted at least twice (a draft cut mid-repeat), else their number."""
    seq = np.asarray(indices)
    n = seq.size
    for k in range(1, n):
        if n % k == 0 and np.array_equal(seq, np.roll(seq, k)):
            return k
    held = _period(seq[None, :], axis=1)
    return held if 2 * held <= n else n


def _linear_colour(rgb, colour_range) -> tuple[float, float, float]:
    """A colour table entry (integers in ``colour_range``, sRGB-encoded) as linear RGB."""
    from .photo import srgb_to_linear

    lo, hi = colour_range if colour_range else (0, 255)
    c = (np.asarray(rgb, dtype=np.float64) - lo) / max(hi - lo, 1)
    return tuple(float(v) for v in srgb_to_linear(np.clip(c, 0.0, 1.0)))


def colour_orders(data, ends: int, picks: int, *, path: str = ""):
    """The thread colours of a parsed draft (:class:`dtx_to_wif.PatternData`), as
    :class:`weavecap.params.Threads`, or None when each family is drafted in one colour.

    Each end's colour is its ``[WARP COLORS]`` entry or the ``[WARP]`` ``Color`` (likewise the
    picks); a family in more than one colour gets a colour order: its colour repeat
    (:func:`colour_period`), a palette of the colour table's entries it uses, in the order of
    their indices, each as body reflection and subsurface colour (a WIF colour is one colour),
    and per thread the entry it wears.

    Raises
    ------
    InputError
        (exit 2) A thread's colour is not in ``[COLOR TABLE]``, or the colour repeat is longer
        than a params file holds (4096 threads).
    """
    from .params import PaletteEntry, ThreadColours, Threads

    orders = {}
    for family, count, section in (("warp", ends, "warp_colors"), ("weft", picks, "weft_colors")):
        explicit = getattr(data, f"{family}_colors") or {}
        default = getattr(data, family).color
        indices = [explicit.get(k, default) for k in range(1, count + 1)]
        if not indices or any(i is None for i in indices) or len(set(indices)) < 2:
            continue
        missing = sorted(set(indices) - set(data.color_table))
        if missing:
            raise _refuse(path, section, f"colour {missing[0]} is not an entry of [COLOR TABLE]; use one of its "
                          "indices")
        period = colour_period(indices)
        if period > MAX_COLOUR_REPEAT:
            raise _refuse(path, section, f"the colour order repeats over {period} threads; weavecap holds colour "
                          f"repeats of at most {MAX_COLOUR_REPEAT} (give a draft of one colour repeat)")
        used = sorted(set(indices[:period]))
        rank = {index: k for k, index in enumerate(used)}
        palette = []
        for index in used:
            rgb = _linear_colour(data.color_table[index], data.color_range)
            palette.append(PaletteEntry(body_reflection=rgb, body_subsurface=rgb))
        orders[family] = ThreadColours(palette=tuple(palette), sequence=tuple(rank[i] for i in indices[:period]))
    return Threads(**orders) if orders else None


# ---------------------------------------------------------------------------------------------
# writing


def _first_seen(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distinct rows of ``rows`` in order of first appearance, and each row's index among them."""
    _, first, inverse = np.unique(rows, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first)  # np.unique sorts lexicographically; renumber by first appearance
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return rows[np.sort(first)], rank[inverse.reshape(-1)]


def _srgb8(rgb) -> tuple[int, int, int]:
    from .photo import linear_to_srgb

    c = np.rint(linear_to_srgb(np.clip(np.asarray(rgb, dtype=np.float64), 0.0, 1.0)) * 255.0)
    return (int(c[0]), int(c[1]), int(c[2]))


def body_colour(colour) -> tuple[float, float, float]:
    """A yarn's body colour as one linear RGB: the colour itself, or a texture's mean."""
    if isinstance(colour, str):
        from .photo import load_photo

        return tuple(float(c) for c in np.clip(load_photo(colour).rgb, 0.0, 1.0).reshape(-1, 3).mean(axis=0))
    return tuple(float(c) for c in colour)


def draft_of(pattern: np.ndarray, *, warp_rgb=(1.0, 1.0, 1.0), weft_rgb=(0.0, 0.0, 0.0),
             pitch_mm: float | None = None, title: str = "weavecap", treadle_limit: int = TREADLE_LIMIT,
             threads=None):
    """The draft of a pattern, as ``dtx-to-wif``'s :class:`~dtx_to_wif.PatternData`.

    Parameters
    ----------
    pattern : numpy.ndarray
        ``(wefts, warps)`` 0/1, 1 = weft over warp (weavecap's convention).
    warp_rgb, weft_rgb : RGB
        Linear RGB in [0, 1] of the warp and the weft; written sRGB-encoded (0–255), as WIF's
        colour table holds them.
    pitch_mm : float, optional
        Yarn spacing (``scale.pitch_mm``), written in centimetres (WIF keeps 3 decimals: 0.01 mm).
    title : str
        ``[TEXT] Title``.
    treadle_limit : int
        Also write threading + tie-up + treadling when the pattern needs at most this many
        shafts and treadles; the liftplan is always written.
    threads : weavecap.params.Threads, optional
        Colour orders: the draft then spans the lcm of the weave's and each colour repeat
        (the pattern tiled), its palettes follow the warp and weft colours in ``[COLOR
        TABLE]`` (each entry's body reflection), and ``[WARP COLORS]`` / ``[WEFT COLORS]``
        give every thread's entry.

    Returns
    -------
    dtx_to_wif.PatternData
        Rising shed. Shafts are the pattern's distinct columns and treadles its distinct rows,
        numbered in order of first appearance (a straight twill threads 1, 2, 3, ...). A pattern
        whose warps never rise (all ones) is written as a sinking shed, since WIF needs a
        liftplan that moves a shaft.
    """
    from dtx_to_wif import PatternData, WarpWeftData

    from . import __version__

    p = np.asarray(pattern, dtype=np.uint8)
    colour_table, colours, (picks, ends) = _thread_colours(threads, p.shape, warp_rgb=warp_rgb, weft_rgb=weft_rgb)
    p = np.tile(p, (picks // p.shape[0], ends // p.shape[1]))
    rising = bool((p == 0).any())
    moves = (1 - p) if rising else p  # (wefts, warps): warp end moves (rises / sinks) on this pick
    columns, shaft_of_end = _first_seen(moves.T)  # (shafts, wefts), (warps,)
    shaft_moves = columns.T  # (wefts, shafts)
    threading = {e + 1: {int(s) + 1} for e, s in enumerate(shaft_of_end)}
    liftplan = {i + 1: {int(s) + 1 for s in np.flatnonzero(row)} for i, row in enumerate(shaft_moves)}
    treadles, treadle_of_pick = _first_seen(shaft_moves)
    used = treadles.any(axis=1)  # a pick that moves nothing needs no treadle
    number = np.cumsum(used)  # treadle numbers 1.. over the treadles that move something
    tieup, treadling = {}, {}
    if len(columns) <= treadle_limit and int(used.sum()) <= treadle_limit:
        tieup = {int(number[t]): {int(s) + 1 for s in np.flatnonzero(row)} for t, row in enumerate(treadles) if used[t]}
        treadling = {i + 1: {int(number[t])} for i, t in enumerate(treadle_of_pick) if used[t]}
    spacing = {} if pitch_mm is None else {"spacing": float(pitch_mm) / 10.0, "units": "centimeters"}
    return PatternData(
        name=title, threading=threading, tieup=tieup, treadling=treadling, liftplan=liftplan,
        color_table=colour_table, color_range=(0, 255), warp_colors=colours["warp"], weft_colors=colours["weft"],
        warp=WarpWeftData(threads=p.shape[1], color=1, **spacing),
        weft=WarpWeftData(threads=p.shape[0], color=2, **spacing),
        is_rising_shed=rising, source_program="weavecap", source_version=__version__,
        num_shafts=len(columns), num_treadles=int(used.sum()) if tieup else len(columns))


def _thread_colours(threads, shape: tuple[int, int], *, warp_rgb, weft_rgb) -> tuple[dict, dict, tuple[int, int]]:
    """The colour table (1: the warp's colour, 2: the weft's, then each colour order's palette),
    per family with a colour order each drafted thread's entry (``{}`` for a family without
    one: its ``Color``), and the (picks, ends) to draft: per family the lcm of the weave's and
    its colour repeat."""
    table = {1: _srgb8(warp_rgb), 2: _srgb8(weft_rgb)}
    colours, counts = {"warp": {}, "weft": {}}, {"warp": shape[1], "weft": shape[0]}
    for family, n in (("warp", shape[1]), ("weft", shape[0])):
        order = threads.family(family) if threads is not None else None
        if order is None:
            continue
        first = len(table) + 1
        for k, entry in enumerate(order.palette):
            table[first + k] = _srgb8(entry.body_reflection)
        count = math.lcm(n, order.repeat)
        if count > MAX_THREADS:
            raise InputError(f"threads.{family}.sequence: a colour repeat of {order.repeat} over a weave repeat of {n} "
                             f"drafts {count} {'ends' if family == 'warp' else 'picks'}, more than a WIF draft here "
                             f"holds ({MAX_THREADS}); export a shorter colour order")
        colours[family] = {t + 1: first + order.sequence[t % order.repeat] for t in range(count)}
        counts[family] = count
    return table, colours, (counts["weft"], counts["warp"])


def wif_text(fabric, *, title: str | None = None) -> str:
    """The WIF 1.1 text of a fabric's pattern, yarn colours and spacing.

    Parameters
    ----------
    fabric : weavecap.params.Fabric
        Its pattern; its warp and weft body reflection colours (R^B, a texture's mean) as the
        WIF warp and weft colours; ``scale.pitch_mm`` as the thread spacing, when known.
    title : str, optional
        ``[TEXT] Title``; the weave's name by default.
    """
    from dtx_to_wif import write_wif

    from .estimate.weave_name import weave_name

    pitch = (fabric.scale or {}).get("pitch_mm")
    data = draft_of(fabric.pattern, warp_rgb=body_colour(fabric.warp.body_reflection),
                    weft_rgb=body_colour(fabric.weft.body_reflection), pitch_mm=pitch,
                    title=title or f"weavecap {weave_name(fabric.pattern)}", threads=fabric.threads)
    out = io.StringIO()
    write_wif(out, data)
    return out.getvalue()


def save_wif(fabric, path: str | os.PathLike, *, force: bool = False, title: str | None = None) -> None:
    """Write :func:`wif_text` to ``path`` atomically; refuse to overwrite without ``force``."""
    from .io import atomic_write_text, refuse_overwrite

    refuse_overwrite(path, force=force)
    atomic_write_text(path, wif_text(fabric, title=title))
