"""Image files in, bounded: the size a header claims is checked before anything is decoded.

A 370-byte PNG can claim 100000 × 100000 pixels; OpenCV would then either refuse with its own
exception or try to allocate tens of gigabytes. Here the file is read through
:func:`marknav.core.inputfile.read_bytes` (a regular file, at most
:data:`~marknav.core.inputfile.MAX_IMAGE_BYTES`), its width and height are read from the header of
the formats marknav accepts (PNG, JPEG, BMP, TIFF, WebP, PNM), and only an image of at most
:data:`MAX_IMAGE_PIXELS` is handed to ``cv2.imdecode``. Any other format, a header that cannot
be read, or a decoder failure is an :class:`~marknav.core.errors.InputError` naming the file.

A JPEG that does not end with its end-of-image marker (``FF D9``; NUL padding after it is
allowed) was cut short: a file copied in part, a camera frame lost in transit. OpenCV 5 refuses
to decode it (an :class:`InputError` saying so), OpenCV 4 decodes it without a word, making up
the rows after the cut; then one warning through :mod:`logging` names the file or stream (once
per name: a stream of damaged frames is not a warning per frame).

Other damage inside the compressed data is found only by decoding it, and libjpeg reports that
itself (``Corrupt JPEG data: 2 extraneous bytes before marker 0xd9``) with ``fprintf`` on the
process's standard error: OpenCV's log level (``cv2.utils.logging.setLogLevel``,
``OPENCV_LOG_LEVEL``) does not reach it (measured on OpenCV 4.10 and 5.1), and catching it would
mean redirecting file descriptor 2 around the decode, which is process-wide: it would swallow
what other threads (a camera reader, logging) write meanwhile. So that line stays libjpeg's; the
image it comes with decodes.
"""

from __future__ import annotations

import logging
import re
import struct
from pathlib import Path

import cv2
import numpy as np
import numpy.typing as npt

from marknav.core.errors import InputError
from marknav.core.inputfile import MAX_IMAGE_BYTES, read_bytes

__all__ = ["MAX_IMAGE_PIXELS", "check_image_file", "decode_image", "image_size", "read_image"]

log = logging.getLogger(__name__)

Image = npt.NDArray[np.uint8]

#: Largest image accepted: 50 megapixels (8660 × 5774), 150 MB once decoded to BGR.
MAX_IMAGE_PIXELS = 50_000_000

#: The marker that ends every whole JPEG (EOI).
_JPEG_EOI = b"\xff\xd9"
#: Names (files, streams) already warned about a cut-short JPEG: one warning each.
_WARNED_CUT: set[str] = set()

_JPEG_SOF = frozenset(range(0xC0, 0xD0)) - {0xC4, 0xC8, 0xCC}
_PNM = re.compile(rb"P[1-6](?:\s+|#[^\n]*\n)+(\d+)(?:\s+|#[^\n]*\n)+(\d+)")


def _png(data: bytes) -> tuple[int, int] | None:
    if len(data) >= 24 and data[12:16] == b"IHDR":
        w, h = struct.unpack(">II", data[16:24])
        return int(w), int(h)
    return None


def _jpeg(data: bytes) -> tuple[int, int] | None:
    i = 2
    n = len(data)
    while i + 4 <= n:
        if data[i] != 0xFF:
            return None
        marker = data[i + 1]
        if marker == 0xFF:  # fill byte
            i += 1
            continue
        if marker in (0x01, 0xD8) or 0xD0 <= marker <= 0xD7:
            i += 2
            continue
        (length,) = struct.unpack(">H", data[i + 2:i + 4])
        if marker in _JPEG_SOF:
            if i + 9 > n:
                return None
            h, w = struct.unpack(">HH", data[i + 5:i + 9])
            return int(w), int(h)
        if length < 2:
            return None
        i += 2 + length
    return None


def _bmp(data: bytes) -> tuple[int, int] | None:
    if len(data) < 26:
        return None
    (dib,) = struct.unpack("<I", data[14:18])
    if dib == 12:
        w, h = struct.unpack("<hh", data[18:22])
    else:
        w, h = struct.unpack("<ii", data[18:26])
    return abs(int(w)), abs(int(h))


def _tiff(data: bytes) -> tuple[int, int] | None:
    order = "<" if data[:2] == b"II" else ">"
    if len(data) < 8:
        return None
    (ifd,) = struct.unpack(order + "I", data[4:8])
    if ifd + 2 > len(data):
        return None
    (count,) = struct.unpack(order + "H", data[ifd:ifd + 2])
    found: dict[int, int] = {}
    for k in range(min(count, 512)):
        e = ifd + 2 + 12 * k
        if e + 12 > len(data):
            break
        tag, typ = struct.unpack(order + "HH", data[e:e + 4])
        if tag in (256, 257):
            if typ == 3:
                (v,) = struct.unpack(order + "H", data[e + 8:e + 10])
            elif typ == 4:
                (v,) = struct.unpack(order + "I", data[e + 8:e + 12])
            else:
                return None
            found[tag] = int(v)
    if 256 in found and 257 in found:
        return found[256], found[257]
    return None


def _webp(data: bytes) -> tuple[int, int] | None:
    chunk = data[12:16]
    if chunk == b"VP8 " and len(data) >= 30:
        w, h = struct.unpack("<HH", data[26:30])
        return int(w) & 0x3FFF, int(h) & 0x3FFF
    if chunk == b"VP8L" and len(data) >= 25:
        (bits,) = struct.unpack("<I", data[21:25])
        return 1 + (bits & 0x3FFF), 1 + ((bits >> 14) & 0x3FFF)
    if chunk == b"VP8X" and len(data) >= 30:
        w = int.from_bytes(data[24:27], "little") + 1
        h = int.from_bytes(data[27:30], "little") + 1
        return w, h
    return None


def image_size(data: bytes) -> tuple[str, tuple[int, int] | None] | None:
    """``(format, (width, height))`` from the header; ``(format, None)`` if the format is known
    but its header unreadable; ``None`` if the format is not one marknav accepts."""
    if data.startswith(b"\x89PNG\r\n\x1a\n"):
        return "PNG", _png(data)
    if data.startswith(b"\xff\xd8"):
        return "JPEG", _jpeg(data)
    if data.startswith(b"BM"):
        return "BMP", _bmp(data)
    if data[:4] in (b"II*\x00", b"MM\x00*"):
        return "TIFF", _tiff(data)
    if data[:4] == b"RIFF" and data[8:12] == b"WEBP":
        return "WebP", _webp(data)
    m = _PNM.match(data[:512])
    if m is not None:
        return "PNM", (int(m.group(1)), int(m.group(2)))
    return None


def _checked_format(data: bytes, name: str) -> str:
    """The image's format, once its header names a size marknav accepts; else InputError."""
    found = image_size(data)
    if found is None:
        raise InputError("not an image marknav reads (PNG, JPEG, BMP, TIFF, WebP or PNM)",
                         file=name)
    fmt, size = found
    if size is None:
        raise InputError(f"{fmt} header unreadable (truncated or damaged file)", file=name)
    w, h = size
    if w <= 0 or h <= 0:
        raise InputError(f"{fmt} header claims an empty image ({w} × {h})", file=name)
    if w * h > MAX_IMAGE_PIXELS:
        raise InputError(f"{fmt} header claims {w} × {h} pixels, more than the "
                         f"{MAX_IMAGE_PIXELS / 1e6:g} megapixels accepted", file=name)
    return fmt


def check_image_file(path: str | Path) -> None:
    """What :func:`read_image` checks before decoding (a readable regular file, a known format,
    a size in bounds), without decoding: a command given many images checks them all first,
    then decodes one at a time instead of holding every decoded image at once."""
    name = str(path)
    _checked_format(read_bytes(name, limit=MAX_IMAGE_BYTES, what="an image file"), name)


def decode_image(data: bytes, name: str, *, grey: bool = False) -> Image:
    """Decode an encoded image (BGR, or one channel with ``grey``) after checking the size its
    header claims."""
    fmt = _checked_format(data, name)
    cut = fmt == "JPEG" and not data.rstrip(b"\x00").endswith(_JPEG_EOI)
    try:
        image = cv2.imdecode(np.frombuffer(data, dtype=np.uint8),
                             cv2.IMREAD_GRAYSCALE if grey else cv2.IMREAD_COLOR)
    except cv2.error as exc:
        raise InputError(f"cannot decode the {fmt} image: {str(exc).strip()}",
                         file=name) from None
    if image is None:
        why = ("truncated: no end-of-image marker at its end" if cut
               else "damaged or truncated?")
        raise InputError(f"cannot decode the {fmt} image ({why})", file=name)
    if cut:
        level = logging.DEBUG if name in _WARNED_CUT else logging.WARNING
        _WARNED_CUT.add(name)
        log.log(level, "%s: truncated JPEG (no end-of-image marker at its end): the decoder "
                "made up the image after the cut", name)
    return np.asarray(image, dtype=np.uint8)


def read_image(path: str | Path, *, grey: bool = False) -> Image:
    """Read a BGR (or ``grey``) image file, bounded (see the module docstring)."""
    name = str(path)
    return decode_image(read_bytes(name, limit=MAX_IMAGE_BYTES, what="an image file"), name,
                        grey=grey)
