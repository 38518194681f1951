"""An MJPEG-over-HTTP camera (mjpg-streamer, a GelSight R1.5) read with the standard library.

OpenCV reads an ``http://`` stream through FFmpeg and the recorder could only
stamp each frame when it arrived: network jitter then lands in the timestamps
(4 ms of it moved λ by 7 % on the simulated rig). This client parses the stream
itself, so it sees each part's ``X-Timestamp`` header.

**Protocol** (:mod:`liquidtouch.protocols.mjpeg`): ``GET`` answered by
``multipart/x-mixed-replace; boundary=B``, then parts ``--B``, headers
(``Content-Type: image/jpeg``, ``Content-Length``, and optionally ``X-Timestamp:
<seconds on the sender's clock>``), a blank line and the JPEG (:class:`MjpegStream`;
a part without ``Content-Length`` runs to the next boundary line, or the stream's end
if its JPEG is complete). ``--B--`` or
the server closing between parts ends the stream (:class:`StreamEnded`); closing
inside a part, a part that breaks the format, or no complete part within ``read_timeout_s``
raise :class:`DeviceError`. A JPEG
that does not decode is skipped (it shows as a dropped frame) and counted in
:attr:`MjpegCamera.bad_frames`.

**Timestamps** (:class:`SenderClock`): a part with ``X-Timestamp`` is stamped at
that capture time moved onto the local :func:`time.monotonic` clock by the
sender→receiver offset, the minimum of ``arrival − sender time`` over the last
:data:`OFFSET_WINDOW_S` seconds of frames: the network only ever delays a frame,
so the least delayed frame shows the offset (plus the smallest latency), and
jitter does not reach the timestamps. A part without it is stamped on arrival
(a part without ``Content-Length`` arrives only with the next boundary). When the
sender's clock steps back or stands still (an ``X-Timestamp`` not after the one
before) the offset is learnt anew from that frame, which is stamped on arrival: the
frames stay in order and the step is counted (:attr:`Camera.reanchors`) and logged
as a warning.

**Deadlines.** Opening (connect, request, response headers) and each read are
bounded as a whole (:data:`DEFAULT_OPEN_TIMEOUT_S`, :data:`DEFAULT_READ_TIMEOUT_S`),
not per network read: a sender that drips a byte a second fails the call in time.
"""

from __future__ import annotations

import base64
import http.client
import io
import logging
import math
import socket
import threading
import time
from collections import deque
from urllib.parse import urlsplit

import numpy as np

from liquidtouch.acquire.cameras.devices import Camera, StreamEnded
from liquidtouch.acquire.cameras.profiles import CameraProfile
from liquidtouch.acquire.deadlines import DEFAULT_OPEN_TIMEOUT_S, DEFAULT_READ_TIMEOUT_S
from liquidtouch.errors import DeviceError
from liquidtouch.io.image_size import check_frame_size, declared_size
from liquidtouch.protocols import mjpeg

__all__ = ["OFFSET_WINDOW_S", "MjpegCamera", "MjpegStream", "SenderClock"]

logger = logging.getLogger(__name__)

OFFSET_WINDOW_S = 30.0
"""The sender→receiver clock offset is the least delay over this many seconds of frames [s]
(longer than a trial; short enough that two machines' clocks drift by < 1 ms over it)."""
MAX_PART_BYTES = 32 * 1024 * 1024
"""Largest JPEG part accepted [bytes] (a 12 MP frame at high quality is a few MB)."""
MAX_HEADER_LINES = 64
MAX_LINE_BYTES = 8192
MAX_SKIPPED_BYTES = 65536
"""Bytes between parts (preamble, padding) skipped while looking for the boundary."""


class SenderClock:
    """Maps a sender's capture times onto the local monotonic clock (module docstring).

    ``to_local(sender_s, arrival_s)`` [s] gives ``sender_s + offset``, the offset
    being the least ``arrival_s − sender_s`` seen over the last ``window_s`` seconds
    (a sliding minimum, O(1) per frame).
    """

    def __init__(self, window_s: float = OFFSET_WINDOW_S) -> None:
        self.window_s = float(window_s)
        self._recent: deque[tuple[float, float]] = deque()  # (arrival, offset), offsets rising

    def to_local(self, sender_s: float, arrival_s: float) -> float:
        offset = arrival_s - sender_s
        while self._recent and self._recent[-1][1] >= offset:
            self._recent.pop()
        self._recent.append((arrival_s, offset))
        while self._recent[0][0] < arrival_s - self.window_s:
            self._recent.popleft()
        return sender_s + self._recent[0][1]


class MjpegStream:
    """One HTTP connection to an MJPEG stream; :meth:`read_part` gives its next part.

    Both timeouts bound a whole call, not each network read (a sender that drips a
    byte a second cannot hold a call longer): ``open_timeout_s`` connecting, the
    request and the response headers, ``read_timeout_s`` each :meth:`read_part` [s].
    Raises :class:`DeviceError` when the URL cannot be opened or does not serve a
    multipart stream.
    """

    def __init__(
        self,
        url: str,
        *,
        open_timeout_s: float = DEFAULT_OPEN_TIMEOUT_S,
        read_timeout_s: float = DEFAULT_READ_TIMEOUT_S,
    ) -> None:
        parts = urlsplit(url)
        if parts.scheme not in ("http", "https") or not parts.hostname:
            raise DeviceError(f"{url!r} is not an http:// or https:// stream URL")
        self.url = url
        self.read_timeout_s = float(read_timeout_s)
        open_timeout_s = float(open_timeout_s)
        kind = (
            http.client.HTTPSConnection if parts.scheme == "https" else http.client.HTTPConnection
        )
        self._conn = kind(parts.hostname, parts.port, timeout=open_timeout_s)
        self._sock: socket.socket | None = None
        self._buffer = bytearray()
        self._deadline = math.inf
        target = (parts.path or "/") + (f"?{parts.query}" if parts.query else "")
        headers = {
            "Accept": f"{mjpeg.MULTIPART_TYPE}, {mjpeg.JPEG_TYPE}",
            "Connection": "close",
        }
        if parts.username:  # mjpg-streamer's -c user:password
            token = f"{parts.username}:{parts.password or ''}".encode()
            headers["Authorization"] = "Basic " + base64.b64encode(token).decode("ascii")
        start = time.monotonic()
        expired = threading.Event()

        def expire() -> None:  # the whole open overran: wake the blocked read
            expired.set()
            self.interrupt()

        watchdog: threading.Timer | None = None
        try:
            self._conn.connect()  # bounded by open_timeout_s itself
            # kept: once the response owns the connection (Connection: close) conn.sock is None
            self._sock = self._conn.sock
            left_s = max(0.0, open_timeout_s - (time.monotonic() - start))
            watchdog = threading.Timer(left_s, expire)
            watchdog.daemon = True
            watchdog.start()
            self._conn.request("GET", target, headers=headers)
            response = self._conn.getresponse()
        except (OSError, http.client.HTTPException) as exc:
            self._conn.close()
            if self._sock is not None:
                self._sock.close()
            reason = f"no answer within {open_timeout_s:g} s" if expired.is_set() else exc
            logger.info("stream %s could not be opened: %s", url, reason)
            raise DeviceError(f"stream {url} could not be opened: {reason}") from None
        finally:
            if watchdog is not None:
                watchdog.cancel()
        if expired.is_set():  # fired just as the headers completed: the socket is shut
            response.close()
            self._conn.close()
            raise DeviceError(
                f"stream {url} could not be opened: no answer within {open_timeout_s:g} s"
            )
        kind_header = response.getheader("Content-Type", "")
        boundary = mjpeg.parse_boundary(kind_header)
        if response.status != 200 or boundary is None:
            response.close()
            self._conn.close()
            raise DeviceError(
                f"stream {url} could not be opened: the server answered {response.status} "
                f"{response.reason[:80]} with {kind_header[:80] or 'no Content-Type'!r}, not a "
                f"{mjpeg.MULTIPART_TYPE} MJPEG stream"
            )
        self._response = response
        self._boundary = b"--" + boundary.encode("latin-1")
        self._pending: bytes | None = None  # a boundary line already read (no Content-Length)
        logger.info("connected to MJPEG stream %s (boundary %r)", url, boundary[:80])

    def read_part(self, timeout_s: float | None = None) -> tuple[float, dict[str, str], bytes]:
        """``(arrival_s, headers, body)`` of the next part; ``arrival_s`` on time.monotonic.

        The whole part must arrive within ``timeout_s`` [s] (default
        :attr:`read_timeout_s`). Header names are lower case. :class:`StreamEnded` at
        the stream's end, :class:`DeviceError` on a timeout or a broken part (module
        docstring).
        """
        timeout_s = self.read_timeout_s if timeout_s is None else float(timeout_s)
        self._deadline = time.monotonic() + timeout_s
        try:
            self._skip_to_boundary()
            headers = self._headers()
            body = self._body(headers.get(mjpeg.LENGTH_HEADER.lower()))
        except TimeoutError:
            raise DeviceError(
                f"stream {self.url} delivered no complete frame within {timeout_s:.3g} s; is "
                "the sensor still streaming?"
            ) from None
        except (OSError, http.client.HTTPException) as exc:
            raise DeviceError(f"stream {self.url} broke off: {exc}") from None
        return time.monotonic(), headers, body

    def interrupt(self) -> None:
        """Wake a read blocked on the socket (from another thread): it fails at once."""
        sock = self._sock if self._sock is not None else self._conn.sock
        if sock is None:
            return
        try:
            sock.shutdown(socket.SHUT_RDWR)
        except OSError:  # already closed or never connected
            pass

    def close(self) -> None:
        """Close the connection (idempotent)."""
        self._response.close()
        self._conn.close()
        if self._sock is not None:
            self._sock.close()

    # --- reading against the call's deadline ------------------------------------------

    def _fill(self) -> bool:
        """Read what the socket has (at most one receive) into the buffer, waiting at most
        until the call's deadline; ``False`` at the end of the stream."""
        remaining = self._deadline - time.monotonic()
        if remaining <= 0:
            raise TimeoutError
        if self._response.isclosed():  # http.client closed it at the stream's end
            return False
        assert self._sock is not None
        try:
            self._sock.settimeout(remaining)
        except OSError:  # closed at the stream's end: the read below says so
            pass
        chunk = self._response.read1(65536)
        if not chunk:
            return False
        self._buffer += chunk
        return True

    def _line(self) -> bytes:
        searched = 0
        while True:
            end = self._buffer.find(b"\n", searched)
            if end >= 0:
                if end + 1 > MAX_LINE_BYTES:
                    break
                line = bytes(self._buffer[: end + 1])
                del self._buffer[: end + 1]
                return line
            if len(self._buffer) > MAX_LINE_BYTES:
                break
            searched = len(self._buffer)
            if not self._fill():  # the end: what is left is the last line
                line = bytes(self._buffer)
                self._buffer.clear()
                return line
        raise DeviceError(f"stream {self.url}: a line longer than {MAX_LINE_BYTES} bytes")

    def _read_exact(self, size: int) -> bytes:
        while len(self._buffer) < size:
            if not self._fill():
                break
        data = bytes(self._buffer[:size])
        del self._buffer[:size]
        return data

    # --- parsing ------------------------------------------------------------------------

    def _skip_to_boundary(self) -> None:
        if self._pending is not None:
            line, self._pending = self._pending, None
        else:
            line = self._line()
        skipped = 0
        while line.rstrip(b"\r\n") != self._boundary:
            if not line:
                raise StreamEnded(f"stream {self.url} ended (the server closed it)")
            if line.rstrip() == self._boundary + b"--":
                raise StreamEnded(f"stream {self.url} ended (its last part was sent)")
            skipped += len(line)
            if skipped > MAX_SKIPPED_BYTES:
                raise DeviceError(
                    f"stream {self.url}: no part boundary in {skipped} bytes; is it an "
                    "MJPEG stream?"
                )
            line = self._line()

    def _headers(self) -> dict[str, str]:
        headers: dict[str, str] = {}
        for _ in range(MAX_HEADER_LINES):
            line = self._line()
            if not line:
                raise DeviceError(f"stream {self.url} closed inside a part's headers")
            text = line.decode("latin-1").strip()
            if not text:
                return headers
            name, sep, value = text.partition(":")
            if not sep:
                raise DeviceError(f"stream {self.url}: malformed part header {text[:80]!r}")
            headers[name.strip().lower()] = value.strip()
        raise DeviceError(f"stream {self.url}: a part with more than {MAX_HEADER_LINES} headers")

    def _body(self, length_text: str | None) -> bytes:
        if length_text is None:
            return self._body_to_boundary()
        try:
            length = int(length_text[:20])
        except ValueError:
            length = -1
        if not 0 < length <= MAX_PART_BYTES:
            raise DeviceError(
                f"stream {self.url}: part Content-Length {length_text[:40]!r} is not a size in "
                f"1..{MAX_PART_BYTES} bytes"
            )
        body = self._read_exact(length)
        if len(body) < length:
            raise DeviceError(
                f"stream {self.url} closed inside a frame ({len(body)} of {length} bytes)"
            )
        return body

    def _body_to_boundary(self) -> bytes:
        chunks: list[bytes] = []
        size = 0
        while True:
            line = self._line()
            if not line:  # the last part ends with the stream, if its JPEG is complete
                if b"".join(chunks).rstrip(b"\r\n").endswith(mjpeg.JPEG_END):
                    break
                raise DeviceError(f"stream {self.url} closed inside a frame")
            if line.startswith(self._boundary):
                self._pending = line
                break
            chunks.append(line)
            size += len(line)
            if size > MAX_PART_BYTES:
                raise DeviceError(f"stream {self.url}: a part over {MAX_PART_BYTES} bytes")
        body = b"".join(chunks)
        return body[:-2] if body.endswith(b"\r\n") else body.rstrip(b"\n")


class MjpegCamera(Camera):
    """An ``http(s)://`` MJPEG stream as a :class:`Camera` (module docstring for timing)."""

    def __init__(
        self,
        url: str,
        profile: CameraProfile,
        *,
        open_timeout_s: float = DEFAULT_OPEN_TIMEOUT_S,
        read_timeout_s: float = DEFAULT_READ_TIMEOUT_S,
    ) -> None:
        self.source = url
        self.profile = profile
        self.nominal_fps = profile.fps
        self.clock = SenderClock()
        self.bad_frames = 0
        """Parts whose JPEG did not decode (skipped: they show as dropped frames)."""
        self.sender_timed: bool | None = None
        """Whether the last part carried ``X-Timestamp`` (``None`` before the first)."""
        self.read_timeout_s = float(read_timeout_s)
        self._lock = threading.Lock()
        self._last_sender_s = -math.inf
        self._stream: MjpegStream | None = MjpegStream(
            url, open_timeout_s=open_timeout_s, read_timeout_s=read_timeout_s
        )

    def _read(self, timeout_s: float) -> tuple[float, np.ndarray]:
        import cv2  # why: OpenCV is heavy; imported when the first frame is decoded

        with self._lock:
            if self._stream is None:
                raise DeviceError(f"stream {self.source} is closed")
            deadline = time.monotonic() + float(timeout_s)
            while True:  # the whole call, skipped parts included, ends by the deadline
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    raise DeviceError(
                        f"stream {self.source}: no decodable JPEG within {timeout_s:g} s"
                    )
                arrival, headers, body = self._stream.read_part(remaining)
                size = declared_size(io.BytesIO(body))  # before decoding: it may claim GBs
                if size is not None:
                    what = f"stream {self.source}: a frame"
                    check_frame_size(*size, what, DeviceError, self.profile.max_pixels)
                image = cv2.imdecode(np.frombuffer(body, np.uint8), cv2.IMREAD_UNCHANGED)
                if image is not None:
                    break
                self.bad_frames += 1
                logger.log(
                    logging.WARNING if self.bad_frames == 1 else logging.DEBUG,
                    "stream %s: a part of %d bytes is not a decodable JPEG (skipped, %d so far)",
                    self.source,
                    len(body),
                    self.bad_frames,
                )
        stamp = headers.get(mjpeg.TIMESTAMP_HEADER.lower())
        if self.sender_timed is None:
            logger.info(
                "stream %s: %s",
                self.source,
                f"frames carry {mjpeg.TIMESTAMP_HEADER} (sender clock)"
                if stamp is not None
                else f"no {mjpeg.TIMESTAMP_HEADER}: frames stamped on arrival",
            )
        self.sender_timed = stamp is not None
        if stamp is None:
            return arrival, image
        try:
            sender_s = float(stamp[:40])
        except ValueError:
            sender_s = math.nan
        if not math.isfinite(sender_s):
            raise DeviceError(
                f"stream {self.source}: {mjpeg.TIMESTAMP_HEADER} {stamp[:40]!r} is not seconds"
            )
        if sender_s <= self._last_sender_s:  # the sender's clock stepped back or froze
            self.reanchors += 1
            logger.log(
                logging.WARNING if self.reanchors == 1 else logging.DEBUG,
                "stream %s: %s went from %.6f to %.6f s (the sender's clock stepped back or "
                "stood still); frames re-anchored on arrival time (%d so far)",
                self.source,
                mjpeg.TIMESTAMP_HEADER,
                self._last_sender_s,
                sender_s,
                self.reanchors,
            )
            self.clock = SenderClock(self.clock.window_s)  # learn the offset anew from here
        self._last_sender_s = sender_s
        return self.clock.to_local(sender_s, arrival), image

    def close(self) -> None:
        stream = self._stream
        if stream is not None:
            stream.interrupt()  # a read in progress holds the lock: end it first
        with self._lock:
            if self._stream is not None:
                self._stream.close()
                self._stream = None
