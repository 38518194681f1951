"""The MJPEG client: parsing multipart streams, X-Timestamp onto our clock, errors, all bounded.

A scripted server (one connection on 127.0.0.1, a list of byte chunks and pauses)
plays well-formed and broken streams; the rig's :class:`MjpegServer` is the real one.
"""

from __future__ import annotations

import socket
import threading
import time

import cv2
import numpy as np
import pytest
from camera_frames import CodedFrames, frame_number
from helpers import jpeg_claiming

from liquidtouch.acquire.cameras import (
    MjpegCamera,
    SenderClock,
    StreamEnded,
    get_profile,
    open_camera,
)
from liquidtouch.errors import DeviceError
from liquidtouch.sim.rig.mjpeg import MjpegServer

FPS = 30.0
HEAD = b"HTTP/1.0 200 OK\r\nContent-Type: multipart/x-mixed-replace; boundary=frame\r\n\r\n"


def jpeg(k: int) -> bytes:
    """Frame k of :class:`CodedFrames` as JPEG."""
    frames = CodedFrames()
    frames.calls = k
    ok, data = cv2.imencode(".jpg", frames())
    assert ok
    return data.tobytes()


def part(k: int, *, stamp: float | None = None, length: bool = True, body=None) -> bytes:
    body = jpeg(k) if body is None else body
    head = b"--frame\r\nContent-Type: image/jpeg\r\n"
    if length:
        head += f"Content-Length: {len(body)}\r\n".encode()
    if stamp is not None:
        head += f"X-Timestamp: {stamp:.6f}\r\n".encode()
    return head + b"\r\n" + body + b"\r\n"


class Scripted:
    """Serves one connection: sends each ``bytes`` item, sleeps for each ``float``, then
    closes (``then="close"``) or stalls until stopped (``then="stall"``)."""

    def __init__(self, script, then: str = "close") -> None:
        self.script, self.then = script, then
        self.listener = socket.create_server(("127.0.0.1", 0))
        self.listener.settimeout(5.0)
        self.url = f"http://127.0.0.1:{self.listener.getsockname()[1]}/stream"
        self.done = threading.Event()
        self.thread = threading.Thread(target=self._serve, daemon=True)

    def _serve(self) -> None:
        try:
            conn, _ = self.listener.accept()
        except OSError:
            return
        with conn:
            conn.settimeout(5.0)
            try:
                conn.recv(4096)  # the request
                for item in self.script:
                    if self.done.is_set():
                        break
                    if isinstance(item, bytes):
                        conn.sendall(item)
                    else:
                        time.sleep(item)
                if self.then == "stall":
                    self.done.wait(10.0)
            except OSError:
                pass

    def __enter__(self) -> Scripted:
        self.thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.done.set()
        self.listener.close()
        self.thread.join(timeout=5.0)


def camera(url: str, read_timeout_s: float = 2.0) -> MjpegCamera:
    return MjpegCamera(url, get_profile("raw"), open_timeout_s=2.0, read_timeout_s=read_timeout_s)


def test_sender_clock_takes_the_least_delayed_frame():
    clock = SenderClock(window_s=1.0)
    rng = np.random.default_rng(0)
    sender = 50.0 + np.arange(120) / FPS
    delay = 0.002 + rng.exponential(0.004, sender.size)  # latency >= 2 ms, jittered
    arrival = 1000.0 + sender + delay  # another machine's clock, 1000 s apart
    local = np.array([clock.to_local(s, a) for s, a in zip(sender, arrival, strict=True)])
    assert (local <= arrival + 1e-12).all()
    late = local[60:] - sender[60:] - 1000.0  # after the first second: the least delay
    assert np.ptp(late) < 1e-3 and abs(late.mean() - 0.002) < 1e-3
    assert np.diff(local[60:]).std() < 0.1 * np.diff(arrival[60:]).std()


def test_jittered_delivery_keeps_the_capture_times():
    rng = np.random.default_rng(1)
    t0 = time.monotonic()
    sent_s = np.arange(40) / FPS + rng.uniform(0, 0.008, 40)  # each sent 0–8 ms late
    script: list = [HEAD]
    for k in range(40):  # captured at t0 + k / FPS
        script += [float(sent_s[k] - (sent_s[k - 1] if k else 0.0)), part(k, stamp=t0 + k / FPS)]
    with Scripted(script) as server:
        cam = camera(server.url)
        try:
            got = [cam.read(timeout_s=2.0) for _ in range(40)]
        finally:
            cam.close()
    t = np.array([s for s, _ in got])
    assert [frame_number(image) for _, image in got] == list(range(40))
    assert cam.sender_timed
    # not 8 ms of jitter: once a little-delayed frame came (a camera's warm-up frames) the
    # offset holds; before, it can only shrink by what the first frames were late
    np.testing.assert_allclose(np.diff(t[10:]), 1 / FPS, atol=2e-4)
    np.testing.assert_allclose(np.diff(t), 1 / FPS, atol=0.008)
    assert (t - (t0 + np.arange(40) / FPS) >= 0).all()


def test_parts_without_timestamp_or_length_are_read_and_stamped_on_arrival():
    script = [HEAD, b"preamble\r\n", part(0, length=False), 0.05, part(1, length=False)]
    with Scripted(script) as server:
        cam = camera(server.url)
        try:
            before = time.monotonic()
            (t_a, a), (t_b, b) = cam.read(), cam.read()
            assert not cam.sender_timed and before <= t_a < t_b <= time.monotonic()
            assert t_a - before > 0.04  # complete only when the next boundary came
            assert (frame_number(a), frame_number(b)) == (0, 1)
            with pytest.raises(StreamEnded):  # closed between parts
                cam.read()
        finally:
            cam.close()


@pytest.mark.parametrize(
    ("script", "match"),
    [
        ([HEAD, part(0)[:300]], "closed inside a frame"),
        ([HEAD, b"--frame\r\nContent-Length: lots\r\n\r\nxx"], "Content-Length 'lots'"),
        ([HEAD, b"--frame\r\nContent-Length 12\r\n\r\n"], "malformed part header"),
        ([HEAD, part(0, stamp=1.0).replace(b"1.000000", b"soon")], "X-Timestamp 'soon'"),
    ],
)
def test_broken_streams_raise_a_device_error(script, match):
    with Scripted(script) as server:
        cam = camera(server.url)
        try:
            with pytest.raises(DeviceError, match=match):
                cam.read()
        finally:
            cam.close()


def test_a_bad_jpeg_is_skipped_and_counted_and_a_stall_times_out():
    script = [HEAD, part(0, body=b"\xff\xd8not a jpeg\xff\xd9"), part(1)]
    with Scripted(script, then="stall") as server:
        cam = camera(server.url, read_timeout_s=0.5)
        try:
            assert frame_number(cam.read(timeout_s=0.5)[1]) == 1 and cam.bad_frames == 1
            start = time.monotonic()
            with pytest.raises(DeviceError, match=r"no complete frame within 0\.5 s"):
                cam.read(timeout_s=0.5)
            assert time.monotonic() - start < 2.0
        finally:
            cam.close()


def test_not_a_stream_or_nobody_listening_fails_to_open():
    with Scripted([b"HTTP/1.0 200 OK\r\nContent-Type: text/html\r\n\r\n<html>"]) as server:
        with pytest.raises(DeviceError, match="not a multipart/x-mixed-replace"):
            camera(server.url)
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    with pytest.raises(DeviceError, match="could not be opened"):
        camera(f"http://127.0.0.1:{port}/stream")


def test_the_rig_stream_is_timed_by_its_capture_clock():
    with MjpegServer(CodedFrames(), fps=FPS) as server, open_camera(server.url) as cam:
        assert isinstance(cam, MjpegCamera)
        got = [cam.read(timeout_s=2.0) for _ in range(45)]
        sent = np.array(server.sent_timestamps)
    numbers = np.array([frame_number(image) for _, image in got])
    lag = np.array([t for t, _ in got]) - sent[numbers]
    # one offset for every frame (the least latency), however late each one came
    assert (lag >= 0).all() and lag.max() < 0.010
    assert np.ptp(lag[15:]) < 1e-3


def test_close_wakes_a_blocked_read():
    with Scripted([HEAD, part(0)], then="stall") as server:
        cam = camera(server.url, read_timeout_s=5.0)
        cam.read()
        errors = []

        def reader():
            try:
                cam.read(timeout_s=5.0)
            except DeviceError as exc:
                errors.append(exc)

        thread = threading.Thread(target=reader)
        thread.start()
        time.sleep(0.2)
        start = time.monotonic()
        cam.close()
        thread.join(timeout=3.0)
        assert not thread.is_alive() and errors and time.monotonic() - start < 2.0


def drip(data: bytes, pause_s: float = 0.2) -> list:
    """``data`` one byte at a time, ``pause_s`` apart (a sender that never quite stalls)."""
    script: list = []
    for byte in data:
        script += [bytes([byte]), pause_s]
    return script


def test_opening_a_dripping_stream_has_a_whole_call_deadline():
    """Response headers arriving a byte every 0.2 s: each recv is quick, the open is not."""
    with Scripted(drip(HEAD)) as server:
        start = time.monotonic()
        with pytest.raises(DeviceError, match=r"could not be opened: no answer within 1 s"):
            MjpegCamera(server.url, get_profile("raw"), open_timeout_s=1.0)
        assert time.monotonic() - start < 2.5


def test_reading_a_dripping_part_has_a_whole_call_deadline():
    with Scripted([HEAD, part(0), *drip(part(1))]) as server:
        cam = camera(server.url, read_timeout_s=1.0)
        try:
            assert frame_number(cam.read(timeout_s=1.0)[1]) == 0
            start = time.monotonic()
            with pytest.raises(DeviceError, match=r"no complete frame within 1 s"):
                cam.read(timeout_s=1.0)
            assert time.monotonic() - start < 2.0
        finally:
            cam.close()


def test_warm_up_has_a_whole_call_deadline():
    """A frame every 0.6 s: each read is within its 2 s, but 10 warm-up frames take 6 s."""
    script = [HEAD]
    for k in range(20):
        script += [part(k, stamp=100.0 + k), 0.6]
    with Scripted(script) as server:
        start = time.monotonic()
        with pytest.raises(DeviceError, match=r"of 10 warm-up frames within 1\.5 s"):
            open_camera(server.url, warmup_timeout_s=1.5, read_timeout_s=2.0)
        assert time.monotonic() - start < 3.0
    for bad in (0.0, -1.0, float("inf"), float("nan"), 1e9):
        with pytest.raises(DeviceError, match="warm-up timeout must be a number of seconds"):
            open_camera("http://127.0.0.1:9/stream", warmup_timeout_s=bad)


def test_a_sender_clock_that_steps_back_or_freezes_is_reanchored_on_arrival():
    """X-Timestamps 100.0, 100.033, then 95 (back), then 95 three times (frozen), then on:
    every frame is returned, in order, and the steps are counted."""
    stamps = [100.0, 100.033, 95.0, 95.0, 95.0, 95.0, 95.033, 95.066]
    script = [HEAD]
    for k, stamp in enumerate(stamps):
        script += [part(k, stamp=stamp), 0.03]
    with Scripted(script) as server:
        cam = camera(server.url)
        try:
            got = [cam.read(timeout_s=2.0) for _ in stamps]
        finally:
            cam.close()
    times = np.array([t for t, _ in got])
    assert [frame_number(image) for _, image in got] == list(range(len(stamps)))
    assert (np.diff(times) > 0).all(), np.diff(times)
    assert cam.reanchors == 4


def test_a_client_leaving_does_not_starve_another():
    """The README-order rig bug: run-trial closing its camera connection left `live`'s
    connection to the same stream without frames. Every client's queue holds the same
    frames, and deques compare by content, so removing "the equal one" removed the other
    client's queue (deterministic here: both queues empty, as when the handlers keep up)."""
    server = MjpegServer(CodedFrames(), fps=FPS)
    stays, leaves = server._subscribe(), server._subscribe()
    server._unsubscribe(leaves)
    assert len(server._clients) == 1 and server._clients[0] is stays
    server._unsubscribe(leaves)  # twice: nothing else goes
    assert server._clients[0] is stays


def test_a_frame_claiming_gigapixels_is_refused_before_decoding(tmp_path):
    """A 689-byte JPEG claiming 20000 x 20000 px cost 2.5 GB in record and live: the size its
    header declares is checked against the sensor profile first (issue 41)."""
    script = [HEAD, part(0, body=jpeg_claiming(20000, 20000))]
    with Scripted(script, then="stall") as server:
        cam = camera(server.url)
        try:
            with pytest.raises(DeviceError, match="declares 20000x20000 px"):
                cam.read()
        finally:
            cam.close()
    assert get_profile("r15").max_pixels == 4 * 640 * 480  # twice each side of its frames
    script = [HEAD, part(0, body=jpeg_claiming(4000, 3000))]  # 12 MP: more than an R1.5 gives
    with Scripted(script, then="stall") as server:
        cam = MjpegCamera(server.url, get_profile("r15"), open_timeout_s=2.0, read_timeout_s=2.0)
        try:
            with pytest.raises(DeviceError, match="declares 4000x3000 px"):
                cam.read()
        finally:
            cam.close()
