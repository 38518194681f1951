"""Live GelSight cameras: open one by index, path, name or URL; read timed frames on threads.

**Sources** (:func:`open_camera`):

- ``"0"``: a V4L2 device index (``/dev/video0``);
- ``"/dev/video2"``: a device path;
- ``"name:GelSight Mini"``: the first (lowest-numbered) V4L2 device whose
  ``/sys/class/video4linux/video*/name`` contains that text (case-insensitive),
  the way the GelSight SDK finds its sensors (:data:`SYSFS_VIDEO4LINUX`);
- ``"http://..."``: an MJPEG stream (a GelSight R1.5 streams with mjpg-streamer:
  ``http://gsr1500x.local:8080/?action=stream``), read by
  :mod:`~liquidtouch.acquire.mjpeg_client` with open and read timeouts;
- ``"rtsp://..."`` (and other network URLs): through OpenCV's FFmpeg backend;
- a video file: replayed in real time at the pace of its own timestamps (for tests
  and rehearsals; it ends with :class:`StreamEnded`).

**One clock.** Every frame's ``t_s`` is on :func:`time.monotonic` [s], the same
clock for every sensor (and for the gripper and arm), so frames of several
cameras and other events can be compared directly. For an MJPEG stream whose
parts carry ``X-Timestamp`` (the sender's capture time) ``t_s`` is that time moved
onto this clock (network jitter stays out; see
:mod:`~liquidtouch.acquire.mjpeg_client`); for other network or USB cameras ``t_s``
is the moment the frame was grabbed (before decoding); for a V4L2 device
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

This module resolves sources and opens cameras; the parts live in
:mod:`~liquidtouch.acquire.camera_profiles`, :mod:`~liquidtouch.acquire.camera_devices`
and :mod:`~liquidtouch.acquire.capture`, and are re-exported here.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path

from liquidtouch.acquire.camera_devices import (
    DEFAULT_OPEN_TIMEOUT_S,
    DEFAULT_READ_TIMEOUT_S,
    DEFAULT_WARMUP_FRAMES,
    DROP_GAP_PERIODS,
    MAX_WARMUP_S,
    Camera,
    FileCamera,
    OpenCVCamera,
    StreamEnded,
)
from liquidtouch.acquire.camera_profiles import PROFILES, CameraProfile, get_profile
from liquidtouch.acquire.capture import (
    END,
    CameraThread,
    CaptureSession,
    Frame,
    FrameStats,
    default_names,
)
from liquidtouch.acquire.mjpeg_client import MjpegCamera
from liquidtouch.errors import DeviceError

__all__ = [
    "DEFAULT_OPEN_TIMEOUT_S",
    "DEFAULT_READ_TIMEOUT_S",
    "DEFAULT_WARMUP_FRAMES",
    "DROP_GAP_PERIODS",
    "END",
    "MAX_WARMUP_S",
    "PROFILES",
    "SYSFS_VIDEO4LINUX",
    "Camera",
    "CameraProfile",
    "CameraThread",
    "CaptureSession",
    "FileCamera",
    "Frame",
    "FrameStats",
    "MjpegCamera",
    "OpenCVCamera",
    "SourceSpec",
    "StreamEnded",
    "default_names",
    "get_profile",
    "open_camera",
    "parse_source",
    "resolve_device_name",
]

SYSFS_VIDEO4LINUX = Path("/sys/class/video4linux")
"""Where V4L2 devices list their names (patched by tests to a fake tree)."""


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
    elif spec.kind == "url" and str(spec.target).lower().startswith(("http://", "https://")):
        camera = MjpegCamera(
            str(spec.target), prof, open_timeout_s=open_timeout_s, read_timeout_s=read_timeout_s
        )
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
