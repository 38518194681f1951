"""Two cameras, one lost: the live stream ends with ``source_error`` and the estimate so far.

Each camera is a scripted MJPEG server on 127.0.0.1 (:class:`FaultyCamera`): it streams
synthetic marker frames (``helpers.render_blobs``, all markers moved by a damped
oscillation from :data:`PUSH_S`) at 30 fps with ``X-Timestamp``, and after
``fail_after_s`` fails in one way: it stalls (the connection stays open, no byte comes),
sends a broken part, a NaN or garbage ``X-Timestamp``, or closes the stream. Before the
fix the other camera's frames kept coming, the estimate froze on the lost camera's last
frame and the stream never ended. A fake camera whose read ignores its deadline covers the
stall watchdog. Every test is bounded (``timeout`` seconds).
"""

from __future__ import annotations

import math
import socket
import threading
import time

import cv2
import numpy as np
import pytest
from helpers import grid, render_blobs

from liquidtouch.acquire.cameras import Camera, get_profile
from liquidtouch.errors import DeviceError
from liquidtouch.live import camera_frames, live_updates
from liquidtouch.protocols import mjpeg

FPS = 30.0
PUSH_S = 1.0
DECAY_RATE, ANGULAR_FREQUENCY = 0.5, 12.0
HEAD = (
    f"HTTP/1.0 200 OK\r\nContent-Type: {mjpeg.content_type()}\r\n\r\n".encode()
)  # fmt: skip


def displacement_px(t_s: float) -> float:
    """All markers' x displacement [px] at ``t_s`` [s] since the stream's start."""
    tau = t_s - PUSH_S
    return 1.2 * math.exp(-DECAY_RATE * tau) * math.sin(ANGULAR_FREQUENCY * tau) if tau > 0 else 0.0


BASE = render_blobs(grid(), noise=0.0)


def frame_jpeg(t_s: float, seed: int) -> bytes:
    """The marker frame at ``t_s`` [s] (a sub-pixel shift of one rendering, light noise)."""
    shift = np.float32([[1, 0, displacement_px(t_s)], [0, 1, 0]])
    image = cv2.warpAffine(BASE, shift, BASE.shape[::-1], borderMode=cv2.BORDER_REPLICATE)
    noise = np.random.default_rng(seed).normal(0, 1.0, image.shape)
    image = np.clip(image + noise, 0, 255).astype(np.uint8)
    ok, data = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, 95])
    assert ok
    return data.tobytes()


class FaultyCamera:
    """An MJPEG server on 127.0.0.1 streaming marker frames at 30 fps; after ``fail_after_s``
    it fails with ``kind``: ``stall``, ``broken``, ``nan``, ``garbage``, ``close`` (or never).
    """

    def __init__(self, kind: str = "", fail_after_s: float = math.inf, t0: float = 0.0) -> None:
        self.kind, self.fail_after_s, self.t0 = kind, fail_after_s, t0
        self.listener = socket.create_server(("127.0.0.1", 0))
        self.listener.settimeout(10.0)
        self.url = f"http://127.0.0.1:{self.listener.getsockname()[1]}/stream"
        self.done = threading.Event()
        self.thread = threading.Thread(target=self._serve, daemon=True)

    def _failure(self, t_s: float) -> bytes:
        body = frame_jpeg(t_s, 0)
        head = f"--{mjpeg.BOUNDARY}\r\nContent-Type: image/jpeg\r\n"
        if self.kind == "broken":
            return (head + "Content-Length: many\r\n\r\n").encode() + body
        stamp = "nan" if self.kind == "nan" else "soon"
        return (head + f"Content-Length: {len(body)}\r\nX-Timestamp: {stamp}\r\n\r\n").encode() + (
            body + b"\r\n"
        )

    def _serve(self) -> None:
        try:
            conn, _ = self.listener.accept()
        except OSError:
            return
        with conn:
            conn.settimeout(10.0)
            try:
                conn.recv(4096)
                conn.sendall(HEAD)
                start = time.monotonic()
                k = 0
                while not self.done.is_set():
                    due = start + k / FPS
                    time.sleep(max(0.0, due - time.monotonic()))
                    t_s = due - start
                    if t_s >= self.fail_after_s:
                        if self.kind == "stall":
                            self.done.wait(20.0)
                        elif self.kind in ("broken", "nan", "garbage"):
                            conn.sendall(self._failure(t_s))
                            self.done.wait(20.0)
                        return  # "close": the server closes the stream
                    body = frame_jpeg(t_s, k)
                    conn.sendall(mjpeg.part_head(len(body), self.t0 + due) + body + b"\r\n")
                    k += 1
            except OSError:
                pass

    def __enter__(self) -> FaultyCamera:
        self.thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.done.set()
        self.listener.close()
        self.thread.join(5.0)


@pytest.mark.timeout(60)
@pytest.mark.parametrize(
    ("kind", "message"),
    [
        ("stall", "no complete frame within"),  # the read's whole-call deadline
        ("broken", "Content-Length"),
        ("nan", "X-Timestamp"),
        ("garbage", "X-Timestamp"),
        ("close", "stopped sending frames while the others go on"),
    ],
)
def test_losing_one_of_two_cameras_ends_the_stream_with_source_error(kind, message) -> None:
    with FaultyCamera() as good, FaultyCamera(kind, fail_after_s=2.5) as bad:
        began = time.monotonic()
        updates = list(live_updates([good.url, bad.url]))
        took = time.monotonic() - began
    final = updates[-1]
    assert final.final and final.stopped_because == "source_error", final.message
    assert "camera right" in final.message and message in final.message, final.message
    assert final.frames > 2 * 2.0 * FPS * 0.8  # both cameras' frames up to the failure
    assert took < 2.5 + 12.0  # the failure, its read deadline, closing: not forever


@pytest.mark.timeout(60)
def test_the_final_update_keeps_the_estimate_so_far() -> None:
    with FaultyCamera() as good, FaultyCamera("close", fail_after_s=7.0) as bad:
        updates = list(live_updates([good.url, bad.url]))
    final = updates[-1]
    assert final.stopped_because == "source_error" and final.segment == 1, final.message
    assert final.angular_frequency == pytest.approx(ANGULAR_FREQUENCY, rel=0.02)
    assert final.decay_rate == pytest.approx(DECAY_RATE, rel=0.25)
    streamed = [u for u in updates[:-1] if math.isfinite(u.angular_frequency)]
    assert streamed, "no estimate while streaming"


@pytest.mark.timeout(60)
def test_cameras_that_end_together_end_the_stream_normally() -> None:
    with FaultyCamera("close", fail_after_s=2.0) as left, FaultyCamera("close", 2.0) as right:
        updates = list(live_updates([left.url, right.url]))
    assert updates[-1].stopped_because == "end_of_stream", updates[-1].message


class _Frozen(Camera):
    """A camera that gives a few frames, then blocks in ``read`` past any deadline."""

    nominal_fps = FPS

    def __init__(self, frames: int) -> None:
        self.frames, self.k = frames, 0
        self.source, self.profile = "frozen", get_profile("raw")
        self.closed = threading.Event()

    def _read(self, timeout_s: float):
        if self.k >= self.frames:
            self.closed.wait(30.0)  # ignores timeout_s: only the watchdog notices
            raise DeviceError("closed")
        self.k += 1
        time.sleep(1 / FPS)
        return time.monotonic(), cv2.imdecode(
            np.frombuffer(frame_jpeg(self.k / FPS, self.k), np.uint8), cv2.IMREAD_GRAYSCALE
        )

    def close(self) -> None:
        self.closed.set()


@pytest.mark.timeout(60)
def test_a_read_that_ignores_its_deadline_is_a_stall(monkeypatch) -> None:
    import liquidtouch.live.sources as sources

    cams = iter([_Frozen(10**6), _Frozen(15)])
    monkeypatch.setattr(sources, "open_camera", lambda source, profile, **deadlines: next(cams))
    got = 0
    with pytest.raises(DeviceError, match=r"camera right failed: no frame for 0\.5 s"):
        for _ in camera_frames(["http://127.0.0.1:9/a", "http://127.0.0.1:9/b"], stall_s=0.5):
            got += 1
    assert got >= 15
