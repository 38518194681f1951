"""Record GelSight cameras into a trial directory, losslessly, with every frame's timestamp.

:class:`Recorder` opens every source (:func:`~liquidtouch.acquire.cameras.open_camera`),
reads each camera on its own thread (one clock, :func:`time.monotonic`) and
encodes each sensor on its own writer thread while recording, into a temporary
directory beside ``out_dir``. :meth:`Recorder.finish` completes the trial:

```
out_dir/
  left.mkv  right.mkv           fmt="ffv1": FFV1 (lossless) in Matroska; each frame's PTS is
                                its timestamp (1 ms resolution), so `extract` times it exactly
  left.timestamps.csv           frame,t_s,duplicate: absolute capture times [s, time.monotonic]
  left/000000.png ... + left/timestamps.csv       fmt="png": an image folder instead
  meta.json                     written last: fps (measured), sensors, labels, sensor_start_s, ...
```

and renames the directory into place; :meth:`Recorder.abort` (or an exception or
Ctrl-C inside ``with Recorder(...)``) removes everything and leaves no trial.

**Grey by default.** liquidtouch reads the luma of every frame (markers are dark
on every LED colour), so the recorder stores ``grey=True`` frames (BT.601 luma,
``cv2.cvtColor``): a third of the data, and FFV1 keeps up with two 640 × 480
sensors at 30 fps on one core (``benchmarks/acquire/record_formats.py``). ``grey=False``
keeps the BGR colour (FFV1 ``bgr0``, lossless too) for photometric uses.

**Nothing is hidden.** The summary counts dropped frames (timestamp gaps),
duplicated frames (identical consecutive frames; kept in the recording) and frames
lost because an encoder fell more than :data:`MAX_BACKLOG_S` behind the camera
(``backlog_drops``; the frame rate or format is too much for the machine).
"""

from __future__ import annotations

import contextlib
import logging
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from liquidtouch._core import atomic
from liquidtouch.acquire.cameras import (
    Camera,
    CaptureSession,
    FrameStats,
    check_distinct_sources,
    check_timeout,
    default_names,
    get_profile,
    open_camera,
)
from liquidtouch.acquire.deadlines import (
    DEFAULT_OPEN_TIMEOUT_S,
    DEFAULT_READ_TIMEOUT_S,
    DEFAULT_WARMUP_TIMEOUT_S,
)
from liquidtouch.acquire.recording.meta import build_meta, check_meta_fields, validate_meta
from liquidtouch.acquire.recording.summary import RecordingSummary, summarise
from liquidtouch.acquire.recording.writer_pool import WriterPool
from liquidtouch.errors import DeviceError, LiquidTouchError, OutputError
from liquidtouch.io.dataset import META_NAME
from liquidtouch.tracking.clock import check_consistent_times

__all__ = ["FORMATS", "Recorder"]

logger = logging.getLogger(__name__)

FORMATS = ("ffv1", "png")


# --- recorder ---------------------------------------------------------------------------


class Recorder:
    """Record ``sources`` (one per sensor) into the trial directory ``out_dir``.

    Parameters
    ----------
    sources : camera sources as :func:`~liquidtouch.acquire.cameras.open_camera` takes them.
    out_dir : the trial directory to create (it must not exist, or be empty).
    names : sensor names (file stems); default ``left``, ``right``, ``sensor2``, ...
    profile : sensor profile (``mini``, ``r15``, ``digit``, ``raw``), for every source.
    fmt : ``"ffv1"`` (FFV1 in Matroska) or ``"png"`` (image folders); both lossless.
    labels : meta.json labels (``liquid``, ``container``, ``height_mm``, ... or any other
        key), validated now (``TrialMeta``).
    grey : store the luma only (default; what liquidtouch reads) or the BGR colour.
    warmup_frames : frames discarded after opening each camera (``None``: its default).
    read_timeout_s : a camera delivering no frame for this long [s] fails the recording.
    on_frame : ``on_frame(sensor, frame)`` for every frame recorded (on the capture thread:
        must not block), e.g. to estimate live from the frames being recorded.
    open_timeout_s, warmup_timeout_s : deadlines [s] for opening a stream and for the
        whole warm-up (:func:`~liquidtouch.acquire.cameras.open_camera`).

    Use :meth:`start`, :meth:`stop`, :meth:`finish` (or :meth:`abort`); or as a
    context manager, which aborts on any exception (Ctrl-C included) and finishes a
    recording left open on a normal exit. :meth:`open` opens and warms up the
    cameras ahead of :meth:`start`, so that capturing starts without delay.
    """

    def __init__(
        self,
        sources: Sequence[str],
        out_dir: str | Path,
        *,
        names: Sequence[str] | None = None,
        profile: str = "raw",
        fmt: str = "ffv1",
        labels: dict[str, object] | None = None,
        grey: bool = True,
        warmup_frames: int | None = None,
        read_timeout_s: float = DEFAULT_READ_TIMEOUT_S,
        open_timeout_s: float = DEFAULT_OPEN_TIMEOUT_S,
        warmup_timeout_s: float = DEFAULT_WARMUP_TIMEOUT_S,
        speed: float = 1.0,
        on_frame=None,
    ) -> None:
        self.sources = [str(s) for s in sources]
        if not self.sources:
            raise DeviceError("give at least one camera source to record")
        self.names = list(names) if names is not None else default_names(len(self.sources))
        if len(self.names) != len(self.sources):
            raise DeviceError(f"{len(self.sources)} sources but {len(self.names)} names")
        for name in self.names:
            if not name or name != Path(name).name or name.startswith(".") or name == "meta":
                raise DeviceError(f"sensor name {name!r} must be a plain file name")
        if len(set(self.names)) != len(self.names):
            raise DeviceError(f"sensor names must differ: {self.names}")
        self.profile = get_profile(profile)
        if fmt not in FORMATS:
            raise DeviceError(f"unknown recording format {fmt!r}; choose one of {FORMATS}")
        self.fmt = fmt
        self.labels = dict(labels or {})
        check_meta_fields(self.labels, "label")
        validate_meta({"fps": 30.0, **self.labels})
        self.grey = bool(grey)
        self.warmup_frames = warmup_frames
        self.read_timeout_s = check_timeout(read_timeout_s, "the camera read timeout")
        self.open_timeout_s = check_timeout(open_timeout_s, "the camera open timeout")
        self.warmup_timeout_s = check_timeout(warmup_timeout_s, "the camera warm-up timeout")
        self.speed = float(speed)
        self.out_dir = atomic.check_directory_target(out_dir)
        self.cameras: list[Camera] = []
        self.session: CaptureSession | None = None
        self.summary: RecordingSummary | None = None
        self.trial_dir: Path | None = None
        self._stack: contextlib.ExitStack | None = None
        self._tmp: Path | None = None
        self._pool = WriterPool(self.names, grey=self.grey, tap=on_frame)
        self._state = "new"

    # --- lifecycle ----------------------------------------------------------------------

    def open(self) -> Recorder:
        """Open and warm up every camera and start reading them, discarding frames until
        :meth:`start` (done by :meth:`start` if not called before)."""
        if self.cameras:
            return self
        if self._state != "new":
            raise DeviceError(f"this recorder is {self._state}; make a new one")
        check_distinct_sources(self.sources)  # before any camera is opened
        try:
            for source in self.sources:
                self.cameras.append(
                    open_camera(
                        source,
                        profile=self.profile,
                        warmup_frames=self.warmup_frames,
                        read_timeout_s=self.read_timeout_s,
                        open_timeout_s=self.open_timeout_s,
                        warmup_timeout_s=self.warmup_timeout_s,
                        speed=self.speed,
                    )
                )
            self.session = CaptureSession(
                self.cameras, self.names, read_timeout_s=self.read_timeout_s
            )
            self.session.prime()
        except BaseException as exc:
            logger.info("opening the cameras failed: %s", exc or type(exc).__name__)
            if self.session is not None:
                self.session.stop()
            self._close_cameras()
            raise
        return self

    def start(self) -> Recorder:
        """Start capturing every sensor on its own thread into the temporary trial directory."""
        if self._state != "new":
            raise DeviceError(f"this recorder is already {self._state}")
        try:
            self.open()
            # why: imported now, not by a writer thread while recording
            import av  # noqa: F401
            import cv2  # noqa: F401

            self._stack = contextlib.ExitStack()
            self._tmp = self._stack.enter_context(atomic.atomic_directory(self.out_dir))
            assert self.session is not None
            t0 = time.monotonic()
            self._pool.start(self.session, self.cameras, self.names, self._tmp, self.fmt, t0)
            self._state = "recording"
            self.session.start()
            logger.info("recording %s into %s (%s)", ", ".join(self.names), self._tmp, self.fmt)
        except BaseException:
            self.abort()
            raise
        return self

    def stats(self) -> dict[str, FrameStats]:
        """Live per-sensor statistics (frames, measured fps, drops, duplicates)."""
        return self.session.stats if self.session else {}

    def backlog(self) -> dict[str, int]:
        """Frames waiting for each encoder right now."""
        return {n: q.qsize() for n, q in self.session.queues.items()} if self.session else {}

    @property
    def ended(self) -> bool:
        """Whether every source has ended (replayed files) or failed."""
        return self.session is not None and self.session.all_ended

    def check(self) -> None:
        """Raise :class:`DeviceError` if a camera or encoder has failed so far (a live
        camera or stream that ended, e.g. its server closed it, has failed too)."""
        if self.session is not None:
            for name, error in self.session.errors.items():
                raise DeviceError(f"sensor {name}: {error}") from error
            for thread in self.session.threads:  # a live camera does not end by itself
                if thread.end_reason is not None and thread.camera.live:
                    raise DeviceError(
                        f"sensor {thread.sensor}: {thread.end_reason} while recording"
                    ) from thread.end_reason
        for name, error in self._pool.errors.items():
            if isinstance(error, LiquidTouchError):
                raise error
            raise OutputError(f"sensor {name}: cannot write the recording: {error}") from error

    def stop(self) -> RecordingSummary:
        """Stop capturing, let the encoders catch up; return the summary.

        Raises :class:`DeviceError` if a camera failed or recorded no frame (the
        recording stays until :meth:`abort`; the context manager aborts it).
        """
        if self._state != "recording":
            if self.summary is not None:
                return self.summary
            raise DeviceError(f"this recorder is {self._state}, not recording")
        assert self.session is not None
        self.session.stop()
        stopped_at = time.monotonic()
        self._pool.join()
        self._close_cameras()
        self._pool.close()
        self._state = "stopped"
        self.summary = summarise(
            self.session,
            self._pool,
            zip(self.names, self.sources, self.cameras, strict=True),
            stopped_at=stopped_at,
            fmt=self.fmt,
            profile=self.profile.name,
            grey=self.grey,
        )
        self.check()
        for warning in self.summary.warnings:
            logger.warning("%s", warning)
        empty = [n for n, s in self.summary.sensors.items() if s.frames < 2]
        for name, s in self.summary.sensors.items():
            if s.lost:
                logger.info(
                    "sensor %s: %d frames lost (%d dropped by the camera, %d behind the encoder)",
                    name,
                    s.lost,
                    s.drops,
                    s.backlog_drops,
                )
        if empty:
            raise DeviceError(
                f"sensor(s) {', '.join(empty)} recorded fewer than 2 frames; is the camera "
                "delivering (and the recording long enough)?"
            )
        self._check_timing()
        return self.summary

    def _check_timing(self) -> None:
        """The sensors' frame times are one recording, as ``extract`` will check them
        (:func:`~liquidtouch.tracking.clock.check_consistent_times`): a mismatch is a
        :class:`DeviceError` now, not a trial that ``extract`` refuses later."""
        times = [np.asarray(self._pool.writers[name].times) for name in self.names]
        check_consistent_times(
            self.names,
            times,
            [float(t[0]) for t in times],
            error=DeviceError,
            what="sensors",
            hint="run the cameras in one mode (one --sensor profile) and record again",
        )

    def finish(self, extra_meta: dict[str, object] | None = None) -> Path:
        """Write meta.json (last) and rename the trial into ``out_dir``; return its path.

        ``extra_meta`` adds fields to meta.json (e.g. the protocol's push time on the
        same clock); it cannot replace the recorder's own fields (:data:`RESERVED_META`).
        """
        if self._state == "recording":
            self.stop()
        if self._state != "stopped" or self.summary is None or self._tmp is None:
            raise DeviceError(f"this recorder is {self._state}; nothing to finish")
        summary = self.summary
        meta = build_meta(
            summary,
            self.labels,
            extra_meta,
            fmt=self.fmt,
            grey=self.grey,
            profile=self.profile.name,
        )
        atomic.write_json(self._tmp / META_NAME, meta)
        assert self._stack is not None
        stack, self._stack = self._stack, None
        try:
            stack.close()  # renames the temporary directory into place
        except BaseException:
            self._state = "aborted"
            raise
        self._state = "finished"
        self.trial_dir = self.out_dir
        summary.trial_dir = self.out_dir
        logger.info("wrote the trial %s", self.out_dir)
        return self.out_dir

    def abort(self) -> None:
        """Stop everything and remove the temporary directory: no trial is left."""
        if self._state in ("aborted", "finished"):
            return
        logger.info("recording aborted (was %s): no trial is left", self._state)
        try:
            if self.session is not None:
                self.session.stop()
        except BaseException as exc:  # aborting anyway
            logger.debug("stopping the capture session while aborting: %s", exc)
        self._pool.abort()
        self._close_cameras()
        self._state = "aborted"
        if self._stack is not None:
            stack, self._stack = self._stack, None
            error = _Aborted()
            stack.__exit__(type(error), error, None)  # removes the temporary directory

    def _close_cameras(self) -> None:
        for camera in self.cameras:
            try:
                camera.close()
            except BaseException as exc:  # closing anyway
                logger.debug("closing camera %r: %s", camera, exc)

    def __enter__(self) -> Recorder:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is not None:
            self.abort()
            return
        try:
            if self._state in ("recording", "stopped"):
                self.finish()
        except BaseException:
            self.abort()
            raise


class _Aborted(Exception):
    """Thrown into the temporary directory's context to remove it."""
