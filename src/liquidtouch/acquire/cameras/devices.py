"""Open cameras: the :class:`Camera` interface, V4L2/network (OpenCV) and replayed files.

Part of :mod:`liquidtouch.acquire.cameras` (see its docstring for sources and clocks).
"""

from __future__ import annotations

import logging
import math
import os
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from liquidtouch._core.checks import MIN_TIME_STEP_S
from liquidtouch.acquire.cameras.profiles import CameraProfile
from liquidtouch.acquire.deadlines import (
    DEFAULT_OPEN_TIMEOUT_S,
    DEFAULT_READ_TIMEOUT_S,
    DEFAULT_WARMUP_TIMEOUT_S,
)
from liquidtouch.errors import DeviceError
from liquidtouch.io.image_size import check_frame_size

logger = logging.getLogger(__name__)

DEFAULT_WARMUP_FRAMES = 10
"""Frames read and thrown away after opening a live camera (auto-exposure, stale buffers)."""
MAX_TIMEOUT_S = 600.0
"""Largest open, read or warm-up timeout accepted [s]."""
MIN_FRAME_STEP_S = MIN_TIME_STEP_S
"""Consecutive frames of one camera must be at least this far apart [s] (what every
reader of frame times takes, ``_core.checks``): a frame whose clock steps back or stands
still is re-anchored."""


def check_timeout(value: float, what: str) -> float:
    """``value`` [s] as a float in (0, :data:`MAX_TIMEOUT_S`]; :class:`DeviceError` otherwise."""
    try:
        seconds = float(value)
    except (TypeError, ValueError):
        seconds = math.nan
    if not 0 < seconds <= MAX_TIMEOUT_S:
        raise DeviceError(
            f"{what} must be a number of seconds in (0, {MAX_TIMEOUT_S:g}], got {str(value)[:40]}"
        )
    return seconds


class StreamEnded(DeviceError):
    """A finite source (a replayed video file, a closed stream) has no more frames."""


@dataclass(frozen=True)
class SourceSpec:
    """A parsed camera source: ``kind`` is ``device``, ``url`` or ``file``."""

    kind: str
    target: int | str
    text: str


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
    read_timeout_s: float = DEFAULT_READ_TIMEOUT_S
    """The whole-call deadline of one read [s] (warm-up and capture threads use it)."""
    reanchors: int = 0
    """Frames whose own clock stepped back or stood still, timed on arrival instead."""

    def read(self, timeout_s: float = DEFAULT_READ_TIMEOUT_S) -> tuple[float, np.ndarray]:
        """The next frame; :class:`DeviceError` when none comes within ``timeout_s`` seconds,
        :class:`StreamEnded` at the end of a finite source."""
        t_s, frame = self._read(timeout_s)
        height, width = frame.shape[:2]  # decoded by now (MJPEG parts are checked before)
        check_frame_size(
            width, height, f"camera {self.source}: a frame", DeviceError, self.profile.max_pixels
        )
        return t_s, self.profile.apply(frame)

    def _read(self, timeout_s: float) -> tuple[float, np.ndarray]:
        raise NotImplementedError

    def close(self) -> None:
        """Release the device or file (idempotent)."""

    @property
    def live(self) -> bool:
        """Whether frames come at the source's own pace (a camera or stream, not a file)."""
        return True

    def warm_up(self, frames: int, timeout_s: float = DEFAULT_WARMUP_TIMEOUT_S) -> int:
        """Read and discard ``frames`` frames, then any stale frames buffered before now.

        A frame counts as stale when it arrived less than a quarter of a frame period
        after the previous one (it was waiting in a buffer). Returns how many frames
        were discarded. The whole warm-up has ``timeout_s`` [s]: the first frame may
        take all of it (a camera starting up), every later one at most
        :attr:`read_timeout_s`; the ``frames`` frames not read by then raise
        :class:`DeviceError`, the search for stale frames just ends.
        """
        deadline = time.monotonic() + float(timeout_s)
        wanted = max(0, int(frames))
        discarded = 0

        def read_one() -> float:
            """Read a frame within what is left of the warm-up; return how long it took."""
            before = time.monotonic()
            remaining = deadline - before
            limited = remaining if discarded == 0 else min(self.read_timeout_s, remaining)
            try:
                if remaining <= 0:
                    raise DeviceError("no time left")
                self.read(limited)
            except StreamEnded:
                raise
            except DeviceError:
                if limited < remaining or discarded >= wanted:
                    raise  # the read's own deadline, or the search for stale frames
                raise DeviceError(
                    f"camera {self.source} delivered {discarded} of {wanted} warm-up frames "
                    f"within {timeout_s:g} s; is it streaming (or give a longer warm-up "
                    "timeout)?"
                ) from None
            return time.monotonic() - before

        for _ in range(wanted):
            read_one()
            discarded += 1
        if not self.live or not self.nominal_fps:
            return discarded
        quick = 0.25 / self.nominal_fps
        while deadline - time.monotonic() > 0:
            try:
                took = read_one()
            except DeviceError:
                if discarded > 0 and time.monotonic() >= deadline:
                    break  # out of time while looking for stale frames: none are left
                raise
            discarded += 1
            if took >= quick:
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
        import cv2  # why: OpenCV is heavy; imported when a camera is opened

        self.source = spec.text
        self.profile = profile
        self.read_timeout_s = float(read_timeout_s)
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
        import cv2  # why: OpenCV is heavy; imported when a camera is opened

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
            logger.debug("camera %s: no frame (grabbed=%s)", self.source, grabbed)
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
        import cv2  # why: OpenCV is heavy; imported when a camera is opened

        stamp = float(self._capture.get(cv2.CAP_PROP_POS_MSEC) or 0.0) / 1000.0
        plausible = 0.0 <= grabbed_at - stamp < 1.0  # captured before we got it, not long ago
        if self._device_clock is None:
            self._device_clock = plausible
            logger.info(
                "camera %s: %s",
                self.source,
                "driver timestamps on the monotonic clock"
                if plausible
                else "stamped when grabbed (the driver's timestamps are on another clock)",
            )
        return stamp if self._device_clock and plausible else grabbed_at

    def close(self) -> None:
        with self._lock:
            if self._capture is not None:
                self._capture.release()
                self._capture = None


def _quiet_capture(target: int | str, backend: int, params: list[int]):
    """``cv2.VideoCapture(target, backend, params)`` without OpenCV's warnings on stderr
    (a failure becomes one :class:`DeviceError` instead)."""
    import cv2  # why: OpenCV is heavy; imported when a camera is opened

    if backend == cv2.CAP_FFMPEG:  # FFmpeg's own messages ("Connection refused"): quiet
        os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")
    cv_log = getattr(getattr(cv2, "utils", None), "logging", None)
    previous = cv_log.getLogLevel() if cv_log else None
    try:
        if cv_log:
            cv_log.setLogLevel(cv_log.LOG_LEVEL_ERROR)
        return cv2.VideoCapture(target, backend, params)
    finally:
        if cv_log and previous is not None:
            cv_log.setLogLevel(previous)


class FileCamera(Camera):
    """A video file replayed in real time: frame k is returned when it is due.

    Frame k is due at ``t_start + (pts_k − pts_0) / speed`` (``t_start``: the time
    of the first read), and that due time is its ``t_s``, so the replay reproduces
    the file's own timing (jitter and drops included) on the monotonic clock.
    """

    def __init__(self, path: str, profile: CameraProfile, *, speed: float = 1.0) -> None:
        import av  # why: PyAV is heavy; imported when a video is replayed

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
        import av  # why: PyAV is heavy; imported when a video is replayed

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
                logger.info("video %s: a gap of %.3f s in the file", self.source, wait)
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
