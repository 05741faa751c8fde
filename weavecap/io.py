"""Safe output: where results may go, who may write them, and how they are written.

The promises of ``docs/reliability.md``, each kept here in one place:

- **Nothing escapes ``-o``.** :func:`plain_name` refuses a name a user gives for an output
  (``export --name``) unless it is one plain file name; :func:`folder_name` turns any input's
  stem into a plain, visible folder name (a photo ``...png`` has the stem ``..``);
  :func:`inside` checks that a path made under ``-o`` stays there.
- **An unwritable ``-o`` is found before any work** (:func:`check_writable`).
- **One run at a time on an ``-o`` folder** (:func:`folder_lock`): a second run is refused
  (exit 2) while the first holds the folder.
- **Nothing half-written, nothing lost.** Every file is written under a temporary name and
  renamed into place (:func:`atomic_path`); without ``overwrite`` the rename refuses to replace
  a file that appeared meanwhile. A result set — the files one input's run leaves in its
  folder — is staged whole and installed by :func:`write_result_set`, its record last.
- Work abandoned on Ctrl-C leaves no temporary files behind: each temporary file and staging
  folder is journalled (:func:`journal_to`) to the process that removes them (:class:`Unfinished`).
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import json
import os
import re
import shutil
import socket
import sys
import tempfile
import time
from pathlib import Path
from typing import Callable, Iterable, Iterator

from .errors import InputError

#: the lock file of an ``-o`` folder (:func:`folder_lock`)
LOCK = ".weavecap.lock"
#: prefix of the folder a result set is staged in, inside its own folder (:func:`write_result_set`)
STAGING = ".weavecap-partial-"
#: the longest folder name made from an input's name, in bytes (file systems allow 255, and a
#: number may be appended)
MAX_NAME_BYTES = 200
#: deepest nesting of arrays and objects a JSON file weavecap reads may have (:func:`loads_json`)
MAX_JSON_DEPTH = 64

_JSON_STRING = re.compile(r'"(?:[^"\\]|\\.)*"')  # a JSON string, escapes included

#: the file descriptor the temporary files and staging folders being written are told to
#: (``cli/process.py``'s pipe), or None
_JOURNAL_FD: int | None = None


def journal_to(fd: int | None) -> None:
    """Tell ``fd`` (a pipe's writing end) of every temporary file and staging folder as it
    appears (``+path``) and goes (``-path``), one line each: a command's parent process removes
    what is left when it ends the command on Ctrl-C (:class:`Unfinished`)."""
    global _JOURNAL_FD
    _JOURNAL_FD = fd


def _tell(sign: str, path: Path) -> None:
    if _JOURNAL_FD is not None:
        os.write(_JOURNAL_FD, f"{sign}{os.fsdecode(os.path.abspath(path))}\n".encode("utf-8", "surrogateescape"))


class Unfinished:
    """The temporary files and staging folders a command's process journalled
    (:func:`journal_to`) and had not finished: fed the journal's bytes as they come."""

    def __init__(self):
        self.paths: set[Path] = set()
        self._partial = b""

    def feed(self, data: bytes) -> None:
        lines = (self._partial + data).split(b"\n")
        self._partial = lines.pop()
        for line in lines:
            text = line.decode("utf-8", "surrogateescape")
            (self.paths.add if text[:1] == "+" else self.paths.discard)(Path(text[1:]))

    def read(self, fd: int, timeout: float, *, until_closed: bool = False) -> bool:
        """Feed what the pipe ``fd`` holds within ``timeout`` seconds (``until_closed``: what
        comes, each within it, until the pipe closes); False once the pipe is closed."""
        import select

        while select.select([fd], [], [], timeout)[0]:
            data = os.read(fd, 1 << 16)
            self.feed(data)
            if not data:
                return False
            if not until_closed:
                break
        return True

    def remove(self) -> None:
        """Remove them (finished files are untouched)."""
        for path in self.paths:
            if path.is_dir():
                shutil.rmtree(path, ignore_errors=True)
            else:
                with contextlib.suppress(OSError):
                    path.unlink()


# ---------------------------------------------------------------------------------------------
# where outputs may go


def plain_name(name: str, *, what: str) -> str:
    """``name`` if it is one plain, visible file name, else :class:`InputError` (exit 2).

    A plain name has no folder separator, is not ``.`` or ``..``, does not start with a dot
    (hidden, and weavecap's own working files start with one) and holds no control character.
    ``what`` names the option in the message (``--name``).
    """
    bad = ("is empty" if not name.strip() else
           "names a folder (it holds a / or \\)" if "/" in name or "\\" in name else
           "starts with a dot (a hidden file, or . and .. that leave the output folder)" if name.startswith(".") else
           "holds a control character" if any(ord(c) < 32 for c in name) else None)
    if bad:
        raise InputError(f"{what} {name!r} {bad}; give a plain file name such as 'swatch' (outputs go under -o)")
    return name


def folder_name(stem: str, *, fallback: str, reserved: Iterable[str] = ()) -> str:
    """A plain, visible folder name made from an input's ``stem``: leading dots and folder
    separators dropped (``..`` → ``fallback``), control characters replaced by ``_``, cut to
    :data:`MAX_NAME_BYTES`, and a ``_`` appended to a name in ``reserved`` (the files a batch
    keeps at the top of ``-o``)."""
    name = "".join("_" if ord(c) < 32 or c in "/\\" else c for c in stem).lstrip(".").strip()
    name = name.encode("utf-8")[:MAX_NAME_BYTES].decode("utf-8", "ignore") or fallback
    return name + "_" if name in set(reserved) else name


def inside(folder: str | os.PathLike, path: str | os.PathLike) -> Path:
    """``path`` (absolute, or relative to the working folder) if it lies under ``folder``,
    judged on the names (``..`` resolved, links not followed); else :class:`InputError`."""
    top = os.path.normpath(os.path.abspath(folder))
    p = os.path.normpath(os.path.abspath(path))
    if os.path.commonpath([top, p]) != top:
        raise InputError(f"{path}: would be written outside the output folder {folder}; nothing was written")
    return Path(path)


def _nearest_existing(path: Path) -> Path:
    p = Path(os.path.abspath(path))
    while not p.exists() and p != p.parent:
        p = p.parent
    return p


def check_writable(path: str | os.PathLike, *, folder: bool) -> None:
    """Refuse, before any work, an output that cannot be written (exit 2).

    ``folder``: ``path`` is an output folder (made if missing), else an output file. Probes by
    making and removing a temporary file in the nearest folder that exists, which is what
    writing will need (permissions, read-only file systems and ``/proc`` alike; ``os.access``
    says yes to root everywhere).
    """
    path = Path(path)
    if folder and path.exists() and not path.is_dir():
        raise InputError(f"{path}: exists and is not a folder; give a folder name for -o")
    if not folder and path.is_dir():
        raise InputError(f"{path}: is a folder; give a file name for -o")
    where = _nearest_existing(path if folder else path.parent)
    if not where.is_dir():
        raise InputError(f"{path}: cannot be made: {where} is a file, not a folder; choose another -o")
    try:
        fd, probe = tempfile.mkstemp(prefix=".weavecap-probe-", dir=where)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise InputError(f"{path}: cannot write into {where} ({exc.strerror or exc}); choose another -o or fix "
                         "its permissions (checked before any work; nothing was written)") from None


# ---------------------------------------------------------------------------------------------
# one run at a time


def _holder(fd: int) -> str:
    """What the lock file says about the run that holds it, for the message."""
    try:
        info = json.loads(os.pread(fd, 4096, 0).decode("utf-8") or "{}")
        since = time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(info["since"]))
        return f" (pid {info['pid']} on {info['host']}, since {since}: {info['command']})"
    except (OSError, ValueError, KeyError, TypeError):
        return ""


@contextlib.contextmanager
def folder_lock(folder: str | os.PathLike) -> Iterator[Path]:
    """Hold the output folder ``folder`` (made if missing) for one run; yield it.

    The lock is an exclusive ``flock`` on ``folder/.weavecap.lock``, held until the block ends
    (the file is then removed) or the process dies (the kernel releases it: a ``kill -9``
    leaves the file, unlocked, and the next run takes it). A second run on the same folder is
    refused at once with :class:`InputError` (exit 2) naming the run that holds it; it does
    not wait (a batch can run for hours). Folders this call made are removed again if the run
    left nothing in them.

    Over NFS, ``flock`` becomes a POSIX lock of the server's lock manager: runs on different
    machines exclude each other too where the mount has locking (the default, not ``nolock``).
    """
    folder = Path(folder)
    made = []
    p = Path(os.path.abspath(folder))
    while not p.exists():
        made.append(p)
        p = p.parent
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / LOCK
    while True:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            who = _holder(fd)
            os.close(fd)
            if exc.errno not in (errno.EAGAIN, errno.EACCES, errno.EWOULDBLOCK):
                raise InputError(f"{folder}: cannot lock the output folder ({exc.strerror}); choose another "
                                 "-o") from None
            raise InputError(f"{folder}: another weavecap run is writing into this folder{who}; wait for it to "
                             "finish, or choose another -o (two runs on one folder would mix their results)") from None
        try:
            same = os.fstat(fd).st_ino == os.stat(path).st_ino
        except FileNotFoundError:
            same = False
        if same:
            break
        os.close(fd)  # the holder removed the file as we opened it: lock the new one
    try:
        info = {"pid": os.getpid(), "host": socket.gethostname(), "since": time.time(),
                "command": " ".join(Path(a).name if i == 0 else a for i, a in enumerate(sys.argv))}
        os.ftruncate(fd, 0)
        os.pwrite(fd, json.dumps(info).encode("utf-8"), 0)
        yield folder
    finally:
        # removed while held: a run that opened it meanwhile finds it gone and takes a new one
        with contextlib.suppress(OSError):
            os.unlink(path)
        with contextlib.suppress(OSError):
            for p in made:  # innermost first; only folders this run made and left empty
                p.rmdir()
        os.close(fd)


# ---------------------------------------------------------------------------------------------
# writing


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
def atomic_path(path: str | os.PathLike, *, overwrite: bool = True) -> Iterator[Path]:
    """Yield a temporary path beside ``path`` (same suffix); rename it onto ``path`` on success.

    On any exception the temporary file is removed and ``path`` is left as it was. Without
    ``overwrite`` the file is linked into place, which fails if ``path`` exists by then (a
    run that wrote it meanwhile): :class:`InputError`, and ``path`` keeps the other's file.
    """
    dest = Path(path)
    dest.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{dest.stem}.", suffix=dest.suffix, dir=dest.parent)
    os.close(fd)
    tmp_path = Path(tmp)
    _tell("+", tmp_path)
    try:
        yield tmp_path
        os.chmod(tmp_path, _new_file_mode())  # mkstemp's 0600 would hide results from others
        if overwrite:
            os.replace(tmp_path, dest)
        else:
            try:
                os.link(tmp_path, dest)
            except FileExistsError:
                raise InputError(f"{dest}: appeared while this run worked (another run?); it was kept; pass "
                                 "--force to overwrite it, or choose another output name") from None
    finally:
        _tell("-", tmp_path)
        if tmp_path.exists():
            tmp_path.unlink()


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)


def atomic_write_text(path: str | os.PathLike, text: str) -> None:
    """Write UTF-8 ``text`` to ``path`` atomically."""
    atomic_write_bytes(path, text.encode("utf-8"))


def staged(folder: str | os.PathLike) -> bool:
    """Whether ``folder`` holds a result set whose writing was interrupted (a staging folder
    of :func:`write_result_set`): its files are weavecap's, and running again redoes them."""
    folder = Path(folder)
    return folder.is_dir() and any(p.name.startswith(STAGING) for p in folder.iterdir())


def write_result_set(folder: str | os.PathLike, files: dict[str, Callable[[Path], object]], *,
                     record: tuple[str, str], outputs: Iterable[str]) -> None:
    """Write one run's results into ``folder`` so that it holds one run's complete set, or none.

    Parameters
    ----------
    folder : the input's output folder (made if missing)
    files : file name → a function that writes that file at the path it is given
    record : (name, text) of the file that marks the set finished (``report.json``), written last
    outputs : every file name a result set of this kind may hold: those of an earlier run
        that this set does not write are removed (a rejected photo leaves no old params.json)

    Every file is first written into a staging folder inside ``folder``
    (``.weavecap-partial-*``), the record too. Only then is the old record removed, the old
    outputs this set lacks deleted, the new files renamed into place and the record last, and
    the staging folder removed. Until the old record is removed ``folder`` holds the earlier
    set whole; after the new record is in place, the new set whole; in between (renames on one
    file system: microseconds) no record, and the staging folder marks the set unfinished, so
    that running again redoes it (:func:`staged`). Staging folders of interrupted writes are
    removed first (the caller holds the ``-o`` folder's lock).
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    for old in folder.glob(STAGING + "*"):
        shutil.rmtree(old, ignore_errors=True)
    stage = Path(tempfile.mkdtemp(prefix=STAGING, dir=folder))
    _tell("+", stage)
    try:
        names = [*files, record[0]]
        for name, write in files.items():
            write(stage / name)
        atomic_write_text(stage / record[0], record[1])
        (folder / record[0]).unlink(missing_ok=True)
        for name in set(outputs) - set(names):
            (folder / name).unlink(missing_ok=True)
        for name in names:
            os.replace(stage / name, folder / name)
        stage.rmdir()
    finally:
        _tell("-", stage)
        if stage.exists():
            shutil.rmtree(stage, ignore_errors=True)


# ---------------------------------------------------------------------------------------------
# reading


def not_an_input(path: str | os.PathLike, what: str) -> str:
    """Why ``path`` is no input file at all — missing, or a folder — or ``""``: a usage error
    (exit 2) where a ``what`` (``photo``, ``params``) file is wanted. Anything else that exists
    (a device, a pipe, an unreadable file) is for the reader of that input to judge."""
    path = Path(path)
    if path.is_dir():
        return f"{path}: is a folder, not a {what} file; give the path of a file inside it"
    if not path.exists():
        return f"{path}: no such {what}; check the path"
    return ""


def loads_json(text: str):
    """``json.loads``, with nesting deeper than :data:`MAX_JSON_DEPTH` a ``ValueError`` (the
    standard parser recurses, and a file nested 100 000 deep exhausts Python's stack)."""
    import numpy as np

    brackets = _JSON_STRING.sub("", text).encode("utf-8", "replace")
    b = np.frombuffer(brackets, dtype=np.uint8)
    step = np.isin(b, (ord("["), ord("{"))).astype(np.int32) - np.isin(b, (ord("]"), ord("}")))
    if step.size and int(np.cumsum(step).max()) > MAX_JSON_DEPTH:
        raise ValueError(f"nested more than {MAX_JSON_DEPTH} levels deep")
    return json.loads(text)


def dumps_json(doc, *, indent: int | None = None) -> str:
    """Strict JSON text of ``doc``: a non-finite number (a figure that could not be measured,
    e.g. the structure correlation of a flat render) is written as ``null``, never as the
    ``NaN`` / ``Infinity`` that Python alone reads back. Tuples become lists, NumPy scalars
    and arrays plain numbers and lists."""
    import math

    import numpy as np

    def strict(x):
        if isinstance(x, dict):
            return {k: strict(v) for k, v in x.items()}
        if isinstance(x, (list, tuple)):
            return [strict(v) for v in x]
        if isinstance(x, np.ndarray):
            return strict(x.tolist())
        if isinstance(x, np.generic):
            x = x.item()
        if isinstance(x, float) and not math.isfinite(x):
            return None
        return x

    return json.dumps(strict(doc), indent=indent, allow_nan=False)


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
