"""The recorder's encoders: one writer thread per sensor, with a bounded backlog.

Used by :class:`liquidtouch.acquire.recording.Recorder` (see its module docstring).
Each sensor's frames go from its capture thread into a queue that a writer thread
drains into a :class:`~liquidtouch.acquire.recording.frame_writers.FrameWriter`; frames beyond
:data:`MAX_BACKLOG_S` of video waiting for an encoder are dropped and counted.
"""

from __future__ import annotations

import logging
import math
import queue
import threading
import time
from pathlib import Path

from liquidtouch.acquire.cameras import END, Camera, CaptureSession, Frame
from liquidtouch.acquire.recording.frame_writers import Ffv1Writer, FrameWriter, PngWriter
from liquidtouch.errors import OutputError

__all__ = ["MAX_BACKLOG_S", "WRITER_FINISH_S", "WriterPool"]

logger = logging.getLogger(__name__)

MAX_BACKLOG_S = 10.0
"""Frames waiting for an encoder beyond this many seconds of video are dropped and counted."""
WRITER_FINISH_S = 120.0
"""How long :meth:`Recorder.stop` waits for the encoders to catch up [s]."""


class WriterPool:
    """Writers, writer threads, their errors and backlog drops, for every sensor."""

    def __init__(self, names: list[str], *, grey: bool, tap=None) -> None:
        self.grey = grey
        #: ``tap(sensor, frame)`` for each frame captured (e.g. the live estimate); must not block
        self.tap = tap
        self.writers: dict[str, FrameWriter] = {}
        self.threads: list[threading.Thread] = []
        self.errors: dict[str, BaseException] = {}
        self.backlog_drops: dict[str, int] = dict.fromkeys(names, 0)

    def start(
        self,
        session: CaptureSession,
        cameras: list[Camera],
        names: list[str],
        tmp: Path,
        fmt: str,
        t0: float,
    ) -> None:
        """Make each sensor's writer, bound its backlog and start its writer thread."""
        for camera, name in zip(cameras, names, strict=True):
            writer = Ffv1Writer(tmp, name, t0) if fmt == "ffv1" else PngWriter(tmp, name, t0)
            if isinstance(writer, Ffv1Writer):
                writer.fps_hint = camera.nominal_fps or 30.0
            self.writers[name] = writer
            limit = max(30, math.ceil(MAX_BACKLOG_S * (camera.nominal_fps or 60.0)))
            self._install_backlog_limit(session, name, limit)
            thread = threading.Thread(
                target=self._drain, args=(session, name), name=f"writer-{name}", daemon=True
            )
            self.threads.append(thread)
            thread.start()

    def _install_backlog_limit(self, session: CaptureSession, name: str, limit: int) -> None:
        target = session.queues[name]
        thread = next(t for t in session.threads if t.sensor == name)

        def sink(frame: Frame, target: queue.Queue = target) -> None:
            if self.tap is not None:
                try:
                    self.tap(name, frame)
                except Exception as exc:  # the recording matters more than a viewer
                    logger.warning("sensor %s: the frame tap failed: %s", name, exc)
                    self.tap = None
            if target.qsize() >= limit:
                self.backlog_drops[name] += 1
                logger.log(
                    logging.INFO if self.backlog_drops[name] == 1 else logging.DEBUG,
                    "sensor %s: the encoder is %d frames behind; frame dropped (%d so far)",
                    name,
                    limit,
                    self.backlog_drops[name],
                )
                return
            target.put(frame)

        thread.sink = sink

    def _drain(self, session: CaptureSession, name: str) -> None:
        """Writer thread: encode the sensor's frames until END (errors kept, frames drained)."""
        import cv2  # why: OpenCV is heavy; imported when recording starts

        source, writer = session.queues[name], self.writers[name]
        failed = False
        while True:
            frame = source.get()
            if frame is END:
                return
            if failed:
                continue
            try:
                image = frame.image
                if self.grey and image.ndim == 3:
                    image = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
                writer.write(frame, image)
            except BaseException as exc:
                logger.info("sensor %s: cannot encode frame %d: %s", name, frame.index, exc)
                self.errors[name] = exc
                failed = True

    def join(self) -> None:
        """Wait for the writer threads (at most :data:`WRITER_FINISH_S` in all); a thread
        still encoding then is an error."""
        deadline = time.monotonic() + WRITER_FINISH_S
        for thread in self.threads:  # the queues hold at most MAX_BACKLOG_S of frames
            thread.join(timeout=max(0.0, deadline - time.monotonic()))
            if thread.is_alive():
                logger.info("%s did not finish within %g s", thread.name, WRITER_FINISH_S)
                self.errors.setdefault(
                    thread.name.removeprefix("writer-"),
                    OutputError(f"the encoder did not finish within {WRITER_FINISH_S:g} s"),
                )

    def close(self) -> None:
        """Close every writer whose thread has finished (errors kept)."""
        busy = {t.name.removeprefix("writer-") for t in self.threads if t.is_alive()}
        for name, writer in self.writers.items():
            if name in busy:  # still encoding: failed in join(), removed by abort()
                continue
            try:
                writer.close()
            except BaseException as exc:
                logger.info("sensor %s: closing the writer failed: %s", name, exc)
                self.errors.setdefault(name, exc)

    def abort(self) -> None:
        """Wait briefly for the writer threads and close any open container, ignoring errors."""
        for thread in self.threads:
            thread.join(timeout=5.0)
        for name, writer in self.writers.items():
            try:
                writer.discard()
            except BaseException as exc:  # aborting anyway
                logger.debug("sensor %s: discarding the writer: %s", name, exc)
