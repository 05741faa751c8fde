"""Choosing Dr.Jit's libLLVM (weavecap.backend): the newest >= 19, or one clear error."""

from __future__ import annotations

import pytest

from weavecap import backend
from weavecap.errors import BackendError


@pytest.mark.parametrize("name, major", [
    ("libLLVM-19.so.1", 19), ("libLLVM.so.23.1", 23), ("libLLVM-15.so", 15), ("libLLVM.so", None),
    ("libLLVM-14.so.1", 14), ("libfoo.so", None),
])
def test_major_version_is_read_from_the_file_name(name, major):
    assert backend._major_from_name(name) == major


def test_the_newest_usable_library_wins(monkeypatch):
    found = [backend.LLVMCandidate("/usr/lib/libLLVM-15.so.1", 15), backend.LLVMCandidate("/env/libLLVM.so.23.1", 23),
             backend.LLVMCandidate("/usr/lib/libLLVM-19.so.1", 19)]
    monkeypatch.setattr(backend, "llvm_candidates", lambda: sorted(found, key=lambda c: c.major, reverse=True))
    assert backend.find_llvm().path == "/env/libLLVM.so.23.1"


def test_only_old_libraries_give_one_error_naming_what_to_install(monkeypatch):
    monkeypatch.setattr(backend, "llvm_candidates", lambda: [backend.LLVMCandidate("/usr/lib/libLLVM-15.so.1", 15),
                                                             backend.LLVMCandidate("/usr/lib/libLLVM-14.so.1", 14)])
    with pytest.raises(BackendError) as info:
        backend.find_llvm()
    message = str(info.value)
    assert "libLLVM-15.so.1 (15)" in message
    assert "karellen-llvm-core" in message and "libllvm19" in message


def test_a_wrong_user_path_is_reported(monkeypatch, tmp_path):
    monkeypatch.setenv("DRJIT_LIBLLVM_PATH", str(tmp_path / "missing.so"))
    with pytest.raises(BackendError, match="is not a file"):
        backend.configure_llvm()


def test_this_machine_has_a_working_backend():
    """What `make install` set up: a libLLVM >= 19 and an AD variant."""
    mi = backend.mitsuba()
    assert mi.variant() in ("llvm_ad_rgb", "cuda_ad_rgb")
    info = backend.describe()
    assert info["variant"] == mi.variant()
