"""Choose Dr.Jit's LLVM library and the Mitsuba variant, before either is imported.

Dr.Jit 1.5 compiles its CPU kernels with a shared libLLVM that it looks up once, when it is
imported: a library already loaded in the process, else ``DRJIT_LIBLLVM_PATH``, else
``libLLVM.so``, else the newest ``/usr/lib/<arch>-linux-gnu/libLLVM*.so.*``. Versions before
19 are unusable: 14 is refused and 15/16 abort on ``llvm.minimum`` (``../shared/notes/mitsuba.md``).
So this module finds the newest libLLVM >= 19 — the PyPI wheel ``karellen-llvm-core`` inside
the environment (``<prefix>/lib/libLLVM.so.23.1``) or the system's (Debian ``libllvm19``) —
and sets ``DRJIT_LIBLLVM_PATH`` to it before the first ``import drjit``. Where Dr.Jit was
imported first (a script that imports drjit, then weavecap) or the variable names an older
library, :func:`configure_llvm` refuses with the fix instead of letting a kernel abort the
process (:func:`loaded_llvm` reads which library Dr.Jit loaded).

Every module of weavecap that needs Mitsuba calls :func:`mitsuba` instead of importing it.
"""

from __future__ import annotations

import glob
import os
import platform
import re
import sys
from dataclasses import dataclass
from pathlib import Path

from .errors import BackendError

MIN_LLVM = 19
INSTALL_HINT = (
    "Install a libLLVM of version 19 or newer, by either route:\n"
    "  - inside this Python environment (no root):  python -m pip install karellen-llvm-core\n"
    "  - system-wide on Debian/Ubuntu (as root):    apt-get install libllvm19\n"
    "or point DRJIT_LIBLLVM_PATH at such a library. `weavecap doctor` shows what was found."
)

_VERSION_RE = re.compile(r"libLLVM(?:-(\d+)(?:\.\d+)*)?\.so(?:\.(\d+)(?:\.\d+)*)?$")


@dataclass(frozen=True)
class LLVMCandidate:
    """One libLLVM shared library on disk and the major version read from its name."""

    path: str
    major: int | None


def _major_from_name(name: str) -> int | None:
    """Major version from a file name: ``libLLVM-19.so.1`` → 19, ``libLLVM.so.23.1`` → 23."""
    m = _VERSION_RE.search(name)
    if not m:
        return None
    if m.group(1):
        return int(m.group(1))
    if m.group(2):
        return int(m.group(2))
    return None


def llvm_candidates() -> list[LLVMCandidate]:
    """All libLLVM shared libraries in the environment and the system, newest first."""
    arch = platform.machine()
    patterns = [
        os.path.join(sys.prefix, "lib", "libLLVM*.so*"),
        f"/usr/lib/{arch}-linux-gnu/libLLVM*.so*",
        "/usr/lib/llvm-*/lib/libLLVM*.so*",
        "/usr/lib64/libLLVM*.so*",
        "/usr/local/lib/libLLVM*.so*",
    ]
    seen: dict[str, LLVMCandidate] = {}
    for pattern in patterns:
        for path in sorted(glob.glob(pattern)):
            real = os.path.realpath(path)
            if real in seen or not os.path.isfile(real):
                continue
            major = _major_from_name(os.path.basename(path)) or _major_from_name(os.path.basename(real))
            seen[real] = LLVMCandidate(path=path, major=major)
    return sorted(seen.values(), key=lambda c: (c.major or 0), reverse=True)


def find_llvm() -> LLVMCandidate:
    """The newest libLLVM >= 19, or :class:`BackendError` naming what to install."""
    candidates = llvm_candidates()
    for cand in candidates:
        if cand.major is not None and cand.major >= MIN_LLVM:
            return cand
    found = ", ".join(f"{c.path} ({c.major})" for c in candidates) or "none"
    raise BackendError(f"No libLLVM >= {MIN_LLVM} for Dr.Jit's CPU backend (found: {found}).\n{INSTALL_HINT}")


def loaded_llvm() -> LLVMCandidate | None:
    """The libLLVM already mapped into this process (``/proc/self/maps``), or None."""
    try:
        with open("/proc/self/maps", encoding="utf-8", errors="replace") as fh:
            paths = sorted({line.split()[-1] for line in fh if "/libLLVM" in line})
    except OSError:
        return None
    path = next((p for p in paths if _VERSION_RE.search(os.path.basename(p))), None)
    return None if path is None else LLVMCandidate(path=path, major=_major_from_name(os.path.basename(path)))


def _too_old(what: str, cand: LLVMCandidate) -> BackendError:
    try:
        good = f"DRJIT_LIBLLVM_PATH={find_llvm().path}"
    except BackendError:
        good = "DRJIT_LIBLLVM_PATH=<a libLLVM 19 or newer>"
    return BackendError(f"{what} libLLVM {cand.major} ({cand.path}); Dr.Jit's CPU backend needs {MIN_LLVM} or newer "
                        f"(older ones abort the process on weavecap's kernels). {{fix}} e.g. {good}.\n{INSTALL_HINT}")


def configure_llvm() -> str:
    """Set ``DRJIT_LIBLLVM_PATH`` (unless the user set it) and return the path in force.

    Raises
    ------
    BackendError
        (exit 2) ``DRJIT_LIBLLVM_PATH`` is not a file or names a libLLVM older than 19; or
        Dr.Jit was imported before weavecap and loaded such an old one (it loads its libLLVM
        on import, and a kernel then aborts the whole process): the message says the fix.
    """
    user = os.environ.get("DRJIT_LIBLLVM_PATH")
    if user:
        if not os.path.isfile(user):
            raise BackendError(f"DRJIT_LIBLLVM_PATH={user} is not a file.\n{INSTALL_HINT}")
        given = LLVMCandidate(user, _major_from_name(os.path.basename(user))
                              or _major_from_name(os.path.basename(os.path.realpath(user))))
        if given.major is not None and given.major < MIN_LLVM:
            raise BackendError(str(_too_old("DRJIT_LIBLLVM_PATH names", given)).replace(
                "{fix}", "Point it at a newer one, or unset it and weavecap finds one,"))
        return user
    if "drjit" in sys.modules:  # too late to choose: check what Dr.Jit loaded
        loaded = loaded_llvm()
        if loaded is not None and loaded.major is not None and loaded.major < MIN_LLVM:
            raise BackendError(str(_too_old("Dr.Jit was imported before weavecap and loaded", loaded)).replace(
                "{fix}", "Import weavecap before drjit and mitsuba (it points Dr.Jit at a usable library), or set "
                         "the variable before Python starts,"))
        return loaded.path if loaded is not None else ""
    path = find_llvm().path
    os.environ["DRJIT_LIBLLVM_PATH"] = path
    return path


def prefer_llvm() -> None:
    """:func:`configure_llvm` where it can be done quietly: on ``import weavecap``, before any
    ``import drjit`` (Dr.Jit loads its libLLVM on import). Problems are left for
    :func:`mitsuba` to report, when a render needs the library."""
    if "drjit" not in sys.modules and not os.environ.get("DRJIT_LIBLLVM_PATH"):
        try:
            configure_llvm()
        except BackendError:
            pass


_STATE: dict[str, object] = {}


def mitsuba(variant: str | None = None):
    """Import Mitsuba with a usable variant and return the ``mitsuba`` module.

    The variant is ``$WEAVECAP_VARIANT`` if set, else ``cuda_ad_rgb`` when a CUDA device is
    usable, else ``llvm_ad_rgb``. Raises :class:`BackendError` when neither can run.
    """
    if "mi" in _STATE and variant in (None, _STATE["variant"]):
        return _STATE["mi"]
    llvm_path = configure_llvm()
    import drjit as dr
    import mitsuba as mi

    wanted = variant or os.environ.get("WEAVECAP_VARIANT")
    if wanted is None:
        wanted = "cuda_ad_rgb" if _has_cuda(dr) else "llvm_ad_rgb"
    if wanted.startswith("llvm") and not dr.has_backend(dr.JitBackend.LLVM):
        raise BackendError(f"Dr.Jit could not load libLLVM from {llvm_path or 'the default search'}.\n{INSTALL_HINT}")
    try:
        mi.set_variant(wanted)
    except (ImportError, AttributeError, ValueError) as exc:
        raise BackendError(f"Mitsuba variant {wanted!r} is not available: {exc}") from exc
    _STATE.update(mi=mi, variant=wanted, llvm=llvm_path)
    return mi


def _has_cuda(dr) -> bool:
    try:
        return bool(dr.has_backend(dr.JitBackend.CUDA))
    except Exception:  # noqa: BLE001 - any driver problem means "no GPU"
        return False


def describe() -> dict[str, object]:
    """What the backend found, for ``weavecap doctor``: versions, variant, library, threads, cache."""
    mi = mitsuba()
    import drjit as dr

    cache = os.environ.get("DRJIT_CACHE_DIR", str(Path.home() / ".drjit"))
    cache_files = list(Path(cache).glob("*")) if os.path.isdir(cache) else []
    llvm_version = None
    try:
        llvm_version = ".".join(str(v) for v in dr.detail.llvm_version())
    except Exception:  # noqa: BLE001 - only informative
        pass
    return {
        "python": sys.version.split()[0],
        "mitsuba": mi.__version__,
        "drjit": dr.__version__,
        "variant": _STATE["variant"],
        "libllvm_path": _STATE["llvm"],
        "libllvm_version": llvm_version,
        "threads": dr.thread_count(),
        "kernel_cache": cache,
        "kernel_cache_entries": len(cache_files),
        "kernel_cache_mb": round(sum(f.stat().st_size for f in cache_files if f.is_file()) / 2**20, 1),
    }
