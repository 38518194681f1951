"""Cameras: the simulated MJPEG GelSight, opening sources, profiles, capture threads, one clock.

Everything runs on the loopback interface (127.0.0.1) with bounded waits: every
read has a timeout, every server is stopped by its context manager.
"""

from __future__ import annotations

import socket
import time
import urllib.error
import urllib.request
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
from camera_frames import CodedFrames, dot_position, frame_number

from liquidtouch.acquire.cameras import (
    END,
    PROFILES,
    CaptureSession,
    FrameStats,
    open_camera,
    parse_source,
    resolve_device_name,
    sources,
)
from liquidtouch.acquire.recording import Recorder
from liquidtouch.errors import DeviceError
from liquidtouch.protocols.mjpeg import BOUNDARY
from liquidtouch.sim.rig.mjpeg import MjpegServer

FPS = 30.0


def _read_http_head(url: str, n_bytes: int = 20000) -> bytes:
    """The first bytes of a GET on ``url`` (raw socket, 5 s timeout)."""
    host_port, path = url.removeprefix("http://").split("/", 1)
    host, port = host_port.split(":")
    with socket.create_connection((host, int(port)), timeout=5.0) as sock:
        sock.sendall(f"GET /{path} HTTP/1.0\r\nHost: {host}\r\n\r\n".encode())
        data = b""
        while len(data) < n_bytes:
            chunk = sock.recv(65536)
            if not chunk:
                break
            data += chunk
    return data


def test_mjpeg_server_speaks_mjpg_streamer_http() -> None:
    with MjpegServer(CodedFrames(), fps=FPS) as server:
        assert server.url.startswith("http://127.0.0.1:") and server.url.endswith("/stream")
        data = _read_http_head(server.url)
        head, _, body = data.partition(b"\r\n\r\n")
        assert head.startswith(b"HTTP/1.0 200")
        assert f"multipart/x-mixed-replace; boundary={BOUNDARY}".encode() in head
        part_head, _, rest = body.partition(b"\r\n\r\n")
        lines = part_head.decode().split("\r\n")
        assert lines[0] == f"--{BOUNDARY}"
        fields = dict(line.split(": ", 1) for line in lines[1:])
        assert fields["Content-Type"] == "image/jpeg"
        length = int(fields["Content-Length"])
        assert rest[:2] == b"\xff\xd8"  # a JPEG
        assert rest[length - 2 : length] == b"\xff\xd9"
        stamp = float(fields["X-Timestamp"])
        assert any(abs(stamp - t) < 1e-6 for t in server.sent_timestamps)
        url = server.url
        base = url.removesuffix("stream")
        with urllib.request.urlopen(base, timeout=5.0) as response:
            assert b"<img" in response.read()
        with pytest.raises(urllib.error.HTTPError):
            urllib.request.urlopen(base + "nothing", timeout=5.0)
    with pytest.raises(OSError):  # stopped: nothing listens any more
        _read_http_head(url)


def test_open_camera_reads_the_stream_with_content_and_timing() -> None:
    frames = CodedFrames()
    with MjpegServer(frames, fps=FPS) as server, open_camera(server.url) as camera:
        assert camera.live
        got = [camera.read(timeout_s=2.0) for _ in range(60)]
        sent = np.array(server.sent_timestamps)
    t = np.array([t for t, _ in got])
    numbers = np.array([frame_number(image) for _, image in got])
    assert (np.diff(numbers) > 0).all(), "frames arrive in order"
    assert (np.diff(numbers) == 1).mean() >= 0.95, "hardly any frame skipped"
    for (_, image), k in zip(got[::10], numbers[::10], strict=True):
        assert image.shape == (240, 320, 3)
        x, y = dot_position(image)
        ex, ey = frames.dot_center(int(k))
        assert abs(x - ex) < 1.0 and abs(y - ey) < 1.0
    latency = t - sent[numbers]
    assert (latency >= 0).all()
    assert np.median(latency) < 0.010
    assert (latency < 1 / FPS).mean() >= 0.95
    assert abs(np.median(np.diff(t)) - 1 / FPS) < 0.004


def test_stream_closed_by_the_server_ends_the_camera() -> None:
    server = MjpegServer(CodedFrames(), fps=FPS).start()
    camera = open_camera(server.url, read_timeout_s=1.0)
    try:
        camera.read(timeout_s=1.0)
        server.stop()
        start = time.monotonic()
        with pytest.raises(DeviceError):  # StreamEnded, or no frame within the timeout
            for _ in range(100):
                camera.read(timeout_s=1.0)
        assert time.monotonic() - start < 5.0
    finally:
        camera.close()
        server.stop()


def test_unreachable_stream_fails_fast() -> None:
    with socket.socket() as sock:  # a port nobody listens on
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    start = time.monotonic()
    with pytest.raises(DeviceError, match="could not be opened"):
        open_camera(f"http://127.0.0.1:{port}/stream", open_timeout_s=2.0)
    assert time.monotonic() - start < 5.0


def test_capture_session_two_cameras_one_clock() -> None:
    with (
        MjpegServer(CodedFrames(), fps=FPS) as a,
        MjpegServer(CodedFrames(), fps=20.0) as b,
    ):
        cams = [open_camera(a.url), open_camera(b.url)]
        session = CaptureSession(cams)
        with session:
            time.sleep(2.0)
            session.stop()
        assert session.names == ["left", "right"]
        assert not session.errors
        for name, server, fps in (("left", a, FPS), ("right", b, 20.0)):
            items = []
            while (item := session.queues[name].get(timeout=5.0)) is not END:
                items.append(item)
            assert abs(len(items) - 2.0 * fps) <= 3
            t = np.array([f.t_s for f in items])
            assert (t >= session.start_t_s).all() and (t <= session.stop_t_s).all()
            assert t[0] - session.start_t_s < 1.5 / fps
            sent = np.array(server.sent_timestamps)
            numbers = np.array([frame_number(f.image) for f in items])
            lag = t - sent[numbers]  # one clock: the server's time.monotonic and ours
            assert (lag >= 0).all() and np.median(lag) < 0.010
            stats = session.stats[name]
            assert stats.frames == len(items) and stats.duplicates == 0
            assert abs(stats.measured_fps - fps) < 0.05 * fps
        for camera in cams:
            camera.close()


def _write_video(path, timestamps, size=(160, 120), repeat=()) -> list[np.ndarray]:
    """An FFV1 video whose frame k has the given timestamp [s]; frames in ``repeat`` repeat
    the previous image. Returns the BGR images written."""
    import av

    images = []
    with av.open(str(path), "w", format="matroska") as container:
        stream = container.add_stream("ffv1", rate=30)
        stream.width, stream.height = size
        stream.pix_fmt = "bgr0"
        stream.codec_context.time_base = Fraction(1, 1000)
        rng = np.random.default_rng(0)
        for k, t in enumerate(timestamps):
            if k in repeat:
                image = images[-1].copy()
            else:
                image = rng.integers(0, 255, (size[1], size[0], 3), dtype=np.uint8)
            images.append(image)
            frame = av.VideoFrame.from_ndarray(image, format="bgr24")
            frame.pts = round(t * 1000)
            frame.time_base = Fraction(1, 1000)
            for packet in stream.encode(frame):
                container.mux(packet)
        for packet in stream.encode():
            container.mux(packet)
    return images


def test_replayed_video_keeps_its_own_timing(tmp_path) -> None:
    stamps = np.arange(40) / 30.0
    stamps = np.delete(stamps, [10, 25, 26])  # three dropped frames: one gap of 2, one of 3
    stamps[5] += 0.004  # jitter
    path = tmp_path / "replay.mkv"
    images = _write_video(path, stamps, repeat={30})
    camera = open_camera(str(path))
    assert not camera.live
    session = CaptureSession([camera], ["replay"])
    start = time.monotonic()
    with session:
        while not session.all_ended and time.monotonic() - start < 10.0:
            time.sleep(0.05)
    items = []
    while (item := session.queues["replay"].get(timeout=5.0)) is not END:
        items.append(item)
    assert len(items) == len(stamps)
    t = np.array([f.t_s for f in items])
    np.testing.assert_allclose(t - t[0], stamps - stamps[0], atol=1e-3)  # due times (PTS: ms)
    assert time.monotonic() - start >= stamps[-1] - 0.05  # paced in real time
    assert all(np.array_equal(f.image, im) for f, im in zip(items, images, strict=True))
    stats = session.stats["replay"]
    assert stats.drops == 3
    assert stats.duplicates == 1 and items[30].duplicate


def test_frame_stats_counts_drops_and_duplicates() -> None:
    stats = FrameStats(nominal_fps=30.0)
    period = 1 / 30
    times = [0, 1, 2, 4, 5, 8, 9]  # gaps of 2 and 3 periods: 1 + 2 dropped
    for i, k in enumerate(times):
        image = np.full((4, 4), 4 if i == 5 else i, np.uint8)  # frame 5 repeats frame 4
        stats.add(k * period + (0.003 if k == 5 else 0.0), image)
    assert stats.frames == 7
    assert stats.drops == 3
    assert stats.duplicates == 1  # frames 4 and 5 identical
    assert stats.measured_fps == pytest.approx(30.0, rel=3e-3)  # the camera's (3 ms jitter)
    jitter = FrameStats()  # no nominal rate: the median interval; 1.4 periods is not a drop
    for t in (0.0, 0.033, 0.066, 0.112, 0.133, 0.166):
        jitter.add(t, np.full((2, 2), int(t * 1000) % 250, np.uint8))
    assert jitter.drops == 0 and jitter.duplicates == 0


def test_name_resolution_through_sysfs(tmp_path, monkeypatch) -> None:
    devices = {0: "Integrated Camera", 3: "GelSight Mini R0B", 2: "GelSight Mini R0B", 11: "DIGIT"}
    for index, name in devices.items():
        (tmp_path / f"video{index}").mkdir()
        (tmp_path / f"video{index}" / "name").write_text(name + "\n")
    (tmp_path / "v4l-subdev0").mkdir()
    monkeypatch.setattr(sources, "SYSFS_VIDEO4LINUX", tmp_path)
    assert resolve_device_name("GelSight Mini") == 2  # the lowest node of that sensor
    assert resolve_device_name("gelsight mini") == 2
    assert resolve_device_name("digit") == 11
    spec = parse_source("name:GelSight Mini")
    assert (spec.kind, spec.target) == ("device", 2)
    with pytest.raises(DeviceError, match=r"found video0 \(Integrated Camera\)"):
        resolve_device_name("GelSight R1.5")
    if not Path("/dev/video2").exists():
        with pytest.raises(DeviceError, match="/dev/video2 does not exist"):
            open_camera("name:GelSight Mini")


def test_serial_and_by_id_links_and_the_same_camera_twice(tmp_path, monkeypatch) -> None:
    """Two GelSight Minis share a name: `name:GelSight Mini` twice opened one device twice.
    Now the same camera twice is refused, and `serial:` / by-id links pick each one."""
    for index, name in {2: "GelSight Mini R0B", 4: "GelSight Mini R0B"}.items():
        (tmp_path / f"video{index}").mkdir()
        (tmp_path / f"video{index}" / "name").write_text(name + "\n")
    by_id = tmp_path / "by-id"
    by_id.mkdir()
    for index, serial in {2: "2BJ7-4F8Q", 4: "2BJ7-9X1Z"}.items():
        link = by_id / f"usb-GelSight_GelSight_Mini_R0B_{serial}-video-index0"
        link.symlink_to(tmp_path / f"video{index}")
        (by_id / f"usb-GelSight_GelSight_Mini_R0B_{serial}-video-index1").symlink_to(tmp_path)
    monkeypatch.setattr(sources, "SYSFS_VIDEO4LINUX", tmp_path)
    monkeypatch.setattr(sources, "V4L_BY_ID", by_id)
    assert parse_source("serial:9x1z").target == 4
    assert parse_source("serial:2BJ7-4F8Q").target == 2
    with pytest.raises(DeviceError, match="2 cameras with serial '2BJ7'"):
        parse_source("serial:2BJ7")
    with pytest.raises(DeviceError, match="no camera with serial 'nope'"):
        parse_source("serial:nope")
    specs = sources.check_distinct_sources(["serial:4F8Q", "serial:9X1Z"])
    assert [s.target for s in specs] == [2, 4]
    for pair in (
        ["name:GelSight Mini", "name:GelSight Mini"],
        ["name:GelSight Mini", "2"],
        ["/dev/video4", "serial:9X1Z"],
        ["http://127.0.0.1:9/stream", "http://127.0.0.1:9/stream"],
    ):
        with pytest.raises(DeviceError, match="are the same camera"):
            sources.check_distinct_sources(pair)
    with pytest.raises(DeviceError, match="are the same camera"):  # before opening anything
        Recorder(["name:GelSight Mini", "name:gelsight mini"], tmp_path / "t").open()


def test_source_strings() -> None:
    assert (parse_source("0").kind, parse_source("0").target) == ("device", 0)
    assert parse_source("/dev/video4").target == 4
    assert parse_source("http://127.0.0.1:8080/?action=stream").kind == "url"
    assert parse_source("rtsp://127.0.0.1/x").kind == "url"
    for bad in ("", "   ", "no/such/file.mp4"):
        with pytest.raises(DeviceError):
            parse_source(bad)
    with pytest.raises(DeviceError, match="unknown sensor profile"):
        open_camera("0", profile="gelsight-9000")


def test_profiles_crop_and_resize_like_the_sdk() -> None:
    mini = PROFILES["mini"]
    assert (mini.width, mini.height, mini.fps) == (320, 240, 25.0)
    assert mini.capture == (3280, 2464, "MJPG")
    frame = np.full((2464, 3280, 3), 200, np.uint8)
    by, bx = 2464 // 7, 3280 // 7
    frame[:by] = frame[-by:] = 0  # the borders the SDK crops away
    frame[:, :bx] = frame[:, -bx:] = 0
    frame[1232 - 40 : 1232 + 40, 1640 - 40 : 1640 + 40] = 50  # a marker in the middle
    out = mini.apply(frame)
    assert out.shape == (240, 320, 3)
    assert out.min() == 50 and (out > 150).mean() > 0.9  # no border left
    x, y = dot_position(out)
    assert abs(x - 159.5) < 1 and abs(y - 119.5) < 1
    small = np.zeros((240, 320), np.uint8)
    assert mini.apply(small) is small  # already the sensor's size (a replayed recording)
    assert PROFILES["r15"].apply(np.zeros((240, 320), np.uint8)).shape == (480, 640)
    assert PROFILES["digit"].fps == 60.0
    raw = np.zeros((7, 9, 3), np.uint8)
    assert PROFILES["raw"].apply(raw) is raw


def test_profile_applies_to_a_stream() -> None:
    with MjpegServer(CodedFrames(640, 480), fps=FPS) as server:
        with open_camera(server.url, profile="digit", warmup_frames=2) as camera:
            _, image = camera.read()
            assert image.shape == (240, 320, 3)
            assert camera.nominal_fps == 60.0
