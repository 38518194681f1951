"""Camera sources: resolve a source string (index, path, ``name:``, URL, file) and open it.

Part of :mod:`liquidtouch.acquire.cameras` (see its docstring for the sources).
"""

from __future__ import annotations

import logging
import os
import re
from pathlib import Path

from liquidtouch.acquire.cameras.devices import (
    DEFAULT_WARMUP_FRAMES,
    Camera,
    FileCamera,
    OpenCVCamera,
    SourceSpec,
    check_timeout,
)
from liquidtouch.acquire.cameras.mjpeg import MjpegCamera
from liquidtouch.acquire.cameras.profiles import CameraProfile, get_profile
from liquidtouch.acquire.deadlines import (
    DEFAULT_OPEN_TIMEOUT_S,
    DEFAULT_READ_TIMEOUT_S,
    DEFAULT_WARMUP_TIMEOUT_S,
)
from liquidtouch.errors import DeviceError

logger = logging.getLogger(__name__)

__all__ = [
    "SYSFS_VIDEO4LINUX",
    "V4L_BY_ID",
    "check_distinct_sources",
    "open_camera",
    "parse_source",
    "resolve_device_name",
    "resolve_serial",
]

SYSFS_VIDEO4LINUX = Path("/sys/class/video4linux")
"""Where V4L2 devices list their names (patched by tests to a fake tree)."""
V4L_BY_ID = Path("/dev/v4l/by-id")
"""udev's stable links to V4L2 devices, named after the USB device and its serial
(``usb-<vendor>_<product>_<serial>-video-index0``; patched by tests)."""


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
            logger.info("camera name %r is /dev/video%d (%s)", name, index, label)
            return index
    listing = ", ".join(f"video{i} ({label})" for i, label in found) or "no video devices"
    raise DeviceError(
        f"no camera named {name!r} in {SYSFS_VIDEO4LINUX}: found {listing}; is the sensor "
        "plugged in (try `v4l2-ctl --list-devices`)?"
    )


def resolve_serial(serial: str) -> int:
    """The V4L2 index of the capture node (``video-index0``) whose :data:`V4L_BY_ID` link
    name contains ``serial`` (case-insensitive); :class:`DeviceError` listing the links
    when none or several devices match."""
    wanted = serial.strip().lower()
    if not wanted:
        raise DeviceError("give a serial number after 'serial:', e.g. serial:2BJ7-4F8Q")
    try:
        links = sorted(p for p in V4L_BY_ID.iterdir() if p.name.endswith("-video-index0"))
    except OSError:
        links = []
    matches = [link for link in links if wanted in link.name.lower()]
    if len(matches) != 1:
        listing = ", ".join(link.name for link in links) or f"no {V4L_BY_ID} links"
        what = "no camera" if not matches else f"{len(matches)} cameras"
        raise DeviceError(
            f"{what} with serial {serial[:40]!r} in {V4L_BY_ID}: found {listing}; give more "
            "of the serial (see `ls -l /dev/v4l/by-id/`)"
        )
    return _device_index(matches[0], f"serial:{serial}")


def _device_index(path: Path, text: str) -> int:
    """The index N of the /dev/videoN that ``path`` (a device node or a link to one) is."""
    real = os.path.realpath(path)
    match = re.fullmatch(r"video(\d+)", os.path.basename(real))
    if match is None:
        raise DeviceError(f"camera source {text[:80]!r} is {real[:80]}, not a /dev/videoN device")
    return int(match.group(1))


def parse_source(source: str | int | os.PathLike[str]) -> SourceSpec:
    """Classify a source string (see the module docstring); resolve ``name:``,
    ``serial:`` and links such as ``/dev/v4l/by-id/...`` to a device index."""
    text = str(source).strip()
    if not text:
        raise DeviceError("empty camera source; give an index, /dev/videoN, name:..., a URL")
    if re.fullmatch(r"\d+", text):
        return SourceSpec("device", int(text), text)
    if text.lower().startswith("name:"):
        return SourceSpec("device", resolve_device_name(text[5:]), text)
    if text.lower().startswith("serial:"):
        return SourceSpec("device", resolve_serial(text[7:]), text)
    match = re.fullmatch(r"/dev/video(\d+)", text)
    if match:
        return SourceSpec("device", int(match.group(1)), text)
    if text.startswith("/dev/") and Path(text).is_symlink():  # /dev/v4l/by-id/..., by-path
        return SourceSpec("device", _device_index(Path(text), text), text)
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


def check_distinct_sources(sources: list[str]) -> list[SourceSpec]:
    """Parse every source; :class:`DeviceError` when two of them are the same camera (a
    device index, a ``name:`` or ``serial:`` resolving to it, a link to it; the same URL or
    file): one device opened twice would give every frame to one of them."""
    specs = [parse_source(source) for source in sources]
    seen: dict[object, SourceSpec] = {}
    for spec in specs:
        key: object = (spec.kind, spec.target)
        if spec.kind == "file":
            key = ("file", os.path.realpath(str(spec.target)))
        if key in seen:
            what = f"/dev/video{spec.target}" if spec.kind == "device" else str(spec.target)
            raise DeviceError(
                f"camera sources {seen[key].text[:80]!r} and {spec.text[:80]!r} are the same "
                f"camera ({what[:80]}); give each sensor's camera once (name: matches the "
                "first device with that name: pick each by serial:... or /dev/v4l/by-id/...)"
            )
        seen[key] = spec
    return specs


def open_camera(
    source: str | int | os.PathLike[str],
    *,
    profile: str | CameraProfile = "raw",
    warmup_frames: int | None = None,
    open_timeout_s: float = DEFAULT_OPEN_TIMEOUT_S,
    read_timeout_s: float = DEFAULT_READ_TIMEOUT_S,
    warmup_timeout_s: float = DEFAULT_WARMUP_TIMEOUT_S,
    speed: float = 1.0,
) -> Camera:
    """Open a camera source (see the module docstring) with a sensor ``profile``.

    ``warmup_frames`` frames are read and discarded after opening, then any frames
    that were waiting in buffers (default :data:`DEFAULT_WARMUP_FRAMES` for a live
    camera or stream, 0 for a replayed file). Deadlines for whole calls [s]:
    ``open_timeout_s`` opening a network stream, ``warmup_timeout_s`` the whole
    warm-up, ``read_timeout_s`` each frame later on. ``speed`` is the replay speed
    of a video file. Raises :class:`DeviceError` if the source cannot be opened or
    delivers no frames in time.
    """
    open_timeout_s = check_timeout(open_timeout_s, "the camera open timeout")
    read_timeout_s = check_timeout(read_timeout_s, "the camera read timeout")
    warmup_timeout_s = check_timeout(warmup_timeout_s, "the camera warm-up timeout")
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
            discarded = camera.warm_up(warmup_frames, warmup_timeout_s)
            logger.debug("camera %s: %d warm-up frames discarded", spec.text, discarded)
    except BaseException:
        camera.close()
        raise
    logger.info("opened camera %r (profile %s, %s fps)", camera, prof.name, camera.nominal_fps)
    return camera
