"""Frame sources: a video file, a folder of images, or a live camera.

Every source yields ``(t_s, image)`` pairs: ``t_s`` is the frame's timestamp in
seconds (container presentation time for files, a monotonic clock for cameras)
and ``image`` a 2-D ``uint8`` grey image. Grey (luma) is what the marker
detector wants: the printed markers are dark on every LED colour, and for the
usual YUV codecs the luma plane is read straight out of the decoder, with no
colour conversion.
"""

from __future__ import annotations

import re
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from liquidtouch.errors import VideoError

VIDEO_SUFFIXES = (".mp4", ".avi", ".mkv", ".mov")
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")


@dataclass(frozen=True)
class VideoInfo:
    """What a video file's container says about its video stream."""

    path: Path
    width: int
    height: int
    fps: float
    frames: int  # 0 when the container does not say


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
            return VideoInfo(
                path=path,
                width=int(stream.codec_context.width),
                height=int(stream.codec_context.height),
                fps=float(rate),
                frames=int(stream.frames or 0),
            )
    except av.FFmpegError as exc:
        raise VideoError(f"cannot read video {path}: {exc}; is it a video file?") from None


def iter_video(path: str | Path) -> Iterator[tuple[float, np.ndarray]]:
    """Decode a video file; yield ``(t_s, grey_image)`` with container timestamps (PTS × time base).

    Frames without a PTS get the previous timestamp plus the nominal frame
    interval. Raises :class:`VideoError` for a missing, unreadable or empty file.
    """
    import av

    path = _existing_file(path)
    try:
        container = av.open(str(path))
    except av.FFmpegError as exc:
        raise VideoError(f"cannot read video {path}: {exc}; is it a video file?") from None
    with container:
        if not container.streams.video:
            raise VideoError(f"{path} holds no video stream; give a GelSight video file")
        stream = container.streams.video[0]
        stream.thread_type = "AUTO"
        rate = float(stream.average_rate or stream.guessed_rate or 30.0)
        time_base = float(stream.time_base) if stream.time_base else 1.0 / rate
        t0: float | None = None
        previous = -1.0 / rate
        count = 0
        try:
            for frame in container.decode(stream):
                if frame.pts is None:
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
            # A truncated tail (recording cut short) keeps the frames decoded so far.
        if count == 0:
            raise VideoError(f"video {path} has no frames; record again or pick another file")


def iter_image_folder(folder: str | Path, fps: float = 30.0) -> Iterator[tuple[float, np.ndarray]]:
    """Read a folder of images in natural name order; frame ``k`` gets ``t = k / fps``."""
    import cv2

    folder = Path(folder)
    files = image_files(folder)
    if fps <= 0 or not np.isfinite(fps):
        raise VideoError(f"frame rate must be positive, got {fps}")
    shape = None
    for k, file in enumerate(files):
        image = cv2.imread(str(file), cv2.IMREAD_GRAYSCALE)
        if image is None:
            raise VideoError(f"cannot read image {file}; is it a PNG/JPEG/BMP/TIFF image?")
        if shape is not None and image.shape != shape:
            raise VideoError(
                f"image {file} is {image.shape[1]}x{image.shape[0]} but the first image is "
                f"{shape[1]}x{shape[0]}; all frames of a folder must have one size"
            )
        shape = image.shape
        yield k / fps, image


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


def iter_frames(source: str | Path | int, fps: float = 30.0) -> Iterator[tuple[float, np.ndarray]]:
    """Frames of any source: a video file, an image folder, or a camera index (``int``)."""
    if isinstance(source, int):
        return iter_camera(source, duration_s=10.0)
    path = Path(source)
    if path.is_dir():
        return iter_image_folder(path, fps=fps)
    return iter_video(path)


def read_frames(source: str | Path | int, fps: float = 30.0) -> tuple[np.ndarray, np.ndarray]:
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
