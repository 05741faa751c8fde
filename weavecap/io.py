"""Safe output: everything is written under a temporary name and renamed into place.

DESIGN.md, "Nothing is lost": an interrupted write never leaves a half file under the final
name, and an existing result is never overwritten unless the caller says so (``--force``).
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path
from typing import Iterator

from .errors import InputError


def refuse_overwrite(path: str | os.PathLike, *, force: bool) -> None:
    """Raise :class:`InputError` (exit 2) if ``path`` exists and ``force`` is false."""
    if not force and Path(path).exists():
        raise InputError(f"{path}: already exists; pass --force to overwrite it, or choose another output name")


def _new_file_mode() -> int:
    """The mode ``open()`` would give a new file: 0666 less the process umask."""
    umask = os.umask(0o022)
    os.umask(umask)
    return 0o666 & ~umask


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path beside ``path`` (same suffix); rename it onto ``path`` on success.

    On any exception the temporary file is removed and ``path`` is left as it was.
    """
    dest = Path(path)
    dest.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{dest.stem}.", suffix=dest.suffix, dir=dest.parent)
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        os.chmod(tmp_path, _new_file_mode())  # mkstemp's 0600 would hide results from others
        os.replace(tmp_path, dest)
    finally:
        if tmp_path.exists():
            tmp_path.unlink()


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)


def atomic_write_text(path: str | os.PathLike, text: str) -> None:
    """Write UTF-8 ``text`` to ``path`` atomically."""
    atomic_write_bytes(path, text.encode("utf-8"))


def user_cache_dir(*parts: str) -> Path:
    """The user's cache folder for weavecap (created), with ``parts`` appended.

    ``$WEAVECAP_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/weavecap``, else
    ``~/.cache/weavecap``. Only data that can be recomputed belongs there (it may be deleted
    at any time); write into it with :func:`atomic_path`.
    """
    root = os.environ.get("WEAVECAP_CACHE_DIR")
    if not root:
        xdg = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
        root = str(Path(xdg) / "weavecap")
    folder = Path(root).joinpath(*parts)
    folder.mkdir(parents=True, exist_ok=True)
    return folder
