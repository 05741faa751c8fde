"""Promise: nothing hangs. Inputs whose cost grows without bound are refused with a clear
message or handled in time linear in their size; steps that take long say so; Ctrl-C (and
SIGTERM) stop any command within 2 s — during a Dr.Jit kernel compile too, which Python's
signal handling alone cannot interrupt — leaving no temporary file behind."""

from __future__ import annotations

import os
import signal
import struct
import time
import warnings
import zlib
from pathlib import Path

import pytest

from weavecap import wif
from weavecap.errors import InputError
from weavecap.render import mesh as wmesh

from .conftest import PLAIN, SWATCH, files_under, params_with, shell, weavecap

HUGE_OBJ = "v -1e30 -1e30 0\nv 1e30 -1e30 0\nv -1e30 1e30 0\nv 1e30 1e30 0\nf 1 2 4\nf 1 4 3\n"


def test_a_mesh_xatlas_loops_on_is_refused_in_seconds(sandbox):
    """Coordinates of ±1e30 without UVs: xatlas looped forever on them (Ctrl-C ignored)."""
    path = sandbox / "in" / "h.obj"
    path.write_text(HUGE_OBJ)
    started = time.perf_counter()
    result = weavecap("render", PLAIN, path, "-o", sandbox / "out.png", "--size", "32x18")
    assert result.exit_code == 2 and "2.83e+30 m across" in result.output and "--units" in result.output
    assert time.perf_counter() - started < 10
    assert files_under(sandbox) == {"in/h.obj"}


def test_xatlas_gets_a_mesh_of_unit_size_whatever_its_place(tmp_path):
    """A 6 km mesh (inside the limits) gets its UVs at once: xatlas sees it centred and scaled."""
    path = tmp_path / "big.obj"
    path.write_text(HUGE_OBJ.replace("1e30", "3e3"))
    mesh = wmesh.load_mesh(path)
    assert mesh.uv_source == "xatlas" and mesh.stretch["after"] == pytest.approx(1.0, abs=1e-6)


def wif_text(threads: int) -> str:
    """A 2-shaft plain weave declaring ``threads`` ends and picks, only 2 of them threaded."""
    return ("[WIF]\nVersion=1.1\nDate=April 20, 1997\nDevelopers=wif@mhsoft.com\nSource Program=test\n"
            "[CONTENTS]\nCOLOR PALETTE=true\nWEAVING=true\nWARP=true\nWEFT=true\nCOLOR TABLE=true\n"
            "THREADING=true\nTIEUP=true\nTREADLING=true\n[COLOR PALETTE]\nEntries=2\nForm=RGB\nRange=0,255\n"
            "[COLOR TABLE]\n1=255,255,255\n2=0,0,0\n[WEAVING]\nShafts=2\nTreadles=2\nRising Shed=true\n"
            f"[WARP]\nThreads={threads}\nColor=1\n[WEFT]\nThreads={threads}\nColor=2\n"
            "[THREADING]\n1=1\n2=2\n[TIEUP]\n1=1\n2=2\n[TREADLING]\n1=1\n2=2\n")


def test_a_wif_declaring_thousands_of_threads_is_read_in_seconds(tmp_path):
    """4000 threads took 93 s (a period search in the cube of the thread count); now linear."""
    path = tmp_path / "big.wif"
    path.write_text(wif_text(4000))
    started = time.perf_counter()
    with pytest.raises(InputError, match="4000 picks × 4000 ends"):
        wif.read_wif(path)
    assert time.perf_counter() - started < 10
    path.write_text(wif_text(wif.MAX_THREADS + 1))
    with pytest.raises(InputError, match=f"at most {wif.MAX_THREADS}"):
        wif.read_wif(path)


def test_a_wif_with_thousands_of_shafts_is_refused(tmp_path):
    """One threading line naming 9000 shafts would make a matrix of ends × shafts."""
    path = tmp_path / "shafts.wif"
    text = wif_text(4).replace("[THREADING]\n1=1", "[THREADING]\n1=1," + ",".join(map(str, range(3, 9002))))
    path.write_text(text.replace("Shafts=2", "Shafts=9001"))
    with pytest.raises(InputError, match="9001 different shafts is more than weavecap reads"):
        wif.read_wif(path)


def test_a_huge_text_pattern_is_refused_unread(tmp_path):
    from weavecap.patterns import MAX_TEXT_BYTES, load_pattern

    path = tmp_path / "pattern.txt"
    path.write_text("0 1\n" * (MAX_TEXT_BYTES // 4 + 1))
    with pytest.raises(InputError, match="too large for a pattern file"):
        load_pattern(path)


def test_a_large_mesh_says_what_it_is_doing(tmp_path, monkeypatch):
    """From LARGE_FACES triangles each step of reading gets a line (a 2-million-triangle mesh
    took minutes without a word)."""
    monkeypatch.setattr(wmesh, "LARGE_FACES", 2)
    lines = []
    wmesh.load_mesh(SWATCH, progress=lines.append)
    steps = [line.split(" (")[0] for line in lines]
    assert steps[0].startswith("cleaning") and steps[-1] == "read" and "solving the fabric coordinates" in steps
    assert all("s so far)" in line for line in lines)


def png_header(width: int, height: int) -> bytes:
    """A PNG whose header declares ``width`` × ``height`` (8-bit RGB) and whose data is a
    few bytes: what a decompression bomb looks like before it is decoded."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(b"\x00" * 64)) + chunk(b"IEND", b""))


def test_a_photo_over_the_pixel_limit_is_refused_from_its_header(sandbox):
    path = sandbox / "in" / "bomb.png"
    path.write_bytes(png_header(30000, 30000))
    started = time.perf_counter()
    result = weavecap("fit", path, "-o", sandbox / "out", "-q")
    assert result.exit_code == 3 and "limit of 100,000,000 pixels" in result.output and "downscale" in result.output
    assert time.perf_counter() - started < 10


def test_a_photo_under_the_limit_gives_no_pillow_warning():
    """98 MP is allowed (limit 100 MP): Pillow's own limit (89.5 MP) must not leak its
    DecompressionBombWarning while the header is read."""
    from weavecap.photo import DEFAULT_MAX_PIXELS, _pillow_header

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        header = _pillow_header(png_header(10000, 9800), "png", DEFAULT_MAX_PIXELS)
    assert (header.width, header.height) == (10000, 9800)
    assert not [w for w in caught if "Decompression" in str(w.category.__name__)]


@pytest.mark.parametrize("signum, status", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_a_signal_stops_a_render_within_2_s_during_a_cold_kernel_compile(sandbox, signum, status):
    """With an empty kernel cache a neural render compiles for seconds in C++, where Python
    runs no signal handler. The command runs in a worker thread; the main thread ends the
    process at once. The signal is sent while kernels are still being compiled (the cache has
    its first kernels, the render has not finished)."""
    cache = sandbox / "kernels"
    cache.mkdir()
    out = sandbox / "out"
    out.mkdir()
    proc = shell("render", PLAIN, SWATCH, "-o", out / "r.png", "--size", "64x36", "--view", "13,37", "--mode", "neural",
                 env={"DRJIT_CACHE_DIR": str(cache)})
    try:
        deadline = time.monotonic() + 120
        while len(os.listdir(cache)) < 3 and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        assert proc.poll() is None, "the render finished before it could be interrupted"
        sent = time.monotonic()
        proc.send_signal(signum)
        code = proc.wait(timeout=30)
        took = time.monotonic() - sent
    finally:
        if proc.poll() is None:
            proc.kill()
    stderr = proc.stderr.read()
    assert code == status and took < 2.0, (code, took, stderr)
    assert "interrupted" in stderr and "Traceback" not in stderr
    assert files_under(out) == set()  # no image, no temporary file
