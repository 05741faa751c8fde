"""Known weave patterns from files: the ``--pattern`` of ``fit``, ``synth`` and ``render``.

A pattern is ``(wefts, warps)`` uint8, 1 = weft over warp (``params.schema.json``), at most
64 × 64. It can come from

- a params ``.json`` (its ``pattern``);
- a ``.wif`` weaving draft (:func:`weavecap.wif.read_wif`: the drawdown's minimum repeat);
- a text file of 0/1 rows, one row per weft, values separated by spaces or commas.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .errors import InputError
from .wif import MAX_REPEAT

#: What a pattern file may be, for messages.
KINDS = "a params .json, a .wif weaving draft, or a text file of 0/1 rows"


#: the largest text pattern file read: 64 rows of 64 values fill about 8 KiB
MAX_TEXT_BYTES = 1 << 20


def _text_pattern(path: Path) -> np.ndarray:
    if path.stat().st_size > MAX_TEXT_BYTES:
        raise InputError(f"{path}: {path.stat().st_size} bytes is too large for a pattern file (at most "
                         f"{MAX_TEXT_BYTES}; one repeat of at most {MAX_REPEAT} × {MAX_REPEAT}); give {KINDS}")
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        why = exc.strerror if isinstance(exc, OSError) else "not text"
        raise InputError(f"{path}: cannot read the pattern file ({why}); give {KINDS}") from None
    rows = [line.replace(",", " ").split() for line in text.splitlines() if line.strip()]
    try:
        values = [[int(v) for v in row] for row in rows]
    except ValueError:
        raise InputError(f"{path}: a pattern file holds rows of 0 and 1 separated by spaces") from None
    if len({len(row) for row in values}) > 1:
        raise InputError(f"{path}: rows have {sorted({len(row) for row in values})} values; the pattern must be a "
                         "rectangle of 0 and 1 (1 = weft over warp), one row per weft")
    pattern = np.array(values, dtype=np.int64)
    if pattern.size == 0 or not np.isin(pattern, (0, 1)).all():
        raise InputError(f"{path}: the pattern must be a non-empty rectangle of 0 and 1 "
                         "(1 = weft over warp), one row per weft")
    if max(pattern.shape) > MAX_REPEAT:
        raise InputError(f"{path}: the pattern is {pattern.shape[0]} wefts × {pattern.shape[1]} warps; weavecap "
                         f"fabrics repeat over at most {MAX_REPEAT} × {MAX_REPEAT} yarns (give one repeat)")
    return pattern.astype(np.uint8)


def load_pattern(path: str | os.PathLike) -> np.ndarray:
    """Read a known weave pattern.

    Parameters
    ----------
    path : str or os.PathLike
        A params ``.json``, a ``.wif`` draft, or a text file of 0/1 rows (by extension; any
        other extension is read as text).

    Returns
    -------
    numpy.ndarray
        ``(wefts, warps)`` uint8, 1 = weft over warp.

    Raises
    ------
    InputError
        (exit 2) The file is missing or unreadable, not a valid params file or WIF draft (the
        message names the field or the WIF section), not a rectangle of 0/1, or larger than
        64 × 64.
    """
    p = Path(path)
    suffix = p.suffix.lower()
    if not p.is_file():
        why = "a folder" if p.is_dir() else "not a regular file" if p.exists() else "no such file"
        raise InputError(f"{p}: cannot read the pattern file ({why}); give {KINDS}")
    if suffix == ".json":
        from . import params

        return params.load(p).pattern
    if suffix == ".wif":
        from .wif import read_wif

        return read_wif(p).pattern
    return _text_pattern(p)
