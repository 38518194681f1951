"""Frame sources: a video file, a folder of images, or a live camera.

Every source yields ``(t_s, image)`` pairs: ``t_s`` is the frame's timestamp in
seconds (container presentation time for files, a monotonic clock for cameras)
and ``image`` a 2-D ``uint8`` grey image. Grey (luma) is what the marker
detector wants: the printed markers are dark on every LED colour, and for the
usual YUV codecs the luma plane is read straight out of the decoder, with no
colour conversion.

**Image folders** carry no clock of their own. Their frames are timed, in this
order, by a ``timestamps.csv`` in the folder (column ``t_s``, one row per image
in natural name order), or by a frame rate the caller gives (a trial's
``meta.json`` ``fps``, or ``extract --fps``); with neither, reading refuses
instead of guessing a rate.

**Videos** are timed by their container's presentation times, unless a
``<name>.timestamps.csv`` sidecar (what the recorder writes beside its FFV1
videos, to 1 µs where Matroska keeps 1 ms) gives one valid time per frame: then
the sidecar wins (:mod:`liquidtouch.io.frame_times`).

**Truncated videos**: a video whose decoding fails part-way, or that ends well
before the frame count or duration its container declares (a recording cut
short, a partial copy), raises :class:`VideoError` instead of silently giving
the frames decoded so far (a shortened decay biases the fit).
"""

from __future__ import annotations

import re
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from liquidtouch.errors import VideoError
from liquidtouch.io.frame_times import (
    folder_times,
    video_sidecar,
    video_sidecar_times,
)
from liquidtouch.io.image_size import check_frame_size, check_image_file

__all__ = [
    "IMAGE_SUFFIXES",
    "VIDEO_SUFFIXES",
    "VideoInfo",
    "count_frames",
    "image_files",
    "iter_camera",
    "iter_frames",
    "iter_image_folder",
    "iter_video",
    "read_frames",
    "video_info",
]

VIDEO_SUFFIXES = (".mp4", ".avi", ".mkv", ".mov")
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")
#: a video may end this many frames (or this fraction) short of its declared length
TRUNCATION_TOLERANCE_FRAMES = 2
TRUNCATION_TOLERANCE_FRACTION = 0.02


@dataclass(frozen=True)
class VideoInfo:
    """What a video file's container says about its video stream."""

    path: Path
    width: int
    height: int
    fps: float
    frames: int  # 0 when the container does not say
    codec: str = ""  # FFmpeg's codec name, e.g. "h264", "mpeg4", "mjpeg", "ffv1"


def _luma(frame) -> np.ndarray:
    """The grey image of a decoded PyAV frame, from the Y plane when there is one."""
    name = frame.format.name
    if name.startswith(("yuv", "yuvj", "nv12", "nv21")):
        plane = frame.planes[0]
        rows = np.frombuffer(plane, dtype=np.uint8).reshape(plane.height, plane.line_size)
        return rows[:, : plane.width].copy()
    return frame.to_ndarray(format="gray")


def video_info(path: str | Path) -> VideoInfo:
    """Size, nominal frame rate and frame count of a video file; :class:`VideoError` if unusable."""
    import av

    path = _existing_file(path)
    try:
        with av.open(str(path)) as container:
            if not container.streams.video:
                raise VideoError(f"{path} holds no video stream; give a GelSight video file")
            stream = container.streams.video[0]
            rate = stream.average_rate or stream.guessed_rate or 0
            _check_stream_size(path, stream)
            return VideoInfo(
                path=path,
                width=int(stream.codec_context.width),
                height=int(stream.codec_context.height),
                fps=float(rate),
                frames=int(stream.frames or 0),
                codec=str(stream.codec_context.name or ""),
            )
    except av.FFmpegError as exc:
        raise VideoError(f"cannot read video {path}: {exc}; is it a video file?") from None


def iter_video(path: str | Path) -> Iterator[tuple[float, np.ndarray]]:
    """Decode a video file; yield ``(t_s, grey_image)`` with container timestamps (PTS × time base).

    A ``<name>.timestamps.csv`` sidecar with one valid time per frame wins over
    the PTS (module docstring). Frames without a PTS get the previous timestamp
    plus the nominal frame interval. Raises :class:`VideoError` for a missing,
    unreadable or empty file, or a sidecar that does not fit the video.
    """
    import av

    path = _existing_file(path)
    sidecar = None
    if video_sidecar(path).is_file():
        sidecar = video_sidecar_times(path, count_frames(path))
    try:
        container = av.open(str(path))
    except av.FFmpegError as exc:
        raise VideoError(f"cannot read video {path}: {exc}; is it a video file?") from None
    with container:
        if not container.streams.video:
            raise VideoError(f"{path} holds no video stream; give a GelSight video file")
        stream = container.streams.video[0]
        _check_stream_size(path, stream)
        stream.thread_type = "AUTO"
        rate = float(stream.average_rate or stream.guessed_rate or 30.0)
        time_base = float(stream.time_base) if stream.time_base else 1.0 / rate
        declared_frames = int(stream.frames or 0)
        declared_s = _declared_duration_s(container, stream)
        t0: float | None = None
        previous = -1.0 / rate
        count = 0
        try:
            for frame in container.decode(stream):
                if sidecar is not None:
                    t_s = float(sidecar[min(count, len(sidecar) - 1)])
                elif frame.pts is None:
                    t_s = previous + 1.0 / rate
                else:
                    stamp = frame.pts * time_base
                    t0 = stamp if t0 is None else t0
                    t_s = stamp - t0
                previous = t_s
                count += 1
                yield t_s, _luma(frame)
        except av.FFmpegError as exc:
            if count == 0:
                raise VideoError(f"cannot decode video {path}: {exc}") from None
            raise VideoError(
                f"video {path} is damaged or cut short: decoding failed after {count} frames "
                f"({previous:.2f} s); re-export the recording, or remux the good part "
                "(e.g. ffmpeg -i IN -c copy OUT) to use it"
            ) from None
        if count == 0:
            raise VideoError(f"video {path} has no frames; record again or pick another file")
        _check_complete(path, count, previous, declared_frames, declared_s)


def _check_stream_size(path: Path, stream) -> None:
    """Refuse a video stream whose declared frame size is no sensor's, before decoding."""
    width, height = int(stream.codec_context.width), int(stream.codec_context.height)
    if width or height:  # 0 x 0: the container does not say; the decoder will
        check_frame_size(width, height, f"video {path}", VideoError)


def count_frames(path: str | Path) -> int:
    """How many frames the video stream of ``path`` holds (its packets; nothing decoded)."""
    import av

    try:
        with av.open(str(path)) as container:
            if not container.streams.video:
                return 0
            return sum(1 for p in container.demux(container.streams.video[0]) if p.size)
    except av.FFmpegError as exc:
        raise VideoError(f"cannot read video {path}: {exc}; is it a video file?") from None


def _declared_duration_s(container, stream) -> float:
    """The video stream's duration [s] its container declares (0 when it does not say)."""
    if stream.duration and stream.time_base:
        return float(stream.duration * stream.time_base)
    if container.duration:
        return float(container.duration) / 1e6  # AV_TIME_BASE (microseconds)
    return 0.0


def _check_complete(
    path: Path, count: int, last_s: float, declared_frames: int, declared_s: float
) -> None:
    """Raise :class:`VideoError` if a video ended far short of its declared length."""
    shortfall = max(TRUNCATION_TOLERANCE_FRAMES, TRUNCATION_TOLERANCE_FRACTION * declared_frames)
    if declared_frames and count < declared_frames - shortfall:
        raise VideoError(
            f"video {path} is cut short: {count} of the {declared_frames} frames its container "
            "declares could be decoded (a truncated file?); re-export the recording, or remux "
            "the good part (e.g. ffmpeg -i IN -c copy OUT) to use it"
        )
    if declared_frames or count < 2 or declared_s <= 0:
        return
    frame_s = last_s / (count - 1)
    missing_s = declared_s - (last_s + frame_s)
    if missing_s > max(
        TRUNCATION_TOLERANCE_FRAMES * frame_s, TRUNCATION_TOLERANCE_FRACTION * declared_s
    ):
        raise VideoError(
            f"video {path} is cut short: its frames end at {last_s + frame_s:.2f} s but its "
            f"container declares {declared_s:.2f} s (a truncated file?); re-export the "
            "recording, or remux the good part (e.g. ffmpeg -i IN -c copy OUT) to use it"
        )


def iter_image_folder(
    folder: str | Path, fps: float | None = None
) -> Iterator[tuple[float, np.ndarray]]:
    """Read a folder of images in natural name order; yield ``(t_s, grey_image)``.

    Timing: the folder's ``timestamps.csv`` if there is one
    (:func:`read_folder_timestamps`, shifted to start at 0), else frame ``k`` at
    ``t = k / fps``; with neither a :class:`VideoError` says to give one.
    """
    import cv2

    folder = Path(folder)
    files = image_files(folder)
    times = folder_times(folder, len(files), fps)
    shape = None
    for file, t_s in zip(files, times, strict=True):
        check_image_file(file, VideoError)  # before decoding: a header may claim gigapixels
        image = cv2.imread(str(file), cv2.IMREAD_GRAYSCALE)
        if image is None:
            raise VideoError(f"cannot read image {file}; is it a PNG/JPEG/BMP/TIFF image?")
        if shape is not None and image.shape != shape:
            raise VideoError(
                f"image {file} is {image.shape[1]}x{image.shape[0]} but the first image is "
                f"{shape[1]}x{shape[0]}; all frames of a folder must have one size"
            )
        shape = image.shape
        yield float(t_s), image


def image_files(folder: str | Path) -> list[Path]:
    """Image files of ``folder`` in natural order (``2.png`` before ``10.png``)."""
    folder = Path(folder)
    if not folder.is_dir():
        raise VideoError(f"{folder} is not a folder of images")
    files = [p for p in folder.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES and p.is_file()]
    if not files:
        raise VideoError(f"folder {folder} holds no images ({', '.join(IMAGE_SUFFIXES)})")

    def natural(p: Path) -> list[object]:
        return [int(s) if s.isdigit() else s for s in re.split(r"(\d+)", p.name)]

    return sorted(files, key=natural)


def iter_camera(
    index: int = 0, n_frames: int | None = None, duration_s: float | None = None
) -> Iterator[tuple[float, np.ndarray]]:
    """Grab frames from a live camera (OpenCV device ``index``) with monotonic timestamps.

    Stops after ``n_frames`` frames or ``duration_s`` seconds (whichever comes
    first; at least one must be given). Raises :class:`VideoError` when the
    device cannot be opened or stops delivering frames.
    """
    import cv2

    if n_frames is None and duration_s is None:
        raise VideoError("give n_frames or duration_s for a camera recording")
    capture = cv2.VideoCapture(int(index))
    try:
        if not capture.isOpened():
            raise VideoError(
                f"camera {index} could not be opened; is the GelSight plugged in "
                "and is the index right (try 0, 1, 2)?"
            )
        start = time.monotonic()
        count = 0
        while n_frames is None or count < n_frames:
            ok, image = capture.read()
            now = time.monotonic() - start
            if not ok or image is None:
                raise VideoError(f"camera {index} stopped delivering frames after {count}")
            if duration_s is not None and now > duration_s:
                break
            if image.ndim == 3:
                image = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
            count += 1
            yield now, image
    finally:
        capture.release()


def iter_frames(
    source: str | Path | int, fps: float | None = None
) -> Iterator[tuple[float, np.ndarray]]:
    """Frames of any source: a video file, an image folder, or a camera index (``int``).

    ``fps`` times an image folder without ``timestamps.csv`` (see :func:`iter_image_folder`).
    """
    if isinstance(source, int):
        return iter_camera(source, duration_s=10.0)
    path = Path(source)
    if path.is_dir():
        return iter_image_folder(path, fps=fps)
    return iter_video(path)


def read_frames(
    source: str | Path | int, fps: float | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """All frames of a source at once: ``(t_s (T,), images (T, H, W) uint8)``."""
    times, images = zip(*iter_frames(source, fps=fps), strict=True)
    return np.asarray(times, dtype=float), np.stack(images)


def _existing_file(path: str | Path) -> Path:
    path = Path(path)
    if not path.exists():
        raise VideoError(f"video {path} does not exist; check the path")
    if not path.is_file():
        raise VideoError(f"{path} is not a file; give a video file or a folder of images")
    if path.stat().st_size == 0:
        raise VideoError(f"video {path} is empty (0 bytes); record again or pick another file")
    return path
