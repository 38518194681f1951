"""Threaded capture: frame statistics, one reader thread per camera, a capture session.

Part of :mod:`liquidtouch.acquire.cameras` (see its docstring for drops and duplicates).
"""

from __future__ import annotations

import logging
import math
import queue
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from liquidtouch.acquire.cameras.devices import (
    MIN_FRAME_STEP_S,
    Camera,
    StreamEnded,
)
from liquidtouch.acquire.deadlines import DEFAULT_READ_TIMEOUT_S, DEFAULT_WARMUP_TIMEOUT_S
from liquidtouch.errors import DeviceError
from liquidtouch.tracking.clock import PeriodFit, fit_frame_period

logger = logging.getLogger(__name__)

MIN_MEASURED_GAPS = 2
"""Frame intervals needed before the period is fitted (a median of two: one may be a drop);
the nominal rate stands in before."""

# --- statistics -------------------------------------------------------------------------


@dataclass
class FrameStats:
    """Frame count, timing, drops and duplicates of one camera's frames so far.

    The frame rate and the drops are those of the frame period fitted to every
    timestamp so far (:func:`~liquidtouch.tracking.clock.fit_frame_period`, what
    ``extract`` fits: drops on the camera's lattice are counted, frames delivered in
    bursts are not drops; a GelSight Mini that gives 15 fps in a 25 fps mode drops
    nothing); ``nominal_fps`` [Hz] stands in until :data:`MIN_MEASURED_GAPS` intervals
    have been seen.
    """

    nominal_fps: float | None = None
    frames: int = 0
    duplicates: int = 0
    first_t_s: float | None = None
    last_t_s: float | None = None
    _times: list[float] = field(default_factory=list, repr=False)
    _previous: np.ndarray | None = field(default=None, repr=False)
    # (frames, fit): the fit of the timestamps so far, kept until the next frame, so that
    # reading the period, the drops and the rate fits the stamps once
    _fitted: tuple[int, PeriodFit] | None = field(default=None, repr=False)

    def add(self, t_s: float, frame: np.ndarray) -> bool:
        """Count a frame; return whether it duplicates the previous frame."""
        duplicate = self._previous is not None and np.array_equal(self._previous, frame)
        self.duplicates += int(duplicate)
        if self.first_t_s is None:
            self.first_t_s = t_s
        self.last_t_s = t_s
        self._times.append(t_s)
        self.frames += 1
        self._previous = frame
        return duplicate

    def _fit_all(self) -> PeriodFit:
        """The period fitted to every timestamp so far (at least two)."""
        if self._fitted is None or self._fitted[0] != len(self._times):
            self._fitted = (len(self._times), fit_frame_period(np.asarray(self._times)))
        return self._fitted[1]

    def _fit(self) -> PeriodFit | None:
        """The period fitted to the frames so far (``None`` before enough of them)."""
        if len(self._times) > MIN_MEASURED_GAPS or (len(self._times) > 1 and not self.nominal_fps):
            return self._fit_all()
        return None

    @property
    def period_s(self) -> float | None:
        """The frame period [s] fitted so far (1 / nominal fps before
        :data:`MIN_MEASURED_GAPS` intervals, or the fit of fewer without it)."""
        fit = self._fit()
        if fit is not None:
            return fit.period_s
        return 1.0 / self.nominal_fps if self.nominal_fps else None

    @property
    def drops(self) -> int:
        """Frames missing between the first and the last, on the fitted lattice."""
        fit = self._fit()
        return fit.dropped if fit is not None else 0

    @property
    def measured_fps(self) -> float | None:
        """The frame rate [Hz] fitted to the timestamps (what ``extract`` fits); ``None``
        before two frames."""
        return self._fit_all().fps if self.frames > 1 else None


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
            last_t_s = -math.inf
            shape: tuple[int, ...] | None = None
            while not self._stop_event.is_set():
                before = time.monotonic()
                t_s, image = self.camera.read(self.read_timeout_s)
                arrival = time.monotonic()
                if arrival - before >= quick_s:  # waited for it: no stale frames left
                    self.fresh.set()
                if t_s < last_t_s + MIN_FRAME_STEP_S:  # its clock stepped back or stood still
                    t_s = self._reanchor(t_s, last_t_s, arrival)
                last_t_s = t_s
                if self._stop_event.is_set() or t_s > self.keep_until_t_s:
                    break
                if t_s < self.keep_from_t_s:  # primed, not yet recording: keep buffers empty
                    continue
                if shape is None:
                    shape = image.shape
                elif image.shape != shape:  # extract reads one frame size per sensor
                    raise DeviceError(
                        f"the frame size changed from {_size(shape)} to {_size(image.shape)} "
                        f"at frame {index}; a recording keeps one size per sensor (give a "
                        "--sensor profile, which resizes, or fix the camera's mode)"
                    )
                duplicate = self.stats.add(t_s, image)
                self.sink(Frame(self.sensor, index, t_s, image, duplicate))
                index += 1
        except StreamEnded as exc:
            logger.info("sensor %s: %s (after %d frames)", self.sensor, exc, index)
            self.end_reason = exc
        except BaseException as exc:
            logger.info("sensor %s: camera failed after %d frames: %s", self.sensor, index, exc)
            self.error = exc
        finally:
            self.ended.set()

    def _reanchor(self, t_s: float, last_t_s: float, arrival_s: float) -> float:
        """A frame timed ``t_s`` [s] not after the one before (``last_t_s``): timed on
        ``arrival_s`` instead (kept after the one before), counted and logged."""
        self.camera.reanchors += 1
        logger.log(
            logging.WARNING if self.camera.reanchors == 1 else logging.DEBUG,
            "sensor %s: the camera's clock went from %.6f to %.6f s (back or standing "
            "still); frames re-anchored on arrival time (%d so far)",
            self.sensor,
            last_t_s,
            t_s,
            self.camera.reanchors,
        )
        return max(arrival_s, last_t_s + MIN_FRAME_STEP_S)

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

        First waits (at most :data:`DEFAULT_WARMUP_TIMEOUT_S`) until every live camera's thread has
        read the frames that were waiting in buffers since it was opened."""
        if not self._started:
            self.prime()
            deadline = time.monotonic() + DEFAULT_WARMUP_TIMEOUT_S
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
                logger.info("camera %s did not stop within %g s", thread.sensor, timeout_s)
                thread.error = thread.error or DeviceError(
                    f"camera {thread.sensor} did not stop within {timeout_s:g} s"
                )
        for name in self.names:
            self.queues[name].put(END)
        for thread in self.threads if logger.isEnabledFor(logging.INFO) else ():
            stats = thread.stats
            logger.info(
                "sensor %s: %d frames, %d dropped, %d duplicated",
                thread.sensor,
                stats.frames,
                stats.drops,
                stats.duplicates,
            )

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


def _size(shape: tuple[int, ...]) -> str:
    return f"{shape[1]}x{shape[0]}" + (f"x{shape[2]}" if len(shape) > 2 else "")


def default_names(n: int) -> list[str]:
    """``left``, ``right``, then ``sensor2``, ``sensor3``, ... for ``n`` sensors."""
    return [("left", "right")[i] if i < 2 else f"sensor{i}" for i in range(n)]
