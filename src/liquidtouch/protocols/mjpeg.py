"""MJPEG over HTTP, as mjpg-streamer (a GelSight R1.5) serves it.

Written once for both sides: :mod:`liquidtouch.acquire.cameras.mjpeg` (the client)
and :mod:`liquidtouch.sim.rig.mjpeg` (the simulated sensor's server).

A ``GET`` is answered ``200`` with ``Content-Type: multipart/x-mixed-replace;
boundary=B`` (:func:`content_type`), then parts: ``--B``, headers
(``Content-Type: image/jpeg``, ``Content-Length`` and optionally ``X-Timestamp:
<seconds on the sender's clock>``), a blank line, the JPEG and ``\\r\\n``
(:func:`part_head`). ``--B--`` or closing the connection between parts ends the stream.
"""

from __future__ import annotations

__all__ = [
    "BOUNDARY",
    "JPEG_END",
    "JPEG_TYPE",
    "LENGTH_HEADER",
    "MULTIPART_TYPE",
    "PART_END",
    "TIMESTAMP_HEADER",
    "content_type",
    "parse_boundary",
    "part_head",
]

MULTIPART_TYPE = "multipart/x-mixed-replace"
JPEG_TYPE = "image/jpeg"
LENGTH_HEADER = "Content-Length"
TIMESTAMP_HEADER = "X-Timestamp"
"""A part's capture time [s] on the sender's clock."""
BOUNDARY = "liquidtouchframe"
"""The multipart boundary liquidtouch's server writes between JPEG parts."""
JPEG_END = b"\xff\xd9"
"""The JPEG end-of-image marker."""
PART_END = b"\r\n"
"""What follows a part's JPEG."""


def content_type(boundary: str = BOUNDARY) -> str:
    """The stream's ``Content-Type``."""
    return f"{MULTIPART_TYPE}; boundary={boundary}"


def part_head(length: int, t_s: float | None, boundary: str = BOUNDARY) -> bytes:
    """The boundary line and headers of a JPEG part of ``length`` bytes captured at ``t_s``
    (``None``: no timestamp header, as a sender without a clock of its own)."""
    stamp = "" if t_s is None else f"{TIMESTAMP_HEADER}: {t_s:.6f}\r\n"
    return (
        f"--{boundary}\r\nContent-Type: {JPEG_TYPE}\r\n{LENGTH_HEADER}: {length}\r\n{stamp}\r\n"
    ).encode("ascii")


def parse_boundary(value: str) -> str | None:
    """The boundary of a ``multipart/x-mixed-replace`` Content-Type (``None`` for others)."""
    kind, _, params = value.partition(";")
    if kind.strip().lower() != MULTIPART_TYPE:
        return None
    for param in params.split(";"):
        name, _, text = param.strip().partition("=")
        if name.strip().lower() == "boundary" and text.strip().strip('"'):
            return text.strip().strip('"').removeprefix("--")
    return None
