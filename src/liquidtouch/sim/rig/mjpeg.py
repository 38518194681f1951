"""A simulated networked GelSight: an MJPEG-over-HTTP stream as mjpg-streamer serves it.

A GelSight R1.5 is a Raspberry Pi that streams its camera with mjpg-streamer:
``GET /stream`` (mjpg-streamer: ``/?action=stream``) answers with
``multipart/x-mixed-replace; boundary=...`` and then one JPEG part per frame,
each with ``Content-Type: image/jpeg``, ``Content-Length`` and ``X-Timestamp``
headers, for as long as the client stays connected (the protocol:
:mod:`liquidtouch.protocols.mjpeg`, shared with the client
:mod:`liquidtouch.acquire.cameras.mjpeg`). :class:`MjpegServer` does the same on the
loopback interface from a Python frame source, so the whole
recording path (OpenCV/FFmpeg client, capture threads, recorder) can be run and
timed without hardware.

One producer thread "captures" frames on the server's schedule: it calls
``frame_source()`` once per frame period, at the frame's time, encodes the image
as JPEG (``cv2.imencode``) and queues it for every connected client. A client
that reads too slowly gets its frames late rather than not at all (up to
:data:`CLIENT_QUEUE_S` of frames; mjpg-streamer would skip to the newest frame),
so a briefly starved server thread does not lose frames in tests: only the
recorder's own losses show. Clients connected to ``/stream`` receive only frames
captured after they connected.

Timing (all on :func:`time.monotonic`, seconds): ``sent_timestamps[k]`` is the
capture time of the k-th frame, which is also its ``X-Timestamp`` header: its slot
on the camera's frame lattice (start + j / fps; a producer that falls more than a
frame behind skips whole slots, as a camera drops frames), which the k-th
``frame_source()`` call follows within a frame period (or is given, ``timed``). Frames are
indexed by the order of the ``frame_source`` calls, so a test whose frame
source encodes a counter in the image can match each received frame to its
capture time.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections import deque
from collections.abc import Callable
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import numpy as np

from liquidtouch.errors import DeviceError
from liquidtouch.protocols import mjpeg as wire

__all__ = ["CLIENT_QUEUE_S", "CLIENT_TIMEOUT_S", "STREAM_PATH", "MjpegServer"]

logger = logging.getLogger(__name__)

STREAM_PATH = "/stream"
CLIENT_TIMEOUT_S = 5.0
"""Socket timeout [s] of a client connection: a stalled client is dropped after this."""
CLIENT_QUEUE_S = 2.0
"""A client that falls behind gets every frame late, up to this many seconds of frames [s];
beyond that its oldest frames are dropped (as a camera's buffer overflows)."""
_WAIT_S = 0.1  # how often waiting threads check for stop [s]


class _Handler(BaseHTTPRequestHandler):
    server: _Server
    timeout = CLIENT_TIMEOUT_S

    def log_message(self, format: str, *args: object) -> None:
        """Stay quiet (the stdlib handler logs every request to stderr)."""

    def do_GET(self) -> None:
        path = self.path.split("?", 1)[0]
        if path in ("/", "/index.html"):
            self._index()
        elif path == STREAM_PATH or (path == "/" and "action=stream" in self.path):
            self._stream()
        else:
            self.send_error(404, "not found")

    def _index(self) -> None:
        body = (
            "<!doctype html><title>liquidtouch simulated GelSight</title>"
            f'<img src="{STREAM_PATH}" alt="stream">'
        ).encode()
        self.send_response(200)
        self.send_header("Content-Type", "text/html; charset=utf-8")
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)

    def _stream(self) -> None:
        owner = self.server.owner
        self.send_response(200)
        self.send_header("Content-Type", wire.content_type())
        self.send_header("Cache-Control", "no-cache, no-store, must-revalidate")
        self.send_header("Pragma", "no-cache")
        self.send_header("Connection", "close")
        self.end_headers()
        pending = owner._subscribe()
        logger.info("MJPEG client %s connected", self.client_address[0])
        try:
            while not owner._stopping.is_set():
                part = owner._next_part(pending)
                if part is None:
                    continue
                _, t_s, jpeg = part
                if owner.burst_s:  # held until the end of its burst window
                    window = math.ceil((t_s - owner.start_t_s) / owner.burst_s) * owner.burst_s
                    owner._stopping.wait(max(0.0, owner.start_t_s + window - time.monotonic()))
                stamp = t_s if owner.stamped else None
                self.wfile.write(wire.part_head(len(jpeg), stamp) + jpeg + wire.PART_END)
                self.wfile.flush()
        except (OSError, ValueError) as exc:  # the client went away (or the socket timed out)
            logger.info("MJPEG client %s left: %s", self.client_address[0], exc)
            return
        finally:
            owner._unsubscribe(pending)


class _Server(ThreadingHTTPServer):
    daemon_threads = True
    allow_reuse_address = True
    owner: MjpegServer


class MjpegServer:
    """Serve ``frame_source()`` images as an MJPEG HTTP stream at ``fps`` frames per second.

    Parameters
    ----------
    frame_source : called with no argument once per frame, at the frame's capture
        time; returns a grey (H, W) or BGR (H, W, 3) ``uint8`` image.
    fps : frame rate [Hz] of the stream.
    host, port : where to listen; the default port 0 picks a free port (see :attr:`url`).
        Only loopback use is intended (the default ``127.0.0.1``).
    quality : JPEG quality, 0–100.
    timed : call ``frame_source(t_s)`` with the frame's capture time [s, time.monotonic]
        (its ``X-Timestamp``), to render the scene at that time: on a busy machine the
        producer thread can be descheduled for tens of ms between the stamp and the call.
    sender_clock : maps a frame's capture time [s] to the ``X-Timestamp`` sent (default:
        the same): a camera whose clock steps back or freezes, for tests and rehearsals.
    stamped : send each part's ``X-Timestamp`` (default); without it the client stamps
        frames on arrival.
    burst_s : hold the frames and send them together at the end of every ``burst_s``
        seconds [s] (from the start), as a loaded machine delivers them (``None``: each
        when it is captured).

    Use as a context manager, or call :meth:`start` and :meth:`stop`. An exception
    raised by ``frame_source`` stops the stream and is kept in :attr:`error`.
    """

    def __init__(
        self,
        frame_source: Callable[[], np.ndarray],
        *,
        fps: float,
        host: str = "127.0.0.1",
        port: int = 0,
        quality: int = 95,
        timed: bool = False,
        sender_clock: Callable[[float], float] | None = None,
        stamped: bool = True,
        burst_s: float | None = None,
    ) -> None:
        if not 0 < float(fps) <= 1000:
            raise DeviceError(f"the stream's frame rate must be in (0, 1000] Hz, got {fps!r}")
        if not 0 <= int(quality) <= 100:
            raise DeviceError(f"JPEG quality must be 0..100, got {quality!r}")
        self.frame_source = frame_source
        self.fps = float(fps)
        self.host = host
        self.port = int(port)
        self.quality = int(quality)
        self.timed = bool(timed)
        self.sender_clock = sender_clock
        self.stamped = bool(stamped)
        if burst_s is not None and not 0 < float(burst_s) <= CLIENT_QUEUE_S:
            raise DeviceError(f"burst_s must be in (0, {CLIENT_QUEUE_S:g}] s, got {burst_s!r}")
        self.burst_s = None if burst_s is None else float(burst_s)
        self.start_t_s = math.nan
        """When the producer started [s, time.monotonic] (burst windows count from it)."""
        self.sent_timestamps: list[float] = []
        """Capture time [s, time.monotonic] of every frame, in frame_source call order."""
        self.error: BaseException | None = None
        self._stopping = threading.Event()
        self._cond = threading.Condition()
        self._clients: list[deque] = []
        self._server: _Server | None = None
        self._threads: list[threading.Thread] = []

    @property
    def url(self) -> str:
        """The stream's URL, ``http://host:port/stream`` (after :meth:`start`)."""
        if self._server is None:
            raise DeviceError("the MJPEG server is not running: call start() first")
        host, port = self._server.server_address[:2]
        return f"http://{host}:{port}{STREAM_PATH}"

    def start(self) -> MjpegServer:
        """Bind the socket, start producing frames and serving clients; return ``self``."""
        if self._server is not None:
            return self
        try:
            server = _Server((self.host, self.port), _Handler)
        except OSError as exc:
            raise DeviceError(
                f"cannot listen on {self.host}:{self.port}: {exc.strerror or exc}"
            ) from None
        server.owner = self
        server.timeout = _WAIT_S
        self._server = server
        self._stopping.clear()
        self._threads = [
            threading.Thread(target=self._produce, name="mjpeg-producer", daemon=True),
            threading.Thread(
                target=server.serve_forever,
                kwargs={"poll_interval": _WAIT_S},
                name="mjpeg-server",
                daemon=True,
            ),
        ]
        for thread in self._threads:
            thread.start()
        return self

    def stop(self) -> None:
        """Stop producing, close every client connection and the listening socket."""
        if self._server is None:
            return
        self._stopping.set()
        with self._cond:
            self._cond.notify_all()
        self._server.shutdown()
        for thread in self._threads:
            thread.join(timeout=5.0)
        self._server.server_close()
        self._server = None
        self._threads = []

    def __enter__(self) -> MjpegServer:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # --- producer -----------------------------------------------------------------------

    def _produce(self) -> None:
        import cv2  # why: OpenCV is heavy; imported when the stream starts

        period = 1.0 / self.fps
        due = self.start_t_s = time.monotonic()
        params = [int(cv2.IMWRITE_JPEG_QUALITY), self.quality]
        index = 0
        while not self._stopping.is_set():
            now = time.monotonic()
            if now < due:
                self._stopping.wait(min(due - now, _WAIT_S))
                continue
            if now > due + period:  # fell behind: skip whole frames, as a camera drops them
                skipped = math.floor((now - due) / period)
                logger.debug("MJPEG producer fell behind: %d frame slots skipped", skipped)
                due += period * skipped
            # A camera exposes on its own clock, whatever its host is busy with: the frame's
            # time is its slot on the frame lattice (the producer may wake late under load)
            t_s = due
            try:
                image = np.asarray(self.frame_source(t_s) if self.timed else self.frame_source())
                if image.dtype != np.uint8 or image.ndim not in (2, 3):
                    raise DeviceError(
                        f"frame_source must return a grey or BGR uint8 image, got "
                        f"{image.dtype} of shape {image.shape}"
                    )
                ok, jpeg = cv2.imencode(".jpg", image, params)
                if not ok:
                    raise DeviceError("cv2.imencode could not encode the frame as JPEG")
            except BaseException as exc:  # kept for the caller; the stream ends
                logger.warning("MJPEG frame source failed, the stream ends: %s", exc)
                self.error = exc
                self._stopping.set()
                with self._cond:
                    self._cond.notify_all()
                return
            self.sent_timestamps.append(t_s)
            stamp = t_s if self.sender_clock is None else float(self.sender_clock(t_s))
            part = (index, stamp, jpeg.tobytes())
            with self._cond:
                for pending in self._clients:
                    pending.append(part)
                self._cond.notify_all()
            index += 1
            due += period

    def _subscribe(self) -> deque:
        pending: deque = deque(maxlen=max(2, round(CLIENT_QUEUE_S * self.fps)))
        with self._cond:
            self._clients.append(pending)
        return pending

    def _unsubscribe(self, pending: deque) -> None:
        # by identity: deques compare by content, and every client's queue holds the same
        # frames, so `list.remove` would drop another client's queue (that client would
        # get no frame again: the README-order bug, `live` starved once `run-trial` left)
        with self._cond:
            self._clients[:] = [q for q in self._clients if q is not pending]

    def _next_part(self, pending: deque) -> tuple[int, float, bytes] | None:
        """The client's next frame, or ``None`` after a short wait without one."""
        with self._cond:
            if not pending:
                self._cond.wait(_WAIT_S)
            return pending.popleft() if pending else None
