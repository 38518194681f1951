"""An image's size from its header, before it is decoded, and the bound on a frame's size.

A 689-byte JPEG may claim 20000 × 20000 px: decoded, that is 1.2 GB of BGR (2.5 GB in
``record``, 6.8 GB in ``extract``), and 65000 × 65000 fails inside OpenCV. Every frame
that liquidtouch decodes (an image folder's files, a bag's compressed images, an MJPEG
camera's parts, a video stream) is therefore checked against :data:`MAX_FRAME_PIXELS`
(or a camera profile's own bound) from the size its header declares, before decoding:
:func:`declared_size` reads it from a PNG ``IHDR``, a JPEG ``SOFn`` segment, a BMP
``BITMAPINFOHEADER`` or a TIFF's first image directory.
"""

from __future__ import annotations

import io
import os
from typing import BinaryIO

from liquidtouch.errors import LiquidTouchError

__all__ = [
    "MAX_FRAME_PIXELS",
    "MAX_FRAME_SIDE_PX",
    "check_frame_size",
    "check_image_bytes",
    "check_image_file",
    "declared_size",
]

#: largest frame [pixels] decoded: twice the largest sensor camera mode liquidtouch knows,
#: the GelSight Mini's 3280 × 2464 (8.1 MP; ``acquire.cameras.PROFILES``); 16 MB grey,
#: 48 MB BGR
MAX_FRAME_PIXELS = 2 * 3280 * 2464
#: longest side of a frame [px] (a 1-pixel-high strip 16 million wide is no sensor image)
MAX_FRAME_SIDE_PX = 8192
#: bytes of a JPEG searched for its frame header (APPn segments, e.g. EXIF with a
#: thumbnail, come first and hold at most 64 KB each)
_JPEG_SEARCH_BYTES = 1 << 20
_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
#: JPEG start-of-frame markers (baseline, progressive, lossless, arithmetic), not DHT/JPG/DAC
_SOF = frozenset(range(0xC0, 0xD0)) - {0xC4, 0xC8, 0xCC}
#: JPEG markers without a length: TEM, RSTn, SOI
_STANDALONE = frozenset({0x01, *range(0xD0, 0xD9)})


def declared_size(source: BinaryIO) -> tuple[int, int] | None:
    """``(width, height)`` [px] an image file declares (PNG, JPEG, BMP or TIFF), read from
    the binary file object ``source`` without decoding; ``None`` when its header is not
    one of those or does not say."""
    head = source.read(26)
    if head.startswith(_PNG_SIGNATURE):
        if len(head) < 24 or head[12:16] != b"IHDR":
            return None
        return int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big")
    if head.startswith(b"\xff\xd8"):
        source.seek(0)
        return _jpeg_size(source.read(_JPEG_SEARCH_BYTES))
    if head.startswith(b"BM") and len(head) >= 26:
        width = int.from_bytes(head[18:22], "little", signed=True)
        height = int.from_bytes(head[22:26], "little", signed=True)
        return abs(width), abs(height)  # a negative height: rows stored top-down
    if head[:4] in (b"II*\x00", b"MM\x00*"):
        return _tiff_size(source, "little" if head[:2] == b"II" else "big")
    return None


def _jpeg_size(data: bytes) -> tuple[int, int] | None:
    """The size in a JPEG's first ``SOFn`` segment (``None`` before the scan without one)."""
    k = 2
    while k + 4 <= len(data):
        if data[k] != 0xFF:
            return None  # not at a marker: a broken stream
        marker = data[k + 1]
        if marker == 0xFF:  # fill byte
            k += 1
            continue
        if marker in _STANDALONE:
            k += 2
            continue
        length = int.from_bytes(data[k + 2 : k + 4], "big")
        if marker in _SOF:
            if k + 9 > len(data):
                return None
            height = int.from_bytes(data[k + 5 : k + 7], "big")
            width = int.from_bytes(data[k + 7 : k + 9], "big")
            return width, height
        if marker == 0xDA or length < 2:  # the scan starts (or a broken length)
            return None
        k += 2 + length
    return None


def _tiff_size(source: BinaryIO, order: str) -> tuple[int, int] | None:
    """Width and length of a TIFF's first image directory (tags 256, 257)."""
    source.seek(4)
    offset = int.from_bytes(source.read(4), order)  # type: ignore[arg-type]
    source.seek(offset)
    count_bytes = source.read(2)
    if len(count_bytes) < 2:
        return None
    entries = source.read(12 * int.from_bytes(count_bytes, order))  # type: ignore[arg-type]
    found: dict[int, int] = {}
    for e in range(0, len(entries) - 11, 12):
        tag = int.from_bytes(entries[e : e + 2], order)  # type: ignore[arg-type]
        kind = int.from_bytes(entries[e + 2 : e + 4], order)  # type: ignore[arg-type]
        if tag in (256, 257):  # SHORT (3) or LONG (4), held in the entry itself
            size = 2 if kind == 3 else 4
            found[tag] = int.from_bytes(entries[e + 8 : e + 8 + size], order)  # type: ignore[arg-type]
    if 256 in found and 257 in found:
        return found[256], found[257]
    return None


def check_frame_size(
    width: int,
    height: int,
    what: str,
    error: type[LiquidTouchError],
    max_pixels: int = MAX_FRAME_PIXELS,
) -> None:
    """Refuse (``error``) a frame of ``width`` × ``height`` [px] that is empty, over
    ``max_pixels`` or over :data:`MAX_FRAME_SIDE_PX` on a side."""
    if width < 1 or height < 1 or max(width, height) > MAX_FRAME_SIDE_PX:
        raise error(
            f"{what} declares {width}x{height} px; a sensor frame is 1 to "
            f"{MAX_FRAME_SIDE_PX} px on a side"
        )
    if width * height > max_pixels:
        raise error(
            f"{what} declares {width}x{height} px ({width * height / 1e6:.1f} MP), more than "
            f"the {max_pixels / 1e6:.1f} MP a sensor frame may have; it is not decoded"
        )


def check_image_bytes(
    data: bytes,
    what: str,
    error: type[LiquidTouchError],
    max_pixels: int = MAX_FRAME_PIXELS,
) -> tuple[int, int]:
    """``(width, height)`` [px] an encoded image ``data`` declares, checked by
    :func:`check_frame_size`; ``error`` when its header does not say."""
    size = declared_size(io.BytesIO(data))
    if size is None:
        raise error(f"{what} does not declare its size (not a PNG, JPEG, BMP or TIFF image)")
    check_frame_size(*size, what, error, max_pixels)
    return size


def check_image_file(
    path: str | os.PathLike[str],
    error: type[LiquidTouchError],
    max_pixels: int = MAX_FRAME_PIXELS,
) -> tuple[int, int]:
    """``(width, height)`` [px] the image file ``path`` declares, checked by
    :func:`check_frame_size`; ``error`` when it cannot be read or does not say."""
    try:
        with open(path, "rb") as handle:
            size = declared_size(handle)
            empty = handle.tell() == 0
    except OSError as exc:
        raise error(f"cannot read image {path}: {exc.strerror or exc}") from None
    if empty:
        raise error(f"image {path} is empty (0 bytes); every frame must be an image")
    if size is None:
        raise error(
            f"image {path} does not declare its size (not a PNG, JPEG, BMP or TIFF image, or "
            "a damaged one)"
        )
    check_frame_size(*size, f"image {path}", error, max_pixels)
    return size
