"""Live GelSight cameras: open one by index, path, name or URL; read timed frames on threads.

**Sources** (:func:`open_camera`):

- ``"0"``: a V4L2 device index (``/dev/video0``);
- ``"/dev/video2"``: a device path;
- ``"name:GelSight Mini"``: the first (lowest-numbered) V4L2 device whose
  ``/sys/class/video4linux/video*/name`` contains that text (case-insensitive),
  the way the GelSight SDK finds its sensors (:data:`SYSFS_VIDEO4LINUX`); two
  sensors of one model share a name, so pick them apart by serial:
- ``"serial:2BJ7-4F8Q"``: the capture node whose ``/dev/v4l/by-id/`` link
  (``usb-<vendor>_<product>_<serial>-video-index0``) contains that text
  (:data:`V4L_BY_ID`), or such a link itself (``/dev/v4l/by-id/...``, any link
  to a ``/dev/videoN``);
- ``"http://..."``: an MJPEG stream (a GelSight R1.5 streams with mjpg-streamer:
  ``http://gsr1500x.local:8080/?action=stream``), read by
  :mod:`~liquidtouch.acquire.cameras.mjpeg` with open and read timeouts;
- ``"rtsp://..."`` (and other network URLs): through OpenCV's FFmpeg backend;
- a video file: replayed in real time at the pace of its own timestamps (for tests
  and rehearsals; it ends with :class:`StreamEnded`).

**One clock.** Every frame's ``t_s`` is on :func:`time.monotonic` [s], the same
clock for every sensor (and for the gripper and arm), so frames of several
cameras and other events can be compared directly. For an MJPEG stream whose
parts carry ``X-Timestamp`` (the sender's capture time) ``t_s`` is that time moved
onto this clock (network jitter stays out; see
:mod:`~liquidtouch.acquire.cameras.mjpeg`); for other network or USB cameras ``t_s``
is the moment the frame was grabbed (before decoding); for a V4L2 device
the driver's buffer timestamp is used when it is on that same clock (Linux
``CLOCK_MONOTONIC``, what UVC drivers use); a replayed file gives each frame the
moment it was due.

**Sensor profiles** (:data:`PROFILES`) set the camera mode and turn each frame into
the sensor's image: ``mini`` (a GelSight Mini: the camera gives MJPG 3280 × 2464 at
up to 25 fps; 1/7 of each border is cropped and the rest resized to 320 × 240, as
the GelSight SDK does), ``r15`` (640 × 480 at 30 fps), ``digit`` (320 × 240 at
60 fps) and ``raw`` (frames as the camera gives them).

**Nothing is hidden.** :class:`FrameStats` counts dropped frames (slots of the camera's
frame lattice without a frame, on the period fitted to every timestamp as ``extract``
fits it, :func:`~liquidtouch.tracking.clock.fit_frame_period`: frames delivered in
bursts are not drops) and duplicated frames (a frame identical to the one before,
which a sensor with noise never produces; a driver repeating its buffer does).
Duplicates are kept in the recording and counted.

**What is kept can be read back.** Each camera's frames are kept in time order,
at least :data:`MIN_FRAME_STEP_S` apart: a frame whose own clock (``X-Timestamp``,
a driver's timestamp) steps back or stands still is re-anchored on its arrival
time, counted in :attr:`Camera.reanchors` and logged as a warning. A camera whose
frame size changes mid-capture fails (:class:`DeviceError`): a sensor's frames have
one size, as ``extract`` requires.

**Deadlines** bound whole calls, not single network reads: opening a stream
(``open_timeout_s``), the warm-up (``warmup_timeout_s``) and every read
(``read_timeout_s``), each at most :data:`MAX_TIMEOUT_S`; the defaults are in
:mod:`liquidtouch.acquire.deadlines`.

:class:`CaptureSession` reads each camera on its own :class:`CameraThread` into a
queue, so a slow consumer never delays a camera's reads (and so its timestamps).

Two sources that are one camera (an index and a ``name:`` resolving to it, the same
URL twice) are refused (:func:`check_distinct_sources`).

Takes camera sources (strings); gives open :class:`Camera` objects, timed frames and
their statistics. The modules, by concept: :mod:`~.sources` (resolving and opening
sources), :mod:`~.profiles` (sensor profiles), :mod:`~.devices` (the :class:`Camera`
interface, OpenCV and file cameras), :mod:`~.mjpeg` (the MJPEG-over-HTTP client) and
:mod:`~.capture` (reader threads, capture sessions, statistics).
"""

from liquidtouch.acquire.cameras.capture import (
    END,
    CameraThread,
    CaptureSession,
    Frame,
    FrameStats,
    default_names,
)
from liquidtouch.acquire.cameras.devices import (
    DEFAULT_WARMUP_FRAMES,
    MAX_TIMEOUT_S,
    MIN_FRAME_STEP_S,
    Camera,
    FileCamera,
    OpenCVCamera,
    SourceSpec,
    StreamEnded,
    check_timeout,
)
from liquidtouch.acquire.cameras.mjpeg import MjpegCamera, MjpegStream, SenderClock
from liquidtouch.acquire.cameras.profiles import PROFILES, CameraProfile, get_profile
from liquidtouch.acquire.cameras.sources import (
    SYSFS_VIDEO4LINUX,
    V4L_BY_ID,
    check_distinct_sources,
    open_camera,
    parse_source,
    resolve_device_name,
    resolve_serial,
)

__all__ = [
    "DEFAULT_WARMUP_FRAMES",
    "END",
    "MAX_TIMEOUT_S",
    "MIN_FRAME_STEP_S",
    "PROFILES",
    "SYSFS_VIDEO4LINUX",
    "V4L_BY_ID",
    "Camera",
    "CameraProfile",
    "CameraThread",
    "CaptureSession",
    "FileCamera",
    "Frame",
    "FrameStats",
    "MjpegCamera",
    "MjpegStream",
    "OpenCVCamera",
    "SenderClock",
    "SourceSpec",
    "StreamEnded",
    "check_distinct_sources",
    "check_timeout",
    "default_names",
    "get_profile",
    "open_camera",
    "parse_source",
    "resolve_device_name",
    "resolve_serial",
]
