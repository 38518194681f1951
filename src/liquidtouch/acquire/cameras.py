"""Live GelSight cameras: open one by index, path, name or URL; read timed frames on threads.

**Sources** (:func:`open_camera`):

- ``"0"``: a V4L2 device index (``/dev/video0``);
- ``"/dev/video2"``: a device path;
- ``"name:GelSight Mini"``: the first (lowest-numbered) V4L2 device whose
  ``/sys/class/video4linux/video*/name`` contains that text (case-insensitive),
  the way the GelSight SDK finds its sensors (:data:`SYSFS_VIDEO4LINUX`);
- ``"http://..."``, ``"rtsp://..."``: a network stream through OpenCV's FFmpeg
  backend (a GelSight R1.5 streams MJPEG with mjpg-streamer:
  ``http://gsr1500x.local:8080/?action=stream``), with open and read timeouts;
- a video file: replayed in real time at the pace of its own timestamps (for tests
  and rehearsals; it ends with :class:`StreamEnded`).

**One clock.** Every frame's ``t_s`` is on :func:`time.monotonic` [s], the same
clock for every sensor (and for the gripper and arm), so frames of several
cameras and other events can be compared directly. For a network or USB camera
``t_s`` is the moment the frame was grabbed (before decoding); for a V4L2 device
the driver's buffer timestamp is used when it is on that same clock (Linux
``CLOCK_MONOTONIC``, what UVC drivers use); a replayed file gives each frame the
moment it was due.

**Sensor profiles** (:data:`PROFILES`) set the camera mode and turn each frame into
the sensor's image: ``mini`` (a GelSight Mini: the camera gives MJPG 3280 × 2464 at
up to 25 fps; 1/7 of each border is cropped and the rest resized to 320 × 240, as
the GelSight SDK does), ``r15`` (640 × 480 at 30 fps), ``digit`` (320 × 240 at
60 fps) and ``raw`` (frames as the camera gives them).

**Nothing is hidden.** :class:`FrameStats` counts dropped frames (a gap between
consecutive timestamps of more than 1.5 frame periods; a gap of g periods counts
round(g) − 1 drops) and duplicated frames (a frame identical to the one before,
which a sensor with noise never produces; a driver repeating its buffer does).
Duplicates are kept in the recording and counted.

:class:`CaptureSession` reads each camera on its own :class:`CameraThread` into a
queue, so a slow consumer never delays a camera's reads (and so its timestamps).
"""

from __future__ import annotations

import math
import os
import queue
import re
import sys
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from liquidtouch.errors import DeviceError

SYSFS_VIDEO4LINUX = Path("/sys/class/video4linux")
"""Where V4L2 devices list their names (patched by tests to a fake tree)."""
DEFAULT_READ_TIMEOUT_S = 2.0
"""How long :meth:`Camera.read` waits for a frame before raising :class:`DeviceError` [s]."""
DEFAULT_OPEN_TIMEOUT_S = 5.0
"""How long opening a network stream may take [s]."""
DEFAULT_WARMUP_FRAMES = 10
"""Frames read and thrown away after opening a live camera (auto-exposure, stale buffers)."""
DROP_GAP_PERIODS = 1.5
"""A timestamp gap of more than this many frame periods means dropped frames."""
MAX_WARMUP_S = 5.0
"""Warm-up gives up after this long [s] (then the camera is not delivering)."""


class StreamEnded(DeviceError):
    """A finite source (a replayed video file, a closed stream) has no more frames."""


# --- sensor profiles --------------------------------------------------------------------


@dataclass(frozen=True)
class CameraProfile:
    """How a sensor's camera is set up and how its frames become the sensor's image.

    ``width`` × ``height`` [px] is the output image size (``None``: unchanged), ``fps``
    [Hz] the nominal frame rate (``None``: the camera's own), ``capture`` the camera
    mode requested from a V4L2 device (width, height, fourcc; ``None``: the
    default), and ``crop_fraction`` the fraction of each border cut off before
    resizing (GelSight Mini: 1/7). A frame that already has the output size is left
    as it is (e.g. a replayed recording of that sensor).
    """

    name: str
    width: int | None
    height: int | None
    fps: float | None
    capture: tuple[int, int, str] | None = None
    crop_fraction: float = 0.0
    description: str = ""

    def apply(self, frame: np.ndarray) -> np.ndarray:
        """The sensor image of one camera frame (crop the borders, resize; area averaging)."""
        if self.width is None or self.height is None:
            return frame
        h, w = frame.shape[:2]
        if (w, h) == (self.width, self.height):
            return frame
        import cv2

        if self.crop_fraction:
            dy, dx = int(h * self.crop_fraction), int(w * self.crop_fraction)
            frame = frame[dy : h - dy, dx : w - dx]
        return cv2.resize(frame, (self.width, self.height), interpolation=cv2.INTER_AREA)


PROFILES: dict[str, CameraProfile] = {
    "raw": CameraProfile("raw", None, None, None, description="frames as the camera gives them"),
    "mini": CameraProfile(
        "mini",
        320,
        240,
        25.0,
        capture=(3280, 2464, "MJPG"),
        crop_fraction=1 / 7,
        description="GelSight Mini: MJPG 3280x2464 at <=25 fps, 1/7 border cropped, 320x240",
    ),
    "r15": CameraProfile(
        "r15", 640, 480, 30.0, description="GelSight R1.5 (mjpg-streamer): 640x480 at 30 fps"
    ),
    "digit": CameraProfile(
        "digit", 320, 240, 60.0, capture=(320, 240, "MJPG"), description="DIGIT: 320x240, 60 fps"
    ),
}


def get_profile(profile: str | CameraProfile) -> CameraProfile:
    """A profile by name (:data:`PROFILES`); :class:`DeviceError` for an unknown one."""
    if isinstance(profile, CameraProfile):
        return profile
    try:
        return PROFILES[str(profile)]
    except KeyError:
        raise DeviceError(
            f"unknown sensor profile {profile!r}; choose one of {', '.join(PROFILES)}"
        ) from None


# --- sources ----------------------------------------------------------------------------


def resolve_device_name(name: str) -> int:
    """The V4L2 index of the first device whose sysfs ``name`` contains ``name``.

    Reads :data:`SYSFS_VIDEO4LINUX`\\ ``/video*/name`` (case-insensitive substring
    match, lowest index first: a GelSight Mini shows two nodes, the capture node
    first). Raises :class:`DeviceError` listing what was found when nothing matches.
    """
    wanted = name.strip().lower()
    if not wanted:
        raise DeviceError("give a device name after 'name:', e.g. name:GelSight Mini")
    found: list[tuple[int, str]] = []
    try:
        entries = list(SYSFS_VIDEO4LINUX.iterdir())
    except OSError:
        entries = []
    for entry in entries:
        match = re.fullmatch(r"video(\d+)", entry.name)
        if not match:
            continue
        try:
            label = (entry / "name").read_text(encoding="utf-8", errors="replace").strip()
        except OSError:
            continue
        found.append((int(match.group(1)), label))
    found.sort()
    for index, label in found:
        if wanted in label.lower():
            return index
    listing = ", ".join(f"video{i} ({label})" for i, label in found) or "no video devices"
    raise DeviceError(
        f"no camera named {name!r} in {SYSFS_VIDEO4LINUX}: found {listing}; is the sensor "
        "plugged in (try `v4l2-ctl --list-devices`)?"
    )


@dataclass(frozen=True)
class SourceSpec:
    """A parsed camera source: ``kind`` is ``device``, ``url`` or ``file``."""

    kind: str
    target: int | str
    text: str


def parse_source(source: str | int | os.PathLike[str]) -> SourceSpec:
    """Classify a source string (see the module docstring); resolve ``name:`` to an index."""
    text = str(source).strip()
    if not text:
        raise DeviceError("empty camera source; give an index, /dev/videoN, name:..., a URL")
    if re.fullmatch(r"\d+", text):
        return SourceSpec("device", int(text), text)
    if text.lower().startswith("name:"):
        return SourceSpec("device", resolve_device_name(text[5:]), text)
    match = re.fullmatch(r"/dev/video(\d+)", text)
    if match:
        return SourceSpec("device", int(match.group(1)), text)
    if re.match(r"^(https?|rtsp|rtsps|rtmp|udp|tcp)://", text, flags=re.IGNORECASE):
        return SourceSpec("url", text, text)
    path = Path(text)
    if text.startswith("/dev/"):
        return SourceSpec("device", text, text)
    if path.is_file():
        return SourceSpec("file", str(path), text)
    raise DeviceError(
        f"camera source {text!r} is not a device index, /dev/videoN, name:..., http/rtsp URL "
        "or an existing video file"
    )


# --- cameras ----------------------------------------------------------------------------


class Camera:
    """An open camera: :meth:`read` gives ``(t_s, frame)``, t_s on :func:`time.monotonic`.

    ``frame`` is a ``uint8`` image (BGR (H, W, 3), or grey (H, W) for a grey
    source) after the sensor profile. ``nominal_fps`` [Hz] is the frame rate the
    profile or the source declares (``None`` when unknown). Close it (or use it
    as a context manager) to release the device.
    """

    source: str
    profile: CameraProfile
    nominal_fps: float | None = None

    def read(self, timeout_s: float = DEFAULT_READ_TIMEOUT_S) -> tuple[float, np.ndarray]:
        """The next frame; :class:`DeviceError` when none comes within ``timeout_s`` seconds,
        :class:`StreamEnded` at the end of a finite source."""
        t_s, frame = self._read(timeout_s)
        return t_s, self.profile.apply(frame)

    def _read(self, timeout_s: float) -> tuple[float, np.ndarray]:
        raise NotImplementedError

    def close(self) -> None:
        """Release the device or file (idempotent)."""

    @property
    def live(self) -> bool:
        """Whether frames come at the source's own pace (a camera or stream, not a file)."""
        return True

    def warm_up(self, frames: int) -> int:
        """Read and discard ``frames`` frames, then any stale frames buffered before now.

        A frame counts as stale when it arrived less than a quarter of a frame period
        after the previous one (it was waiting in a buffer). Returns how many frames
        were discarded; stops after :data:`MAX_WARMUP_S`.
        """
        start = time.monotonic()
        discarded = 0
        for _ in range(max(0, int(frames))):
            self.read()
            discarded += 1
        if not self.live or not self.nominal_fps:
            return discarded
        quick = 0.25 / self.nominal_fps
        while time.monotonic() - start < MAX_WARMUP_S:
            before = time.monotonic()
            self.read()
            discarded += 1
            if time.monotonic() - before >= quick:
                break
        return discarded

    def __enter__(self) -> Camera:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.source!r}, profile={self.profile.name!r})"


class OpenCVCamera(Camera):
    """A V4L2 device or a network stream read with OpenCV ``VideoCapture``."""

    def __init__(
        self,
        spec: SourceSpec,
        profile: CameraProfile,
        *,
        open_timeout_s: float = DEFAULT_OPEN_TIMEOUT_S,
        read_timeout_s: float = DEFAULT_READ_TIMEOUT_S,
    ) -> None:
        import cv2

        self.source = spec.text
        self.profile = profile
        self._spec = spec
        self._lock = threading.Lock()
        timeouts = [
            cv2.CAP_PROP_OPEN_TIMEOUT_MSEC,
            int(open_timeout_s * 1000),
            cv2.CAP_PROP_READ_TIMEOUT_MSEC,
            int(read_timeout_s * 1000),
        ]
        hint = "is the GelSight plugged in, and is the index right (try 0, 1, 2)?"
        if spec.kind == "url":
            what = f"stream {spec.text}"
            hint = "is the sensor (or its streaming service) running and the URL right?"
            capture = _quiet_capture(str(spec.target), cv2.CAP_FFMPEG, timeouts)
        else:
            what = f"camera {spec.text}"
            node = spec.target if isinstance(spec.target, str) else f"/dev/video{spec.target}"
            if sys.platform.startswith("linux") and not Path(node).exists():
                raise DeviceError(f"{what} could not be opened: {node} does not exist; {hint}")
            backend = cv2.CAP_V4L2 if sys.platform.startswith("linux") else cv2.CAP_ANY
            capture = _quiet_capture(spec.target, backend, timeouts)
        if not capture.isOpened():
            capture.release()
            raise DeviceError(f"{what} could not be opened; {hint}")
        self._capture = capture
        self._device_clock: bool | None = None if spec.kind == "device" else False
        if spec.kind == "device":
            self._configure(capture, profile)
        # a V4L2 device reports its mode's rate; FFmpeg guesses 25 for an MJPEG stream
        reported = float(capture.get(cv2.CAP_PROP_FPS) or 0.0) if spec.kind == "device" else 0.0
        self.nominal_fps = profile.fps or (reported if 0 < reported < 1000 else None)

    @staticmethod
    def _configure(capture, profile: CameraProfile) -> None:
        import cv2

        if profile.capture is not None:
            width, height, fourcc = profile.capture
            capture.set(cv2.CAP_PROP_FOURCC, cv2.VideoWriter.fourcc(*fourcc))
            capture.set(cv2.CAP_PROP_FRAME_WIDTH, width)
            capture.set(cv2.CAP_PROP_FRAME_HEIGHT, height)
        if profile.fps:
            capture.set(cv2.CAP_PROP_FPS, profile.fps)

    def _read(self, timeout_s: float) -> tuple[float, np.ndarray]:
        with self._lock:
            if self._capture is None:
                raise DeviceError(f"camera {self.source} is closed")
            start = time.monotonic()
            grabbed = self._capture.grab()
            t_s = time.monotonic()
            if grabbed:
                t_s = self._driver_time(t_s)
                ok, frame = self._capture.retrieve()
            else:
                ok, frame = False, None
        if not ok or frame is None:
            if self._spec.kind == "url" and time.monotonic() - start < timeout_s:
                raise StreamEnded(f"stream {self.source} ended (the server closed it)")
            raise DeviceError(
                f"camera {self.source} delivered no frame within {timeout_s:g} s; is it "
                "still connected?"
            )
        return t_s, frame

    def _driver_time(self, grabbed_at: float) -> float:
        """The V4L2 buffer timestamp when it is on the monotonic clock, else ``grabbed_at``."""
        if self._device_clock is False:
            return grabbed_at
        import cv2

        stamp = float(self._capture.get(cv2.CAP_PROP_POS_MSEC) or 0.0) / 1000.0
        plausible = 0.0 <= grabbed_at - stamp < 1.0  # captured before we got it, not long ago
        if self._device_clock is None:
            self._device_clock = plausible
        return stamp if self._device_clock and plausible else grabbed_at

    def close(self) -> None:
        with self._lock:
            if self._capture is not None:
                self._capture.release()
                self._capture = None


def _quiet_capture(target: int | str, backend: int, params: list[int]):
    """``cv2.VideoCapture(target, backend, params)`` without OpenCV's warnings on stderr
    (a failure becomes one :class:`DeviceError` instead)."""
    import cv2

    if backend == cv2.CAP_FFMPEG:  # FFmpeg's own messages ("Connection refused"): quiet
        os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")
    logging = getattr(getattr(cv2, "utils", None), "logging", None)
    previous = logging.getLogLevel() if logging else None
    try:
        if logging:
            logging.setLogLevel(logging.LOG_LEVEL_ERROR)
        return cv2.VideoCapture(target, backend, params)
    finally:
        if logging and previous is not None:
            logging.setLogLevel(previous)


class FileCamera(Camera):
    """A video file replayed in real time: frame k is returned when it is due.

    Frame k is due at ``t_start + (pts_k − pts_0) / speed`` (``t_start``: the time
    of the first read), and that due time is its ``t_s``, so the replay reproduces
    the file's own timing (jitter and drops included) on the monotonic clock.
    """

    def __init__(self, path: str, profile: CameraProfile, *, speed: float = 1.0) -> None:
        import av

        self.source = str(path)
        self.profile = profile
        if not speed > 0:
            raise DeviceError(f"replay speed must be positive, got {speed!r}")
        self._speed = float(speed)
        try:
            self._container = av.open(str(path))
        except (av.FFmpegError, OSError) as exc:
            raise DeviceError(f"cannot open video {path}: {exc}") from None
        if not self._container.streams.video:
            self._container.close()
            raise DeviceError(f"{path} holds no video stream")
        stream = self._container.streams.video[0]
        stream.thread_type = "AUTO"
        rate = float(stream.average_rate or stream.guessed_rate or 0.0)
        self.nominal_fps = profile.fps or (rate if rate > 0 else None)
        self._time_base = float(stream.time_base) if stream.time_base else None
        self._frames = self._container.decode(stream)
        self._lock = threading.Lock()
        self._t_start: float | None = None
        self._pts0: float | None = None
        self._last_rel = -math.inf
        self._pending: tuple[float, np.ndarray] | None = None

    @property
    def live(self) -> bool:
        return False

    def _next_decoded(self) -> tuple[float, np.ndarray]:
        import av

        try:
            frame = next(self._frames)
        except StopIteration:
            raise StreamEnded(f"video {self.source} has no more frames") from None
        except av.FFmpegError as exc:
            raise DeviceError(f"cannot decode {self.source}: {exc}") from None
        if frame.pts is not None and self._time_base:
            stamp = frame.pts * self._time_base
        else:
            stamp = (self._last_rel if math.isfinite(self._last_rel) else -1) + 1.0 / (
                self.nominal_fps or 30.0
            )
        if self._pts0 is None:
            self._pts0 = stamp
        rel = (stamp - self._pts0) / self._speed
        self._last_rel = rel
        return rel, frame.to_ndarray(format="bgr24")

    def _read(self, timeout_s: float) -> tuple[float, np.ndarray]:
        with self._lock:
            if self._container is None:
                raise DeviceError(f"video {self.source} is closed")
            if self._pending is None:
                self._pending = self._next_decoded()
            rel, image = self._pending
            if self._t_start is None:
                self._t_start = time.monotonic() - rel
            due = self._t_start + rel
            wait = due - time.monotonic()
            if wait > timeout_s:
                time.sleep(timeout_s)
                raise DeviceError(
                    f"video {self.source}: no frame within {timeout_s:g} s (a gap in the file)"
                )
            if wait > 0:
                time.sleep(wait)
            self._pending = None
            return due, image

    def close(self) -> None:
        with self._lock:
            if self._container is not None:
                self._container.close()
                self._container = None


def open_camera(
    source: str | int | os.PathLike[str],
    *,
    profile: str | CameraProfile = "raw",
    warmup_frames: int | None = None,
    open_timeout_s: float = DEFAULT_OPEN_TIMEOUT_S,
    read_timeout_s: float = DEFAULT_READ_TIMEOUT_S,
    speed: float = 1.0,
) -> Camera:
    """Open a camera source (see the module docstring) with a sensor ``profile``.

    ``warmup_frames`` frames are read and discarded after opening, then any frames
    that were waiting in buffers (default :data:`DEFAULT_WARMUP_FRAMES` for a live
    camera or stream, 0 for a replayed file). ``open_timeout_s`` and
    ``read_timeout_s`` bound the waits of network streams [s]; ``speed`` is the
    replay speed of a video file. Raises :class:`DeviceError` if the source cannot
    be opened or delivers no frames.
    """
    prof = get_profile(profile)
    spec = parse_source(source)
    camera: Camera
    if spec.kind == "file":
        camera = FileCamera(str(spec.target), prof, speed=speed)
    else:
        camera = OpenCVCamera(
            spec, prof, open_timeout_s=open_timeout_s, read_timeout_s=read_timeout_s
        )
    if warmup_frames is None:
        warmup_frames = DEFAULT_WARMUP_FRAMES if camera.live else 0
    try:
        if warmup_frames or camera.live:
            camera.warm_up(warmup_frames)
    except BaseException:
        camera.close()
        raise
    return camera


# --- statistics -------------------------------------------------------------------------


@dataclass
class FrameStats:
    """Frame count, timing, drops and duplicates of one camera's frames so far.

    ``nominal_fps`` [Hz] sets the frame period for drop detection; without it the
    median interval of the frames so far is used.
    """

    nominal_fps: float | None = None
    frames: int = 0
    duplicates: int = 0
    first_t_s: float | None = None
    last_t_s: float | None = None
    _gaps: list[float] = field(default_factory=list, repr=False)
    _previous: np.ndarray | None = field(default=None, repr=False)

    def add(self, t_s: float, frame: np.ndarray) -> bool:
        """Count a frame; return whether it duplicates the previous frame."""
        duplicate = self._previous is not None and np.array_equal(self._previous, frame)
        self.duplicates += int(duplicate)
        if self.last_t_s is not None:
            self._gaps.append(t_s - self.last_t_s)
        if self.first_t_s is None:
            self.first_t_s = t_s
        self.last_t_s = t_s
        self.frames += 1
        self._previous = frame
        return duplicate

    @property
    def period_s(self) -> float | None:
        """The frame period [s]: 1 / nominal fps, else the median interval so far."""
        if self.nominal_fps:
            return 1.0 / self.nominal_fps
        if self._gaps:
            return float(np.median(self._gaps))
        return None

    @property
    def drops(self) -> int:
        """Frames missing from gaps over 1.5 frame periods (a gap of g periods: round(g) − 1)."""
        period = self.period_s
        if not period or not self._gaps:
            return 0
        gaps = np.asarray(self._gaps) / period
        long = gaps[gaps > DROP_GAP_PERIODS]
        return int(np.sum(np.maximum(np.rint(long) - 1, 1)))

    @property
    def measured_fps(self) -> float | None:
        """(frames − 1) / (last − first timestamp) [Hz]; ``None`` before two frames."""
        if self.frames < 2 or self.last_t_s is None or self.first_t_s is None:
            return None
        span = self.last_t_s - self.first_t_s
        return (self.frames - 1) / span if span > 0 else None

    def as_dict(self) -> dict[str, object]:
        return {
            "frames": self.frames,
            "measured_fps": self.measured_fps,
            "drops": self.drops,
            "duplicates": self.duplicates,
            "first_t_s": self.first_t_s,
            "last_t_s": self.last_t_s,
        }


# --- threads ----------------------------------------------------------------------------


@dataclass(frozen=True)
class Frame:
    """One captured frame: sensor ``name``, its ``index`` (0, 1, ...), ``t_s`` [s, monotonic]."""

    name: str
    index: int
    t_s: float
    image: np.ndarray
    duplicate: bool = False


class CameraThread(threading.Thread):
    """Reads one camera in a loop; hands each :class:`Frame` to ``sink`` (e.g. ``queue.put``).

    Until :meth:`keep` is called the thread reads a live camera and discards the
    frames (so no stale frames pile up in the driver's or FFmpeg's buffers); a
    replayed file is not read before then. Stops at :meth:`stop`, at the end of a
    finite source (``ended`` is then set) or on an error (kept in ``error``; the
    thread ends, the others go on). The camera's statistics are in ``stats``.
    ``sink`` is called on this thread and must not block for long (``queue.put``).
    """

    def __init__(
        self,
        camera: Camera,
        sink: Callable[[Frame], None],
        *,
        name: str = "sensor",
        read_timeout_s: float = DEFAULT_READ_TIMEOUT_S,
    ) -> None:
        super().__init__(name=f"camera-{name}", daemon=True)
        self.camera = camera
        self.sensor = name
        self.sink = sink
        self.read_timeout_s = read_timeout_s
        self.stats = FrameStats(nominal_fps=camera.nominal_fps)
        self.error: BaseException | None = None
        self.end_reason: StreamEnded | None = None
        """Set when the source ended by itself (a file's end, a stream closed by its server)."""
        self.ended = threading.Event()
        self.fresh = threading.Event()
        """Set once a read had to wait for its frame: frames buffered before are flushed."""
        self.keep_from_t_s = math.inf
        """Frames before this time [s] are read and discarded (primed, not recording)."""
        self.keep_until_t_s = math.inf
        """Frames after this time [s] end the thread (set by :meth:`CaptureSession.stop`)."""
        self._stop_event = threading.Event()

    def run(self) -> None:
        index = 0
        try:
            if not self.camera.live:  # a file: nothing to keep fresh, wait for the start
                self.fresh.set()
                while not self._stop_event.is_set() and not math.isfinite(self.keep_from_t_s):
                    self._stop_event.wait(0.005)
            quick_s = 0.25 / self.camera.nominal_fps if self.camera.nominal_fps else 0.005
            while not self._stop_event.is_set():
                before = time.monotonic()
                t_s, image = self.camera.read(self.read_timeout_s)
                if time.monotonic() - before >= quick_s:  # waited for it: no stale frames left
                    self.fresh.set()
                if self._stop_event.is_set() or t_s > self.keep_until_t_s:
                    break
                if t_s < self.keep_from_t_s:  # primed, not yet recording: keep buffers empty
                    continue
                duplicate = self.stats.add(t_s, image)
                self.sink(Frame(self.sensor, index, t_s, image, duplicate))
                index += 1
        except StreamEnded as exc:
            self.end_reason = exc
        except BaseException as exc:
            self.error = exc
        finally:
            self.ended.set()

    def keep(self, from_t_s: float) -> None:
        """Hand on the frames captured from ``from_t_s`` [s, monotonic] on; drop earlier ones."""
        self.keep_from_t_s = float(from_t_s)

    def stop(self) -> None:
        """Ask the thread to stop after the current read (it may take one read timeout)."""
        self._stop_event.set()


END = None
"""Put on a :class:`CaptureSession` queue after a camera's last frame."""


class CaptureSession:
    """Capture several cameras at once, each on its own :class:`CameraThread`, on one clock.

    ``queues[name]`` receives that sensor's :class:`Frame` objects in order, then
    :data:`END`. ``names`` default to ``left``, ``right``, ``sensor2``, ... . The
    cameras are closed by :meth:`close` (and on leaving the ``with`` block), not by
    :meth:`stop`.
    """

    def __init__(
        self,
        cameras: Sequence[Camera],
        names: Sequence[str] | None = None,
        *,
        read_timeout_s: float = DEFAULT_READ_TIMEOUT_S,
        maxsize: int = 0,
    ) -> None:
        if not cameras:
            raise DeviceError("a capture session needs at least one camera")
        self.cameras = list(cameras)
        self.names = list(names) if names is not None else default_names(len(cameras))
        if len(self.names) != len(self.cameras) or len(set(self.names)) != len(self.names):
            raise DeviceError(
                f"give one distinct name per camera: {len(self.cameras)} cameras, "
                f"names {self.names}"
            )
        self.queues: dict[str, queue.Queue] = {n: queue.Queue(maxsize) for n in self.names}
        self.threads = [
            CameraThread(cam, self.queues[n].put, name=n, read_timeout_s=read_timeout_s)
            for cam, n in zip(self.cameras, self.names, strict=True)
        ]
        self.start_t_s: float | None = None
        self.stop_t_s: float | None = None
        self._primed = False
        self._started = False
        self._stopped = False

    def prime(self) -> CaptureSession:
        """Start the camera threads without keeping frames: live cameras are read and their
        frames discarded until :meth:`start`, so that no stale frame is recorded."""
        if not self._primed:
            self._primed = True
            for thread in self.threads:
                thread.start()
        return self

    def start(self) -> CaptureSession:
        """Keep every frame captured from now on [s, monotonic: :attr:`start_t_s`] (once).

        First waits (at most :data:`MAX_WARMUP_S`) until every live camera's thread has
        read the frames that were waiting in buffers since it was opened."""
        if not self._started:
            self.prime()
            deadline = time.monotonic() + MAX_WARMUP_S
            for thread in self.threads:  # stale frames read before the start, not after it
                while not (thread.fresh.is_set() or thread.ended.is_set()):
                    if time.monotonic() > deadline:
                        break
                    thread.fresh.wait(0.01)
            self._started = True
            self.start_t_s = time.monotonic()
            for thread in self.threads:
                thread.keep(self.start_t_s)
        return self

    def stop(self, timeout_s: float = DEFAULT_READ_TIMEOUT_S + 1.0) -> None:
        """Stop the threads and wait for them; put :data:`END` on every queue.

        Frames captured after this call [s, monotonic: :attr:`stop_t_s`] are not kept.
        """
        if self._stopped or not self._primed:
            return
        self._stopped = True
        self.stop_t_s = time.monotonic()
        for thread in self.threads:
            thread.keep_until_t_s = self.stop_t_s
            thread.stop()
        for thread in self.threads:
            thread.join(timeout=timeout_s)
            if thread.is_alive():
                thread.error = thread.error or DeviceError(
                    f"camera {thread.sensor} did not stop within {timeout_s:g} s"
                )
        for name in self.names:
            self.queues[name].put(END)

    def close(self) -> None:
        """Stop, then release every camera."""
        self.stop()
        for camera in self.cameras:
            camera.close()

    @property
    def stats(self) -> dict[str, FrameStats]:
        return {t.sensor: t.stats for t in self.threads}

    @property
    def errors(self) -> dict[str, BaseException]:
        return {t.sensor: t.error for t in self.threads if t.error is not None}

    @property
    def all_ended(self) -> bool:
        """Whether every camera thread has finished (its source ended, or it failed)."""
        return all(t.ended.is_set() for t in self.threads)

    def __enter__(self) -> CaptureSession:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()


def default_names(n: int) -> list[str]:
    """``left``, ``right``, then ``sensor2``, ``sensor3``, ... for ``n`` sensors."""
    return [("left", "right")[i] if i < 2 else f"sensor{i}" for i in range(n)]
