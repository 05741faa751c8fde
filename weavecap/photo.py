"""Read a photo into linear RGB, and write linear RGB images back out.

Every photo weavecap works on goes through :func:`load_photo`: JPEG, PNG (8/16 bit), TIFF
(8/16 bit, 32-bit float), OpenEXR and camera RAW (through rawpy/LibRaw). The result is a
:class:`Photo` holding an ``H×W×3`` float32 array of **linear** RGB (sRGB primaries), where
1.0 is white for 8/16-bit inputs. Anything wrong with the file — missing, empty, not an image,
truncated, corrupt, too large (decompression bomb), too small, non-finite values — raises
:class:`~weavecap.errors.PhotoError` (exit status 3) with a message that names the file, says
what is wrong and what to do about it.

Headers are read with the libraries made for them before anything is decoded, so an oversized
image is refused without allocating it: Pillow's lazy ``Image.open`` for JPEG and PNG (size,
EXIF orientation, its decompression-bomb guard at ``max_pixels``, a PNG's chunk CRCs), tifffile
for TIFF (size, orientation, where the image data lies). Pixels are decoded by OpenCV for
JPEG/PNG/TIFF — Pillow reduces 16-bit RGB to 8 bits, and tifffile needs the imagecodecs
package for LZW, the usual TIFF compression — by Mitsuba's ``Bitmap`` for OpenEXR (which
OpenCV's wheel lacks; its header is read here, no library reading only an EXR header being at
hand) and by rawpy for RAW. This module applies the EXIF orientation to JPEG and PNG
(OpenCV's TIFF decoder applies the TIFF orientation tag itself) and linearises 8/16-bit sRGB.

Writing (:func:`save_png`, :func:`save_exr`, :func:`save_image`) always goes through
:func:`weavecap.io.atomic_path`, so a half-written file never appears under the final name.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import logging
import os
import struct
import sys
import tempfile
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator

import numpy as np
from PIL import ExifTags, Image

os.environ.setdefault("OPENCV_IO_ENABLE_OPENEXR", "1")  # harmless where the codec is absent
import cv2  # noqa: E402

from .errors import InputError, PhotoError, WeavecapError  # noqa: E402
from .io import atomic_path  # noqa: E402

__all__ = [
    "Photo",
    "load_photo",
    "save_png",
    "save_exr",
    "save_image",
    "srgb_to_linear",
    "linear_to_srgb",
    "DEFAULT_MAX_PIXELS",
    "MIN_SIDE",
    "RAW_EXTENSIONS",
]

DEFAULT_MAX_PIXELS = 100_000_000
MIN_SIDE = 8

RAW_EXTENSIONS = frozenset(
    ".3fr .ari .arw .bay .cap .cr2 .cr3 .crw .dcr .dcs .dng .erf .fff .iiq .k25 .kdc .mef .mos "
    ".mrw .nef .nrw .orf .pef .ptx .r3d .raf .raw .rw2 .rwl .sr2 .srf .srw .x3f".split()
)
_STANDARD_EXTENSIONS = {
    ".jpg": "jpeg", ".jpeg": "jpeg", ".jpe": "jpeg", ".jfif": "jpeg",
    ".png": "png",
    ".tif": "tiff", ".tiff": "tiff",
    ".exr": "exr",
}  # fmt: skip
_FORMAT_NAMES = {"jpeg": "JPEG", "png": "PNG", "tiff": "TIFF", "exr": "OpenEXR"}
_SUPPORTED_HINT = "give a JPEG, PNG, TIFF, OpenEXR or camera RAW (DNG, NEF, CR2, ARW, ...) file"


def _set_threads() -> None:
    """Give OpenCV as many threads as this process may use (its CPU affinity), at most 8."""
    try:
        n = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        n = os.cpu_count() or 1
    cv2.setNumThreads(max(1, min(8, n)))


_set_threads()


# --------------------------------------------------------------------------------------------
# sRGB transfer curve
# --------------------------------------------------------------------------------------------


def srgb_to_linear(x) -> np.ndarray:
    """Decode sRGB-encoded values to linear light with the exact piecewise sRGB curve.

    Parameters
    ----------
    x : array_like
        sRGB-encoded values, any shape, nominally in [0, 1].

    Returns
    -------
    numpy.ndarray
        float32 array of the same shape: ``x / 12.92`` for ``x <= 0.04045``, else
        ``((x + 0.055) / 1.055) ** 2.4``. Values above 1 follow the power branch; values
        below 0 the linear one.
    """
    x = np.asarray(x, dtype=np.float32)
    power = np.power((np.maximum(x, 0.04045) + np.float32(0.055)) / np.float32(1.055), np.float32(2.4))
    return np.where(x <= 0.04045, x / np.float32(12.92), power).astype(np.float32, copy=False)


def linear_to_srgb(x) -> np.ndarray:
    """Encode linear values with the exact piecewise sRGB curve (inverse of :func:`srgb_to_linear`).

    Parameters
    ----------
    x : array_like
        Linear values, any shape, nominally in [0, 1].

    Returns
    -------
    numpy.ndarray
        float32 array of the same shape: ``12.92 x`` for ``x <= 0.0031308``, else
        ``1.055 x ** (1 / 2.4) - 0.055``. No clipping.
    """
    x = np.asarray(x, dtype=np.float32)
    power = np.float32(1.055) * np.power(np.maximum(x, 0.0031308), np.float32(1.0 / 2.4)) - np.float32(0.055)
    return np.where(x <= 0.0031308, x * np.float32(12.92), power).astype(np.float32, copy=False)


def _lut(bits: int) -> np.ndarray:
    """Linear value of every ``bits``-bit sRGB code, computed in float64, stored as float32."""
    codes = np.arange(2**bits, dtype=np.float64) / (2**bits - 1)
    lin = np.where(codes <= 0.04045, codes / 12.92, ((codes + 0.055) / 1.055) ** 2.4)
    return lin.astype(np.float32)


_LUTS: dict[int, np.ndarray] = {}


def _decode_srgb_ints(a: np.ndarray, bits: int) -> np.ndarray:
    if bits not in _LUTS:
        _LUTS[bits] = _lut(bits)
    return _LUTS[bits][a]


# --------------------------------------------------------------------------------------------
# The Photo record
# --------------------------------------------------------------------------------------------


#: a pixel at or above this share of the white (1.0 in an 8/16-bit file or a RAW) was clipped
#: by the camera (JPEG's error near the white included)
CLIPPED_SHARE = 0.98


@dataclass(frozen=True, eq=False)
class Photo:
    """A decoded photo.

    Attributes
    ----------
    rgb : numpy.ndarray
        ``(height, width, 3)`` float32, linear RGB with sRGB primaries, all values finite and
        >= 0. 1.0 is the white of an 8/16-bit file (EXR and float TIFF keep their own scale;
        RAW: 1.0 is sensor saturation after white balance).
    path : str
        The path the photo was read from, as given.
    sha256 : str
        Hex SHA-256 of the file's bytes.
    width, height : int
        Pixels, after EXIF/TIFF orientation was applied (``rgb.shape[:2] == (height, width)``).
    source_format : str
        ``"jpeg"``, ``"png"``, ``"tiff"``, ``"exr"`` or ``"raw"``.
    bit_depth : int
        Bits per sample of the decoded data: 8 or 16 for JPEG/PNG/TIFF, 16 or 32 for EXR
        (half/float) and float TIFF, 16 for RAW (LibRaw's output).
    """

    rgb: np.ndarray = field(repr=False)
    path: str
    sha256: str
    width: int
    height: int
    source_format: str
    bit_depth: int

    @property
    def clipped(self) -> list[float] | None:
        """Per channel (R, G, B), the share of pixels at the camera's white (:data:`CLIPPED_SHARE`
        of it or above): how bright they really were, the photo does not say. None for an EXR or
        float TIFF, whose white is not known."""
        if self.source_format == "exr" or self.bit_depth == 32:
            return None
        return [float(np.mean(self.rgb[..., ch] >= CLIPPED_SHARE)) for ch in range(3)]


# --------------------------------------------------------------------------------------------
# Headers (dimensions before decoding, orientation, truncation): Pillow, tifffile
# --------------------------------------------------------------------------------------------


_REDO = "copy or export the original photo again"


class _Bad(Exception):
    """Internal: the file is malformed; turned into :class:`PhotoError` by :func:`load_photo`.

    ``what`` says what is wrong, ``todo`` what the user can do (default: get the file again).
    """

    def __init__(self, what: str, todo: str | None = None):
        super().__init__(what)
        self.what = what
        self.todo = _REDO if todo is None else todo


@dataclass
class _Header:
    fmt: str
    width: int
    height: int
    orientation: int = 1


_TIFF_MAGIC = (b"II*\x00", b"MM\x00*", b"II+\x00", b"MM\x00+")
_EXR_MAGIC = b"\x76\x2f\x31\x01"


def _other_format(data: bytes) -> str | None:
    """The name of an image format weavecap does not read (GIF, WebP, BMP, ...) that Pillow
    recognises in ``data``, for the message; None if it is none Pillow knows."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            with Image.open(io.BytesIO(data)) as im:
                return im.format
    except Exception:  # noqa: BLE001 - any failure means "not an image Pillow knows"
        return None


def _sniff(data: bytes) -> str | None:
    """The container format: TIFF and OpenEXR by their magic numbers (tifffile and the EXR
    reader take it from there), JPEG and PNG when Pillow identifies them; else None."""
    if data[:4] in _TIFF_MAGIC:
        return "tiff"
    if data[:4] == _EXR_MAGIC:
        return "exr"
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)  # _pillow_header's limit decides
            with Image.open(io.BytesIO(data), formats=("JPEG", "PNG")) as im:
                return {"JPEG": "jpeg", "MPO": "jpeg", "PNG": "png"}.get(im.format)
    except (OSError, SyntaxError, ValueError, Image.DecompressionBombError, Image.DecompressionBombWarning):
        # Pillow knows the format but refuses the header: _pillow_header says why
        return {b"\xff\xd8\xff": "jpeg", b"\x89PN": "png"}.get(data[:3])


@contextlib.contextmanager
def _pixel_limit(max_pixels: int) -> Iterator[None]:
    """Pillow's decompression-bomb guard at ``max_pixels``: ``Image.open`` of a larger image
    raises, from its header, before anything is decoded."""
    old = Image.MAX_IMAGE_PIXELS
    Image.MAX_IMAGE_PIXELS = max_pixels
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", Image.DecompressionBombWarning)
            yield
    finally:
        Image.MAX_IMAGE_PIXELS = old


def _orientation(exif: bytes | None) -> int:
    """EXIF orientation (1..8) of an EXIF block; 1 when absent or unreadable."""
    if not exif:
        return 1
    tags = Image.Exif()
    try:
        tags.load(exif)
        value = int(tags.get(ExifTags.Base.Orientation, 1))
    except Exception:  # noqa: BLE001 - a broken EXIF block does not make the picture unreadable
        return 1
    return value if 1 <= value <= 8 else 1


def _pillow_header(data: bytes, fmt: str, max_pixels: int) -> _Header:
    """Size and EXIF orientation of a JPEG or PNG from Pillow's lazy ``Image.open`` (no pixel
    is decoded); a PNG's chunks are also checked whole (``verify``: CRCs, truncation)."""
    name = _FORMAT_NAMES[fmt]
    try:
        with _pixel_limit(max_pixels), Image.open(io.BytesIO(data), formats=("JPEG", "PNG")) as im:
            width, height = im.size
            orientation = _orientation(im.info.get("exif"))
    except (Image.DecompressionBombError, Image.DecompressionBombWarning) as exc:
        raise _Bad(f"the image is larger than the limit of {max_pixels:,} pixels (a decompression bomb, or simply "
                   f"too large; Pillow: {exc})", "downscale or crop it first") from None
    except (OSError, SyntaxError, ValueError) as exc:
        raise _Bad(f"the {name} header is corrupt or cut short ({exc})") from None
    if fmt == "png":
        try:  # under the same limit: Pillow's own (89.5 MP) would warn on a photo the limit allows
            with _pixel_limit(max_pixels), Image.open(io.BytesIO(data), formats=("PNG",)) as im:
                im.verify()
        except (OSError, SyntaxError, ValueError) as exc:
            what = "the file is truncated" if "truncat" in str(exc).lower() else "the PNG data is corrupt"
            raise _Bad(f"{what} ({exc})") from None
    return _Header(fmt, width, height, orientation)


@contextlib.contextmanager
def _quiet_tifffile() -> Iterator[None]:
    """tifffile logs what it finds wrong in a file; weavecap reports it as a PhotoError instead."""
    log = logging.getLogger("tifffile")
    old = log.level
    log.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        log.setLevel(old)


def _tiff_header(data: bytes, fmt: str, max_pixels: int) -> _Header:
    """Size and orientation of a TIFF's first image from tifffile (no pixel is decoded), and
    whether its image data lies inside the file."""
    import tifffile

    try:
        with _quiet_tifffile(), tifffile.TiffFile(io.BytesIO(data)) as tif:
            if not tif.pages:
                raise _Bad("the file is truncated (its first TIFF image directory lies beyond the end of the file)")
            page = tif.pages.first
            width, height = int(page.imagewidth), int(page.imagelength)
            ends = [int(o) + int(n) for o, n in zip(page.dataoffsets, page.databytecounts)]
            orientation = int(page.tags.valueof(274, 1))
    except (tifffile.TiffFileError, ValueError, IndexError, struct.error) as exc:
        raise _Bad(f"the TIFF structure is corrupt or the file is truncated (tifffile: {exc})") from None
    if ends and max(ends) > len(data):
        raise _Bad("the file is truncated (TIFF image data lies beyond the end of the file)")
    return _Header("tiff", width, height, orientation if 1 <= orientation <= 8 else 1)


def _exr_header(data: bytes, fmt: str, max_pixels: int) -> _Header:
    """Size from an OpenEXR header's ``dataWindow`` (Pillow and tifffile do not read EXR, and
    Mitsuba's Bitmap decodes the whole file): read before decoding, to refuse a huge one."""
    pos = 8
    n = len(data)
    while True:
        end = data.find(b"\x00", pos, n)
        if end < 0:
            raise _Bad("the file is truncated (the OpenEXR header is cut short)")
        name = data[pos:end]
        if not name:
            break
        tend = data.find(b"\x00", end + 1, n)
        if tend < 0 or tend + 5 > n:
            raise _Bad("the file is truncated (the OpenEXR header is cut short)")
        atype = data[end + 1 : tend]
        size = struct.unpack_from("<i", data, tend + 1)[0]
        vpos = tend + 5
        if size < 0 or vpos + size > n:
            raise _Bad("the file is truncated (an OpenEXR header attribute is cut short)")
        if name == b"dataWindow" and atype == b"box2i" and size == 16:
            xmin, ymin, xmax, ymax = struct.unpack_from("<iiii", data, vpos)
            return _Header("exr", xmax - xmin + 1, ymax - ymin + 1)
        pos = vpos + size
    raise _Bad("the OpenEXR header has no dataWindow")


_HEADER_READERS = {"png": _pillow_header, "jpeg": _pillow_header, "tiff": _tiff_header, "exr": _exr_header}


# --------------------------------------------------------------------------------------------
# Decoders
# --------------------------------------------------------------------------------------------


def _apply_orientation(a: np.ndarray, orientation: int) -> np.ndarray:
    """Turn the stored pixel grid into the displayed one for EXIF/TIFF ``orientation`` 1..8."""
    if orientation == 2:
        return a[:, ::-1]
    if orientation == 3:
        return a[::-1, ::-1]
    if orientation == 4:
        return a[::-1]
    t = np.swapaxes(a, 0, 1)
    if orientation == 5:
        return t
    if orientation == 6:  # rotate 90 degrees clockwise
        return t[:, ::-1]
    if orientation == 7:
        return t[::-1, ::-1]
    if orientation == 8:  # rotate 90 degrees counter-clockwise
        return t[::-1]
    return a


@contextlib.contextmanager
def _quiet_opencv() -> Iterator[None]:
    """Silence OpenCV's own log lines while decoding; failures are reported as PhotoError."""
    try:
        logging = cv2.utils.logging
        old = logging.getLogLevel()
        logging.setLogLevel(logging.LOG_LEVEL_SILENT)
    except AttributeError:
        yield
        return
    try:
        yield
    finally:
        logging.setLogLevel(old)


@contextlib.contextmanager
def _captured_stderr(sink: list[str]) -> Iterator[None]:
    """Redirect file descriptor 2 (C libraries print there) into ``sink`` for the block."""
    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, ValueError, AttributeError):
        yield
        return
    with tempfile.TemporaryFile() as tmp:
        os.dup2(tmp.fileno(), 2)
        try:
            yield
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            tmp.seek(0)
            text = tmp.read().decode("utf-8", "replace").strip()
            if text:
                sink.append(text)


def _to_rgb3(a: np.ndarray) -> np.ndarray:
    """OpenCV's BGR/BGRA/grey/grey+alpha array → RGB with 3 channels (alpha dropped)."""
    if a.ndim == 2:
        return np.repeat(a[:, :, None], 3, axis=2)
    c = a.shape[2]
    if c in (1, 2):
        return np.repeat(a[:, :, :1], 3, axis=2)
    if c in (3, 4):
        return a[:, :, 2::-1]
    raise _Bad(f"the image has {c} channels; only grey, RGB and RGBA are supported")


def _decode_opencv(data: bytes, header: _Header) -> tuple[np.ndarray, int]:
    name = _FORMAT_NAMES[header.fmt]
    said: list[str] = []  # what libjpeg/libpng/libtiff printed
    with _quiet_opencv(), _captured_stderr(said):
        try:
            a = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), cv2.IMREAD_UNCHANGED)
        except cv2.error as exc:
            a = None
            said.append(str(exc).strip())
    detail = f" ({said[-1].splitlines()[-1].strip()})" if said else ""
    if a is None or a.size == 0:
        raise _Bad(f"the {name} data is corrupt or uses a variant that cannot be decoded{detail}")
    if header.fmt == "jpeg" and any("Premature end" in m for m in said):
        raise _Bad(f"the file is truncated{detail}")
    if header.fmt == "jpeg" and any("Corrupt JPEG" in m for m in said):
        # libjpeg only warns and fills the damaged part with grey: refuse instead
        raise _Bad(f"the JPEG data is corrupt{detail}")
    if header.fmt in ("jpeg", "png"):  # IMREAD_UNCHANGED ignores EXIF orientation: apply it here
        a = _apply_orientation(a, header.orientation)
    elif header.fmt == "tiff" and header.orientation >= 5 and header.width != header.height:
        # OpenCV's TIFF decoder applies the orientation tag itself; in case a version does not:
        if a.shape[:2] == (header.height, header.width):
            a = _apply_orientation(a, header.orientation)
    rgb = _to_rgb3(a)
    if rgb.dtype == np.uint8:
        return _decode_srgb_ints(rgb, 8), 8
    if rgb.dtype == np.uint16:
        return _decode_srgb_ints(rgb, 16), 16
    if rgb.dtype in (np.float32, np.float64, np.float16):
        return rgb.astype(np.float32), 8 * rgb.dtype.itemsize  # float TIFF: already linear
    raise _Bad(f"the {name} has samples of type {rgb.dtype}, which is not supported (use 8/16-bit or float)")


def _mitsuba_core():
    """Mitsuba's core module, for its OpenEXR codec (no variant needed).

    Dr.Jit fixes its libLLVM when first imported, so the backend's choice is made first.
    """
    if "mitsuba" not in sys.modules:
        from .backend import configure_llvm

        try:
            configure_llvm()
        except WeavecapError:
            pass  # reading/writing EXR needs no LLVM; the renderer will report it later
    import mitsuba

    return mitsuba


def _decode_exr(path: str) -> tuple[np.ndarray, int]:
    mi = _mitsuba_core()
    try:
        bmp = mi.Bitmap(path)
        pf = bmp.pixel_format()
        PF = mi.Bitmap.PixelFormat
        if pf in (PF.Y, PF.YA, PF.RGB, PF.RGBA):
            a = np.asarray(bmp)
        else:
            a = np.asarray(bmp.convert(PF.RGB, mi.Struct.Type.Float32, srgb_gamma=False))
    except (RuntimeError, ValueError, TypeError) as exc:
        raise _Bad(f"the OpenEXR data is truncated or corrupt ({exc})") from None
    bits = 8 * a.dtype.itemsize
    if a.ndim == 2:
        a = a[:, :, None]
    rgb = np.repeat(a[:, :, :1], 3, axis=2) if a.shape[2] in (1, 2) else a[:, :, :3]
    rgb = rgb.astype(np.float32)
    if not np.isfinite(rgb).all():
        bad = int((~np.isfinite(rgb)).any(axis=2).sum())
        raise _Bad(f"the file contains non-finite values (NaN or Inf) in {bad} pixel(s)",
                   "fix or re-render the EXR; weavecap will not guess values for them")  # fmt: skip
    return rgb, bits


def _decode_raw(path: str, data_len: int, max_pixels: int) -> np.ndarray:
    import rawpy

    messages: list[str] = []

    def detail() -> str:
        return f" (LibRaw: {messages[-1].splitlines()[-1]})" if messages else ""

    try:
        with _captured_stderr(messages), rawpy.imread(path) as raw:
            s = raw.sizes
            _check_size(s.width, s.height, max_pixels)
            raw_pixels = s.raw_width * s.raw_height
            if data_len * 32 < raw_pixels:
                raise _Bad(f"the file is far too small ({data_len} bytes) to hold the {s.raw_width}×{s.raw_height} "
                           "sensor image it declares (a metadata-only or cut-short RAW)")  # fmt: skip
            visible = raw.raw_image_visible
            if visible.size == 0 or int(visible.max()) == 0:
                raise _Bad("the RAW file contains no image data (every sensor value is 0)")
            out = raw.postprocess(output_bps=16, gamma=(1, 1), no_auto_bright=True, use_camera_wb=True,
                                  output_color=rawpy.ColorSpace.sRGB)  # fmt: skip
    except rawpy.LibRawFileUnsupportedError:
        raise _Unsupported() from None
    except rawpy.LibRawError as exc:
        raise _Bad(f"the RAW data is corrupt or truncated: {exc}{detail()}") from None
    if out.ndim != 3 or out.shape[2] != 3:
        raise _Bad(f"LibRaw returned an image of shape {out.shape}, not H×W×3")
    return out.astype(np.float32) / np.float32(65535.0)


class _Unsupported(Exception):
    """Internal: LibRaw does not recognise the file."""


def _check_size(width: int, height: int, max_pixels: int) -> None:
    if width * height > max_pixels:
        raise _Bad(f"the image is {width}×{height} = {width * height:,} pixels, more than the limit of "
                   f"{max_pixels:,} (a decompression bomb, or simply too large)", "downscale or crop it first")  # fmt: skip
    if width < MIN_SIDE or height < MIN_SIDE:
        raise _Bad(f"the image is only {width}×{height} pixels",
                   f"at least {MIN_SIDE}×{MIN_SIDE} are needed: use a close-up photo showing several yarns")  # fmt: skip


# --------------------------------------------------------------------------------------------
# load_photo
# --------------------------------------------------------------------------------------------


def file_sha256(path: str | os.PathLike) -> str:
    """SHA-256 (hex) of a file's bytes: the identity of a photo in reports and resumed batches.

    Raises
    ------
    OSError
        Not a regular file (a device such as /dev/zero would be read forever), or unreadable.
    """
    p = Path(path)
    if not p.is_file():
        raise OSError(f"{p}: not a regular file")
    digest = hashlib.sha256()
    with p.open("rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def load_photo(path: str | os.PathLike, *, max_pixels: int = DEFAULT_MAX_PIXELS) -> Photo:
    """Read a photo into linear float32 RGB.

    Parameters
    ----------
    path : str or os.PathLike
        JPEG, PNG (8/16 bit, grey, RGB, RGBA, palette), TIFF (8/16 bit or float), OpenEXR, or
        a camera RAW file LibRaw reads (DNG, NEF, CR2, ARW, KDC, ...). The format is taken from
        the file's content; RAW is tried for any extension that is not a standard image one.
    max_pixels : int, optional
        Largest ``width * height`` accepted, checked from the header before decoding.

    Returns
    -------
    Photo
        ``rgb`` is ``(H, W, 3)`` float32 linear RGB (sRGB primaries), finite and >= 0.
        8/16-bit data are decoded with the exact sRGB curve; greyscale is replicated to three
        channels; alpha is dropped; EXIF orientation (JPEG, PNG) and the TIFF orientation tag
        are applied.

    Raises
    ------
    PhotoError
        The file is missing, a directory, empty, not an image, truncated or corrupt, larger
        than ``max_pixels``, smaller than 8×8 pixels, or (EXR/float TIFF) holds NaN/Inf.
    """
    name = os.fspath(path)
    p = Path(name)

    def fail(what: str, todo: str = "") -> PhotoError:
        return PhotoError(f"{name}: {what}" + (f"; {todo}" if todo else ""))

    if not p.exists():
        raise fail("no such file", "check the path and spelling")
    if p.is_dir():
        raise fail("is a directory, not a photo", "give the path of an image file inside it")
    if not p.is_file():  # reading /dev/zero would never end
        raise fail("is not a regular file (a device or a pipe)", "give the path of an image file")
    try:
        data = p.read_bytes()
    except OSError as exc:
        raise fail(f"cannot be read ({exc.strerror or exc})", "check its permissions") from None
    if not data:
        raise fail("the file is empty (0 bytes)", _REDO)

    digest = hashlib.sha256(data).hexdigest()
    ext = p.suffix.lower()
    kind = _sniff(data)

    try:
        rgb = None
        bits = 0
        fmt = kind
        other = _other_format(data) if kind is None else None
        if other is not None and other not in ("TIFF", "JPEG", "PNG", "MPO"):
            raise _Bad(f"is a {other} image, which weavecap does not read",
                       "convert it to PNG, TIFF or JPEG (a 16-bit PNG or TIFF keeps the most), or give the camera's "
                       "original")
        try_raw = ext in RAW_EXTENSIONS or (ext not in _STANDARD_EXTENSIONS and kind in (None, "tiff"))
        if try_raw:
            try:
                rgb = _decode_raw(name, len(data), max_pixels)
                bits, fmt = 16, "raw"
            except _Unsupported:
                if kind is None or ext in RAW_EXTENSIONS:
                    what = "is not a camera RAW file LibRaw can read" if ext in RAW_EXTENSIONS else "is not an image"
                    raise _Bad(f"{what} (format not recognised)", _SUPPORTED_HINT) from None
        if rgb is None:
            if kind is None:
                head = data[:8].hex(" ")
                expected = _FORMAT_NAMES.get(_STANDARD_EXTENSIONS.get(ext, ""))
                what = f"is not a valid {expected} file" if expected else "is not an image file"
                raise _Bad(f"{what} (it starts with bytes {head}, which match no supported format)", _SUPPORTED_HINT)
            header = _HEADER_READERS[kind](data, kind, max_pixels)
            _check_size(header.width, header.height, max_pixels)
            if kind == "exr":
                rgb, bits = _decode_exr(name)
            else:
                rgb, bits = _decode_opencv(data, header)
    except _Bad as exc:
        raise fail(exc.what, exc.todo) from None
    except MemoryError:
        raise fail("is too large to decode in the memory available", "downscale it first") from None

    h, w = rgb.shape[:2]
    try:
        _check_size(w, h, max_pixels)
    except _Bad as exc:
        raise fail(exc.what, exc.todo) from None
    if not np.isfinite(rgb).all():
        raise fail("the file contains non-finite values (NaN or Inf)", "fix the file; weavecap will not guess values")
    rgb = np.ascontiguousarray(np.maximum(rgb, 0.0, dtype=np.float32))
    return Photo(rgb=rgb, path=name, sha256=digest, width=int(w), height=int(h), source_format=fmt, bit_depth=bits)


# --------------------------------------------------------------------------------------------
# Writing
# --------------------------------------------------------------------------------------------


def _as_rgb(rgb_linear) -> np.ndarray:
    a = np.asarray(rgb_linear, dtype=np.float32)
    if a.ndim == 2:
        a = a[:, :, None]
    if a.ndim != 3 or a.shape[2] not in (1, 3) or a.shape[0] == 0 or a.shape[1] == 0:
        raise ValueError(f"expected an H×W×3 (or H×W) image array, got shape {a.shape}")
    if a.shape[2] == 1:
        a = np.repeat(a, 3, axis=2)
    return a


def _encode_srgb(rgb_linear, bits: int) -> np.ndarray:
    """Linear float → clipped, sRGB-encoded uint8/uint16 in OpenCV's BGR order."""
    a = _as_rgb(rgb_linear)
    a = np.clip(np.nan_to_num(a, nan=0.0, posinf=1.0, neginf=0.0), 0.0, 1.0)
    top = 2**bits - 1
    q = np.rint(linear_to_srgb(a) * np.float32(top))
    q = q.astype(np.uint8 if bits == 8 else np.uint16)
    return np.ascontiguousarray(q[:, :, ::-1])


def _write_encoded(path, ext: str, image: np.ndarray, overwrite: bool = True) -> None:
    ok, buf = cv2.imencode(ext, image)
    if not ok:
        raise WeavecapError(f"{os.fspath(path)}: OpenCV could not encode a {ext} image of shape {image.shape}")
    with atomic_path(path, overwrite=overwrite) as tmp:
        tmp.write_bytes(buf.tobytes())


def save_png(path: str | os.PathLike, rgb_linear, *, bits: int = 8, overwrite: bool = True) -> None:
    """Write linear RGB as an sRGB-encoded PNG, atomically.

    Parameters
    ----------
    path : str or os.PathLike
        Destination; written under a temporary name and renamed into place.
    rgb_linear : array_like
        ``(H, W, 3)`` (or ``(H, W)`` grey) linear values; clipped to [0, 1], NaN → 0, +Inf → 1.
    bits : {8, 16}
        Bits per channel.
    overwrite : bool
        False: refuse (:class:`InputError`) a ``path`` that exists when the file is renamed
        into place (:func:`weavecap.io.atomic_path`).
    """
    if bits not in (8, 16):
        raise ValueError(f"bits must be 8 or 16, not {bits!r}")
    _write_encoded(path, ".png", _encode_srgb(rgb_linear, bits), overwrite)


def save_tiff(path: str | os.PathLike, rgb_linear, *, overwrite: bool = True) -> None:
    """Write linear RGB as an sRGB-encoded 16-bit TIFF, atomically (same clipping and
    ``overwrite`` as :func:`save_png`)."""
    _write_encoded(path, ".tiff", _encode_srgb(rgb_linear, 16), overwrite)


def save_exr(path: str | os.PathLike, rgb_linear, *, overwrite: bool = True) -> None:
    """Write linear RGB as a float32 OpenEXR file, atomically, values unchanged.

    Parameters
    ----------
    path : str or os.PathLike
        Destination; written under a temporary name and renamed into place.
    rgb_linear : array_like
        ``(H, W, 3)`` (or ``(H, W)`` grey) linear values, stored as 32-bit float RGB.
    overwrite : bool
        As :func:`save_png`'s.
    """
    a = np.ascontiguousarray(_as_rgb(rgb_linear))
    mi = _mitsuba_core()
    bmp = mi.Bitmap(a, pixel_format=mi.Bitmap.PixelFormat.RGB)
    with atomic_path(path, overwrite=overwrite) as tmp:
        bmp.write(str(tmp), mi.Bitmap.FileFormat.OpenEXR)


_SAVERS = {".png": save_png, ".exr": save_exr, ".tif": save_tiff, ".tiff": save_tiff}


def supported_output(path: str | os.PathLike):
    """The writer for ``path``'s extension, so a command can check its output name before work.

    Raises
    ------
    InputError
        The extension is none of .png, .exr, .tif, .tiff (case ignored).
    """
    ext = Path(os.fspath(path)).suffix.lower()
    saver = _SAVERS.get(ext)
    if saver is None:
        raise InputError(f"{os.fspath(path)}: cannot write images with extension {ext or '(none)'!r}; "
                         "use one of .png (8-bit sRGB), .exr (linear float) or .tif/.tiff (16-bit sRGB)")  # fmt: skip
    return saver


def save_image(path: str | os.PathLike, rgb_linear, *, overwrite: bool = True) -> None:
    """Write linear RGB in the format the extension names, atomically.

    ``.png`` → 8-bit sRGB PNG, ``.exr`` → float32 linear EXR, ``.tif``/``.tiff`` → 16-bit sRGB
    TIFF (extension case ignored). An unknown extension raises :class:`InputError`; without
    ``overwrite``, a ``path`` that exists by the time it is written too (a command without
    ``--force`` checked it before its work, another run may have written it since).
    """
    supported_output(path)(path, rgb_linear, overwrite=overwrite)
