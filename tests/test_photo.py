"""Tests for weavecap.photo: every test image is generated here, inside tmp_path.

The real photos and RAW files under ``../shared/realdata`` are read in place (never copied:
licences), through the ``shared`` fixture.
"""

from __future__ import annotations

import hashlib
import os
import struct
import zlib
from pathlib import Path

import cv2
import numpy as np
import pytest

from weavecap import photo
from weavecap.errors import InputError, PhotoError
from weavecap.photo import linear_to_srgb, load_photo, save_exr, save_image, save_png, srgb_to_linear


# ---------------------------------------------------------------- helpers to make test files


def srgb8(lin):
    """Expected 8-bit code of linear values (float64 reference)."""
    lin = np.asarray(lin, np.float64)
    s = np.where(lin <= 0.0031308, 12.92 * lin, 1.055 * lin ** (1 / 2.4) - 0.055)
    return np.rint(np.clip(s, 0, 1) * 255)


def write_cv(path: Path, img: np.ndarray) -> Path:
    """Write with OpenCV (img in RGB or grey order)."""
    if img.ndim == 3 and img.shape[2] in (3, 4):
        img = img[:, :, [2, 1, 0, 3][: img.shape[2]]]
    assert cv2.imwrite(str(path), img)
    return path


def exif_block(orientation: int) -> bytes:
    """A little-endian EXIF TIFF block with one IFD0 entry: Orientation (tag 274, SHORT)."""
    ifd = struct.pack("<H", 1) + struct.pack("<HHIHH", 274, 3, 1, orientation, 0) + struct.pack("<I", 0)
    return b"II*\x00" + struct.pack("<I", 8) + ifd


def jpeg_with_orientation(path: Path, rgb8: np.ndarray, orientation: int) -> Path:
    ok, buf = cv2.imencode(".jpg", rgb8[:, :, ::-1], [cv2.IMWRITE_JPEG_QUALITY, 98])
    assert ok
    data = buf.tobytes()
    payload = b"Exif\x00\x00" + exif_block(orientation)
    app1 = b"\xff\xe1" + struct.pack(">H", len(payload) + 2) + payload
    path.write_bytes(data[:2] + app1 + data[2:])  # right after SOI
    return path


def png_chunk(ctype: bytes, body: bytes) -> bytes:
    return struct.pack(">I", len(body)) + ctype + body + struct.pack(">I", zlib.crc32(ctype + body) & 0xFFFFFFFF)


def png_with_orientation(path: Path, rgb8: np.ndarray, orientation: int) -> Path:
    ok, buf = cv2.imencode(".png", rgb8[:, :, ::-1])
    assert ok
    data = buf.tobytes()
    ihdr_end = 8 + 8 + 13 + 4
    path.write_bytes(data[:ihdr_end] + png_chunk(b"eXIf", exif_block(orientation)) + data[ihdr_end:])
    return path


def tiff_uncompressed(path: Path, img: np.ndarray, orientation: int = 1) -> Path:
    """A minimal uncompressed little-endian TIFF (one strip), 8/16 bit, grey or RGB."""
    h, w = img.shape[:2]
    spp = 1 if img.ndim == 2 else img.shape[2]
    bps = img.dtype.itemsize * 8
    pixels = np.ascontiguousarray(img).astype(img.dtype.newbyteorder("<")).tobytes()
    extra = b""
    n_entries = 10
    data_start = 8 + 2 + n_entries * 12 + 4
    bps_off = data_start
    if spp > 1:
        extra += struct.pack(f"<{spp}H", *([bps] * spp))
    pix_off = data_start + len(extra)
    entries = [
        (256, 4, 1, struct.pack("<I", w)),
        (257, 4, 1, struct.pack("<I", h)),
        (258, 3, spp, struct.pack("<I", bps_off) if spp > 1 else struct.pack("<HH", bps, 0)),
        (259, 3, 1, struct.pack("<HH", 1, 0)),
        (262, 3, 1, struct.pack("<HH", 2 if spp >= 3 else 1, 0)),
        (273, 4, 1, struct.pack("<I", pix_off)),
        (274, 3, 1, struct.pack("<HH", orientation, 0)),
        (277, 3, 1, struct.pack("<HH", spp, 0)),
        (278, 4, 1, struct.pack("<I", h)),
        (279, 4, 1, struct.pack("<I", len(pixels))),
    ]
    assert len(entries) == n_entries
    ifd = struct.pack("<H", n_entries) + b"".join(struct.pack("<HHI", t, ty, c) + v for t, ty, c, v in entries)
    path.write_bytes(b"II*\x00" + struct.pack("<I", 8) + ifd + struct.pack("<I", 0) + extra + pixels)
    return path


def displayed(stored: np.ndarray, orientation: int) -> np.ndarray:
    """What a viewer shows for a stored pixel grid and an EXIF orientation (by rotations)."""
    return {
        1: lambda a: a,
        2: lambda a: np.fliplr(a),
        3: lambda a: np.rot90(a, 2),
        4: lambda a: np.flipud(a),
        5: lambda a: np.fliplr(np.rot90(a, -1)),  # transpose
        6: lambda a: np.rot90(a, -1),  # 90 degrees clockwise
        7: lambda a: np.flipud(np.rot90(a, -1)),  # transverse
        8: lambda a: np.rot90(a, 1),  # 90 degrees counter-clockwise
    }[orientation](stored)


def block_image() -> np.ndarray:
    """16×32 RGB uint8, four 8×16 blocks of distinct colours: asymmetric under every flip/turn."""
    img = np.zeros((16, 32, 3), np.uint8)
    img[:8, :16] = (255, 0, 0)
    img[:8, 16:] = (0, 255, 0)
    img[8:, :16] = (0, 0, 255)
    img[8:, 16:] = (255, 255, 255)
    return img


def assert_photo_error(path, *, contains: str = "", **kw) -> PhotoError:
    with pytest.raises(PhotoError) as info:
        load_photo(path, **kw)
    msg = str(info.value)
    assert str(path) in msg, msg
    assert contains.lower() in msg.lower(), msg
    assert info.value.exit_code == 3
    return info.value


def check_photo(p, h, w):
    assert p.rgb.shape == (h, w, 3) and p.rgb.dtype == np.float32
    assert (p.height, p.width) == (h, w)
    assert np.isfinite(p.rgb).all() and p.rgb.min() >= 0.0
    assert p.rgb.flags.c_contiguous


# ---------------------------------------------------------------- sRGB curve


def test_srgb_curve_exact_values_and_inverse():
    x = np.array([0.0, 0.04045, 0.5, 1.0], np.float32)
    ref = np.where(x <= 0.04045, x / 12.92, ((x.astype(np.float64) + 0.055) / 1.055) ** 2.4)
    got = srgb_to_linear(x)
    assert got.dtype == np.float32
    np.testing.assert_allclose(got, ref, rtol=1e-6, atol=1e-9)
    assert got[-1] == pytest.approx(1.0, abs=1e-7) and got[2] == pytest.approx(0.214041, abs=1e-6)
    lin = np.linspace(0, 1, 10001, dtype=np.float32)
    np.testing.assert_allclose(srgb_to_linear(linear_to_srgb(lin)), lin, atol=2e-6)
    # continuous at the joins
    assert abs(float(linear_to_srgb(np.float32(0.0031308))) - 0.0031308 * 12.92) < 1e-6
    assert linear_to_srgb(np.zeros((2, 3, 3))).shape == (2, 3, 3)


# ---------------------------------------------------------------- writing and round trips


def test_png_round_trip_8_and_16_bit(tmp_path):
    rng = np.random.default_rng(1)
    lin = rng.random((20, 24, 3), dtype=np.float32)
    for bits in (8, 16):
        f = tmp_path / f"r{bits}.png"
        save_png(f, lin, bits=bits)
        p = load_photo(f)
        check_photo(p, 20, 24)
        assert (p.source_format, p.bit_depth) == ("png", bits)
        # within half a code step in sRGB space
        err = np.abs(linear_to_srgb(p.rgb) - linear_to_srgb(lin)).max()
        assert err <= 0.5 / (2**bits - 1) + 2e-6, (bits, err)
    raw8 = cv2.imread(str(tmp_path / "r8.png"), cv2.IMREAD_UNCHANGED)[:, :, ::-1]
    np.testing.assert_array_equal(raw8, srgb8(lin))  # exact sRGB encoding, RGB order
    assert cv2.imread(str(tmp_path / "r16.png"), cv2.IMREAD_UNCHANGED).dtype == np.uint16


def test_save_png_clips_and_zeroes_nan(tmp_path):
    lin = np.full((8, 8, 3), 0.5, np.float32)
    lin[0, 0] = (np.nan, -1.0, 7.0)
    save_png(tmp_path / "c.png", lin)
    raw = cv2.imread(str(tmp_path / "c.png"), cv2.IMREAD_UNCHANGED)[:, :, ::-1]
    assert tuple(raw[0, 0]) == (0, 0, 255)
    with pytest.raises(ValueError):
        save_png(tmp_path / "bad.png", lin, bits=12)


def test_clipped_counts_the_pixels_at_the_white_per_channel(tmp_path):
    """A quarter of a PNG's pixels saturated in red, one eighth in all three: the shares per
    channel; JPEG's error near the white still counts (254 of 255); an EXR, whose white is not
    known, has none."""
    lin = np.full((8, 8, 3), 0.3, np.float32)
    lin[:2, :, 0] = 1.0
    lin[7, :] = 1.0
    lin[6, :, 2] = srgb_to_linear(np.float32(254 / 255))
    save_png(tmp_path / "c.png", lin)
    p = load_photo(tmp_path / "c.png")
    assert p.clipped == [0.375, 0.125, 0.25]
    save_exr(tmp_path / "c.exr", lin * 4)
    assert load_photo(tmp_path / "c.exr").clipped is None


def test_exr_round_trip_is_exact(tmp_path):
    rng = np.random.default_rng(2)
    lin = (rng.random((9, 13, 3)) * 20).astype(np.float32)  # HDR values survive
    save_exr(tmp_path / "x.exr", lin)
    p = load_photo(tmp_path / "x.exr")
    check_photo(p, 9, 13)
    assert (p.source_format, p.bit_depth) == ("exr", 32)
    np.testing.assert_array_equal(p.rgb, lin)


def test_save_image_dispatch_and_atomic(tmp_path):
    lin = np.random.default_rng(3).random((10, 12, 3)).astype(np.float32)
    for name, fmt, bits in [("a.png", "png", 8), ("b.exr", "exr", 32), ("c.tif", "tiff", 16), ("d.TIFF", "tiff", 16)]:
        save_image(tmp_path / name, lin)
        p = load_photo(tmp_path / name)
        assert (p.source_format, p.bit_depth) == (fmt, bits), name
        assert np.abs(p.rgb - lin).max() < (1e-7 if fmt == "exr" else 0.01)
    with pytest.raises(InputError) as info:
        save_image(tmp_path / "e.jpg", lin)
    assert all(s in str(info.value) for s in (".png", ".exr", ".tif")) and info.value.exit_code == 2
    with pytest.raises(ValueError):
        save_image(tmp_path / "f.png", np.zeros((4, 4, 5)))
    # nothing half-written or temporary is left behind, and no file under a failed name
    assert sorted(os.listdir(tmp_path)) == ["a.png", "b.exr", "c.tif", "d.TIFF"]


def test_save_replaces_existing_file_only_on_success(tmp_path, monkeypatch):
    f = tmp_path / "keep.png"
    f.write_bytes(b"old")

    def boom(*a, **k):
        raise RuntimeError("disk full")

    monkeypatch.setattr(Path, "write_bytes", boom)
    with pytest.raises(RuntimeError):
        save_png(f, np.zeros((8, 8, 3)))
    monkeypatch.undo()
    assert f.read_bytes() == b"old" and os.listdir(tmp_path) == ["keep.png"]


# ---------------------------------------------------------------- every format


@pytest.mark.parametrize(
    "name, dtype, channels, fmt",
    [
        ("rgb.jpg", np.uint8, 3, "jpeg"),
        ("grey.jpg", np.uint8, 1, "jpeg"),
        ("rgb8.png", np.uint8, 3, "png"),
        ("rgb16.png", np.uint16, 3, "png"),
        ("grey8.png", np.uint8, 1, "png"),
        ("grey16.png", np.uint16, 1, "png"),
        ("rgba8.png", np.uint8, 4, "png"),
        ("rgba16.png", np.uint16, 4, "png"),
        ("rgb8.tif", np.uint8, 3, "tiff"),
        ("rgb16.tiff", np.uint16, 3, "tiff"),
        ("grey8.tif", np.uint8, 1, "tiff"),
        ("grey16.tif", np.uint16, 1, "tiff"),
        ("rgba8.tif", np.uint8, 4, "tiff"),
    ],
)
def test_formats_decode_to_linear_rgb(tmp_path, name, dtype, channels, fmt):
    top = np.iinfo(dtype).max
    code = np.array([0.8, 0.4, 0.1]) * top  # sRGB-encoded R, G, B
    h, w = 16, 24
    if channels == 1:
        img = np.full((h, w), code[0], dtype)
        expect = np.full(3, srgb_to_linear(np.float32(0.8)))
    else:
        img = np.empty((h, w, channels), dtype)
        img[..., :3] = np.rint(code).astype(dtype)
        if channels == 4:
            img[..., 3] = top // 3  # alpha is dropped, not multiplied in
        expect = srgb_to_linear(np.rint(code) / top)
    f = write_cv(tmp_path / name, img)
    p = load_photo(f)
    check_photo(p, h, w)
    assert p.source_format == fmt and p.bit_depth == dtype().itemsize * 8
    tol = 0.02 if fmt == "jpeg" else 1e-6
    np.testing.assert_allclose(p.rgb[h // 2, w // 2], expect, atol=tol)
    if channels == 1:
        assert np.array_equal(p.rgb[..., 0], p.rgb[..., 1]) and np.array_equal(p.rgb[..., 0], p.rgb[..., 2])
    assert p.sha256 == hashlib.sha256(f.read_bytes()).hexdigest() and p.path == str(f)


def test_uncompressed_tiff_and_float_tiff(tmp_path):
    img = (np.arange(16 * 20 * 3) % 65536).reshape(16, 20, 3).astype(np.uint16) * 50
    p = load_photo(tiff_uncompressed(tmp_path / "u16.tif", img))
    check_photo(p, 16, 20)
    np.testing.assert_allclose(p.rgb, srgb_to_linear(img / 65535.0), atol=1e-6)
    lin = np.random.default_rng(4).random((10, 10, 3)).astype(np.float32) * 3
    p = load_photo(write_cv(tmp_path / "f.tif", lin))
    assert p.bit_depth == 32 and np.array_equal(p.rgb, lin)  # float TIFF is taken as linear


def test_exr_half_and_grey(tmp_path):
    from weavecap.photo import _mitsuba_core

    mi = _mitsuba_core()
    half = (np.random.default_rng(5).random((12, 10, 4)) * 4).astype(np.float16)
    mi.Bitmap(half, pixel_format=mi.Bitmap.PixelFormat.RGBA).write(str(tmp_path / "h.exr"))
    p = load_photo(tmp_path / "h.exr")
    check_photo(p, 12, 10)
    assert p.bit_depth == 16 and np.array_equal(p.rgb, half[..., :3].astype(np.float32))
    grey = np.random.default_rng(6).random((9, 11, 1)).astype(np.float32)
    mi.Bitmap(grey, pixel_format=mi.Bitmap.PixelFormat.Y).write(str(tmp_path / "g.exr"))
    p = load_photo(tmp_path / "g.exr")
    check_photo(p, 9, 11)
    assert np.array_equal(p.rgb, np.repeat(grey, 3, axis=2))


def test_content_decides_format_not_extension(tmp_path):
    f = write_cv(tmp_path / "really_png.png", np.full((8, 8, 3), 128, np.uint8))
    g = tmp_path / "named.jpg"
    g.write_bytes(f.read_bytes())
    assert load_photo(g).source_format == "png"


# ---------------------------------------------------------------- orientation


@pytest.mark.parametrize("orientation", range(1, 9))
def test_orientation_png_tiff_exact(tmp_path, orientation):
    stored = block_image()
    want = displayed(stored, orientation)
    for f in (
        png_with_orientation(tmp_path / "o.png", stored, orientation),
        tiff_uncompressed(tmp_path / "o.tif", stored, orientation),
    ):
        p = load_photo(f)
        check_photo(p, *want.shape[:2])
        np.testing.assert_array_equal(np.rint(linear_to_srgb(p.rgb) * 255), want, err_msg=str(f))


@pytest.mark.parametrize("orientation", range(1, 9))
def test_orientation_jpeg(tmp_path, orientation):
    stored = block_image()
    want = displayed(stored, orientation).astype(float)
    p = load_photo(jpeg_with_orientation(tmp_path / "o.jpg", stored, orientation))
    check_photo(p, *want.shape[:2])
    got = linear_to_srgb(p.rgb) * 255
    h, w = want.shape[:2]
    for y, x in [(h // 4, w // 4), (h // 4, 3 * w // 4), (3 * h // 4, w // 4), (3 * h // 4, 3 * w // 4)]:
        assert np.abs(got[y, x] - want[y, x]).max() < 24, (orientation, y, x, got[y, x], want[y, x])


# ---------------------------------------------------------------- bad files


def test_missing_directory_empty(tmp_path):
    assert_photo_error(tmp_path / "nope.jpg", contains="no such file")
    assert_photo_error(tmp_path, contains="directory")
    (tmp_path / "empty.png").write_bytes(b"")
    assert_photo_error(tmp_path / "empty.png", contains="empty")


@pytest.mark.parametrize("name", ["notes.jpg", "notes.png", "notes.tif", "notes.exr", "notes.nef", "notes.xyz"])
def test_text_file_renamed(tmp_path, name):
    f = tmp_path / name
    f.write_text("These are my notes about the fabric, not a picture.\n" * 20)
    assert_photo_error(f, contains="is not")


def test_truncated_files(tmp_path, capfd):
    rng = np.random.default_rng(7)
    noisy = rng.integers(0, 256, (64, 64, 3), dtype=np.uint8)  # noise: no two halves alike
    for name in ("t.jpg", "t.png", "t16.png", "t.tif"):
        img = noisy.astype(np.uint16) * 257 if "16" in name else noisy
        full = write_cv(tmp_path / f"full_{name}", img)
        data = full.read_bytes()
        if name.endswith(".tif"):  # the uncompressed writer keeps pixels at the end
            data = tiff_uncompressed(tmp_path / "full_u.tif", noisy).read_bytes()
        cut = tmp_path / name
        cut.write_bytes(data[: len(data) // 2])
        assert_photo_error(cut, contains="truncated")
    lin = rng.random((32, 32, 3)).astype(np.float32)
    save_exr(tmp_path / "full.exr", lin)
    data = (tmp_path / "full.exr").read_bytes()
    (tmp_path / "t.exr").write_bytes(data[: len(data) // 2])
    assert_photo_error(tmp_path / "t.exr")
    (tmp_path / "h.exr").write_bytes(data[:40])  # cut inside the header
    assert_photo_error(tmp_path / "h.exr", contains="truncated")
    out, err = capfd.readouterr()
    assert out == "" and err == "", (out, err)  # no decoder noise, no traceback


def test_corrupt_in_the_middle(tmp_path, capfd):
    """Zeroed bytes inside the compressed data: libjpeg only warns and fills grey; we refuse."""
    noisy = np.random.default_rng(8).integers(0, 256, (64, 64, 3), dtype=np.uint8)
    for name in ("c.jpg", "c.png"):
        data = bytearray(write_cv(tmp_path / f"full_{name}", noisy).read_bytes())
        mid = len(data) // 2
        data[mid : mid + 100] = bytes(100)
        (tmp_path / name).write_bytes(bytes(data))
        assert_photo_error(tmp_path / name, contains="corrupt")
    out, err = capfd.readouterr()
    assert out == "" and err == "", (out, err)


def test_oversized_refused_before_decoding(tmp_path, monkeypatch):
    img = np.full((40, 50, 3), 100, np.uint8)
    files = [write_cv(tmp_path / n, img) for n in ("big.jpg", "big.png", "big.tif")]
    save_exr(tmp_path / "big.exr", img.astype(np.float32))
    files.append(tmp_path / "big.exr")

    def no_decoding(*a, **k):
        raise AssertionError("decoded although the header is over the limit")

    monkeypatch.setattr(photo.cv2, "imdecode", no_decoding)
    monkeypatch.setattr(photo, "_decode_exr", no_decoding)
    for f in files:
        assert_photo_error(f, contains="limit", max_pixels=1999)
    monkeypatch.undo()
    for f in files:
        assert load_photo(f, max_pixels=2000).rgb.shape == (40, 50, 3)


def test_decompression_bomb_png_header(tmp_path):
    """A 2 kB PNG whose header claims 100 000 × 100 000 pixels."""
    ihdr = struct.pack(">IIBBBBB", 100_000, 100_000, 8, 2, 0, 0, 0)
    idat = zlib.compress(b"\x00" * 1000)
    f = tmp_path / "bomb.png"
    f.write_bytes(b"\x89PNG\r\n\x1a\n" + png_chunk(b"IHDR", ihdr) + png_chunk(b"IDAT", idat) + png_chunk(b"IEND", b""))
    assert_photo_error(f, contains="decompression bomb")


def test_tiny_image(tmp_path):
    for name in ("tiny.png", "tiny.jpg", "tiny.tif"):
        assert_photo_error(write_cv(tmp_path / name, np.zeros((4, 4, 3), np.uint8)), contains="4×4")
    save_exr(tmp_path / "tiny.exr", np.zeros((4, 20, 3)))
    assert_photo_error(tmp_path / "tiny.exr", contains="20×4")


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_exr_with_non_finite_values(tmp_path, bad):
    lin = np.ones((10, 10, 3), np.float32)
    lin[3, 4, 1] = bad
    save_exr(tmp_path / "nan.exr", lin)
    assert_photo_error(tmp_path / "nan.exr", contains="non-finite")


def test_float_tiff_with_nan(tmp_path):
    lin = np.ones((10, 10, 3), np.float32)
    lin[0, 0, 0] = np.nan
    assert_photo_error(write_cv(tmp_path / "nan.tif", lin), contains="non-finite")


def test_negative_exr_values_are_clipped(tmp_path):
    lin = np.full((8, 8, 3), 0.25, np.float32)
    lin[0, 0] = -0.5
    save_exr(tmp_path / "neg.exr", lin)
    p = load_photo(tmp_path / "neg.exr")
    assert p.rgb.min() == 0.0 and p.rgb[1, 1, 0] == 0.25


# ---------------------------------------------------------------- real data (read in place)


RAW_GOOD = ["imageio_Blackmagic_PocketCinema4K_12bit.dng", "rawpy_RAW_KODAK_DC50.KDC"]
RAW_BAD = ["exiftool_DNG_stub_no_image_data.dng", "exiftool_Nikon_stub_truncated.nef"]


@pytest.mark.parametrize("name, shape", list(zip(RAW_GOOD, [(2176, 4128), (512, 768)])))
def test_real_raw_files_decode(name, shape, shared):
    f = shared("realdata", "raw", name)
    p = load_photo(f)
    check_photo(p, *shape)
    assert p.source_format == "raw" and p.bit_depth == 16
    assert p.rgb.max() <= 1.0 and 0.01 < float(p.rgb.mean()) < 0.9  # a real scene, not black or white
    assert np.ptp(p.rgb.mean(axis=(0, 1))) < 0.5  # white balance applied: no wild colour cast


@pytest.mark.parametrize("name", RAW_BAD)
def test_real_raw_stubs_rejected(name, capfd, shared):
    f = shared("realdata", "raw", name)
    assert_photo_error(f)
    out, err = capfd.readouterr()
    assert out == "" and err == "", (out, err)


def test_real_photos_all_load(shared):
    root = shared("realdata", "images")
    files = sorted(f for f in root.glob("*/*") if f.is_file())
    assert files
    for f in files:
        p = load_photo(f)
        assert p.rgb.ndim == 3 and p.rgb.shape[2] == 3 and p.rgb.dtype == np.float32, f
        assert np.isfinite(p.rgb).all() and p.rgb.min() >= 0.0, f
        assert min(p.width, p.height) >= 8 and p.rgb.max() > 0.01, f
