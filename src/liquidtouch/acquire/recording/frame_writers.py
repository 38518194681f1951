"""The recorder's per-sensor frame writers: FFV1 in Matroska, or PNG folders, with timestamps.

Used by :class:`liquidtouch.acquire.recording.Recorder` (see its module docstring).
"""

from __future__ import annotations

import csv
import io
from fractions import Fraction
from pathlib import Path

import numpy as np

from liquidtouch.acquire.cameras import MIN_FRAME_STEP_S, Frame
from liquidtouch.errors import DeviceError, OutputError
from liquidtouch.io.frame_times import TIMESTAMPS_NAME, VIDEO_TIMESTAMPS_SUFFIX

__all__ = [
    "FFV1_OPTIONS",
    "PNG_COMPRESSION",
    "PTS_RATE_HZ",
    "VIDEO_SUFFIX",
    "Ffv1Writer",
    "FrameWriter",
    "PngWriter",
]

VIDEO_SUFFIX = ".mkv"
PTS_RATE_HZ = 1_000_000
"""Time base of the FFV1 encoder's PTS (µs); Matroska stores them to 1 ms."""
FFV1_OPTIONS = {"level": "3", "g": "1", "slicecrc": "1"}
"""FFV1 version 3, every frame a keyframe, a CRC per slice (damage is detected on decoding)."""
PNG_COMPRESSION = 1
"""zlib level of PNG frames (1: fast, within ~5 % of the best size for camera images)."""


class FrameWriter:
    """Encodes one sensor's frames into ``directory`` and keeps their timestamps."""

    def __init__(self, directory: Path, name: str, t0_s: float) -> None:
        self.directory = directory
        self.name = name
        self.t0_s = t0_s
        self.times: list[float] = []
        self.duplicates: list[bool] = []
        self._shape: tuple[int, ...] | None = None

    @property
    def entry(self) -> str:
        raise NotImplementedError

    def write(self, frame: Frame, image: np.ndarray) -> None:
        """Encode one frame, after the checks ``extract`` applies when reading it back:
        times increasing by at least :data:`MIN_FRAME_STEP_S` [s], one frame size."""
        if self.times and frame.t_s < self.times[-1] + MIN_FRAME_STEP_S:
            raise DeviceError(
                f"sensor {self.name}: frame {len(self.times)} is timed {frame.t_s:.6f} s, not "
                f"after the frame before ({self.times[-1]:.6f} s)"
            )
        if self._shape is None:
            self._shape = image.shape
        elif image.shape != self._shape:
            raise DeviceError(
                f"sensor {self.name}: frame {len(self.times)} is {image.shape[1]}x"
                f"{image.shape[0]}, the first was {self._shape[1]}x{self._shape[0]}; a "
                "recording keeps one frame size per sensor"
            )
        self._encode(image, len(self.times), frame.t_s)
        self.times.append(frame.t_s)
        self.duplicates.append(frame.duplicate)

    def _encode(self, image: np.ndarray, index: int, t_s: float) -> None:
        raise NotImplementedError

    def close(self) -> None:
        """Flush the encoder and write the timestamps file."""

    def discard(self) -> None:
        """Close any open output without flushing it (the recording is being aborted)."""

    def timestamps_csv(self) -> str:
        buffer = io.StringIO()
        writer = csv.writer(buffer, lineterminator="\n")
        writer.writerow(["frame", "t_s", "duplicate"])
        for i, (t, dup) in enumerate(zip(self.times, self.duplicates, strict=True)):
            writer.writerow([i, f"{t:.6f}", int(dup)])
        return buffer.getvalue()


class Ffv1Writer(FrameWriter):
    """FFV1 (lossless) in Matroska; each frame's PTS is its time since the sensor's first frame."""

    def __init__(self, directory: Path, name: str, t0_s: float, *, threads: int = 1) -> None:
        super().__init__(directory, name, t0_s)
        self.path = directory / f"{name}{VIDEO_SUFFIX}"
        self.threads = threads
        self._container = None
        self._stream = None
        self._last_pts = -1
        self.fps_hint = 30.0  # the stream's nominal rate (Matroska header only)

    @property
    def entry(self) -> str:
        return self.path.name

    def _open(self, image: np.ndarray, fps: float) -> None:
        import av  # why: PyAV is heavy; imported when recording starts

        self._container = av.open(str(self.path), mode="w", format="matroska")
        stream = self._container.add_stream("ffv1", rate=Fraction(fps).limit_denominator(1000))
        stream.height, stream.width = image.shape[:2]
        stream.pix_fmt = "gray" if image.ndim == 2 else "bgr0"
        stream.codec_context.time_base = Fraction(1, PTS_RATE_HZ)
        stream.codec_context.thread_count = self.threads
        stream.options = dict(FFV1_OPTIONS)
        self._stream = stream

    def _encode(self, image: np.ndarray, index: int, t_s: float) -> None:
        import av  # why: PyAV is heavy; imported when recording starts

        if self._container is None:
            self._open(image, self.fps_hint)
        if not self.times:
            self.t0_s = t_s  # PTS 0 at the sensor's first frame (absolute: sensor_start_s)
        pts = max(self._last_pts + 1, round((t_s - self.t0_s) * PTS_RATE_HZ))
        self._last_pts = pts
        frame = av.VideoFrame.from_ndarray(image, format="gray" if image.ndim == 2 else "bgr24")
        frame.pts = pts
        frame.time_base = Fraction(1, PTS_RATE_HZ)
        for packet in self._stream.encode(frame):
            self._container.mux(packet)

    def close(self) -> None:
        if self._container is not None:
            try:
                for packet in self._stream.encode():
                    self._container.mux(packet)
            finally:
                self._container.close()
                self._container = None
        (self.directory / f"{self.name}{VIDEO_TIMESTAMPS_SUFFIX}").write_text(
            self.timestamps_csv(), encoding="utf-8"
        )

    def discard(self) -> None:
        if self._container is not None:
            self._container.close()
            self._container = None


class PngWriter(FrameWriter):
    """A folder of PNG images ``000000.png``, ... with ``timestamps.csv`` (absolute t_s)."""

    def __init__(self, directory: Path, name: str, t0_s: float) -> None:
        super().__init__(directory, name, t0_s)
        self.folder = directory / name
        self.folder.mkdir()

    @property
    def entry(self) -> str:
        return self.folder.name

    def _encode(self, image: np.ndarray, index: int, t_s: float) -> None:
        import cv2  # why: OpenCV is heavy; imported when recording starts

        path = self.folder / f"{index:06d}.png"
        if not cv2.imwrite(str(path), image, [int(cv2.IMWRITE_PNG_COMPRESSION), PNG_COMPRESSION]):
            raise OutputError(f"cannot write {path} (disk full or not writable?)")

    def close(self) -> None:
        (self.folder / TIMESTAMPS_NAME).write_text(self.timestamps_csv(), encoding="utf-8")
