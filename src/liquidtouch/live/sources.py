"""Timed frames for the streaming estimator, from recordings or live cameras.

Every source yields :class:`LiveFrame` objects in time order across its sensors:
``t_s`` on the clock shared by the sensors [s] and ``due_s``, the
:func:`time.monotonic` moment the frame became available (NaN when frames are
read as fast as possible), from which the estimator's lag is measured.

- :func:`replay_frames`: video files, image folders or one trial directory
  (:func:`~liquidtouch.io.sources.resolve_sources`), merged by timestamp; with
  ``realtime`` each frame is handed on when it is due at the pace of its own
  timestamps (a recording re-lived), else at once.
- :func:`camera_frames`: live cameras (:func:`~liquidtouch.acquire.cameras.open_camera`
  sources), each read on its own thread (:class:`~liquidtouch.acquire.cameras.CaptureSession`).
- :func:`open_frames`: either, from command-line sources.
"""

from __future__ import annotations

import heapq
import logging
import math
import os
import queue
import time
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from liquidtouch.acquire.cameras import (
    END,
    CameraThread,
    CaptureSession,
    check_distinct_sources,
    open_camera,
)
from liquidtouch.acquire.deadlines import DEFAULT_OPEN_TIMEOUT_S, DEFAULT_READ_TIMEOUT_S
from liquidtouch.errors import DeviceError
from liquidtouch.io.dataset import trial_sensor_starts
from liquidtouch.io.frames import iter_frames
from liquidtouch.io.sources import resolve_sources, select_sensors

logger = logging.getLogger(__name__)

#: how long a camera queue is polled before the next one is looked at [s]
POLL_S = 0.005
#: a camera that sends no frame this long has stalled [s]: its read deadline and a second
STALL_S = DEFAULT_READ_TIMEOUT_S + 1.0
#: cameras whose sources end within this much of each other ended together [s]
END_GRACE_S = 1.0


@dataclass(frozen=True)
class LiveFrame:
    """One frame: ``sensor`` name, ``t_s`` [s, shared clock], grey ``image``, ``due_s``."""

    sensor: str
    t_s: float
    image: np.ndarray
    due_s: float = math.nan


def replay_frames(
    paths: str | os.PathLike[str] | Sequence[str | os.PathLike[str]],
    *,
    realtime: bool = False,
    speed: float = 1.0,
    fps: float | None = None,
    sensors: Sequence[str] | None = None,
) -> Iterator[LiveFrame]:
    """Frames of recordings in time order (module docstring); ``realtime`` paces them.

    ``speed`` [×] scales the pace of a real-time replay; ``fps`` times image
    folders without timestamps; ``sensors`` picks sensors by name (default all).
    Sensors of a trial are placed on its shared clock (``sensor_start_s``), else
    aligned on their first frames.
    """

    if not 0 < float(speed) < math.inf:
        raise DeviceError(f"the replay speed must be a number > 0, got {speed!r}")
    chosen = select_sensors(resolve_sources(paths, fps=fps), sensors)
    starts = trial_sensor_starts(paths)
    if not all(name in starts for name, _, _ in chosen):
        starts = {}

    def timed(name: str, source: Path, rate: float | None) -> Iterator[tuple[float, str, object]]:
        first = None
        for t_s, image in iter_frames(source, fps=rate):
            first = t_s if first is None else first
            yield starts.get(name, 0.0) + t_s - first, name, image

    merged = heapq.merge(*(timed(*item) for item in chosen), key=lambda item: item[0])
    wall0 = t0 = None
    for t_s, name, image in merged:
        due = math.nan
        if realtime:
            if wall0 is None:
                wall0, t0 = time.monotonic(), t_s
            due = wall0 + (t_s - t0) / speed
            wait = due - time.monotonic()
            if wait > 0:
                time.sleep(wait)
        yield LiveFrame(name, float(t_s), image, due)


def camera_frames(
    sources: Sequence[str],
    *,
    names: Sequence[str] | None = None,
    profile: str = "raw",
    camera_options: Mapping[str, float] | None = None,
    stall_s: float = STALL_S,
    end_grace_s: float = END_GRACE_S,
) -> Iterator[LiveFrame]:
    """Frames of live cameras (any :func:`open_camera` source), as they arrive.

    ``names`` default to ``left``, ``right``, ... ; ``t_s`` and ``due_s`` are
    the frame's :func:`time.monotonic` capture time. The cameras are closed when
    the generator is closed or ends.

    The stream ends when every camera's source ended (within ``end_grace_s`` [s] of
    each other: recordings of one length). Losing **one** camera ends it too, with
    :class:`DeviceError` after the frames before it, because an estimate from the others
    would silently freeze on the lost camera's last frame: a camera that failed (a read
    past its deadline, a broken part, a bad timestamp), whose source ended while the
    others go on, that sent no frame for ``stall_s`` [s] (a read that ignores its
    deadline), or that gave a timestamp that is not a finite number. A frame whose
    timestamp does not increase is skipped (logged).
    """
    check_distinct_sources(list(sources))
    cameras = []
    try:
        for source in sources:
            cameras.append(open_camera(source, profile=profile, **dict(camera_options or {})))
        session = CaptureSession(cameras, names)
    except BaseException:
        for camera in cameras:
            camera.close()
        raise
    threads = {thread.sensor: thread for thread in session.threads}
    with session:
        # before its first frame a camera may take its open timeout to start sending
        now = time.monotonic()
        open_s = dict(camera_options or {}).get("open_timeout_s", DEFAULT_OPEN_TIMEOUT_S)
        deadline = dict.fromkeys(threads, now + open_s + stall_s)
        last_t = dict.fromkeys(threads, -math.inf)
        ended_at: dict[str, float] = {}  # sources that ended by themselves [s, monotonic]
        while len(ended_at) < len(threads):
            for name, q in session.queues.items():
                if name in ended_at:
                    continue
                try:
                    frame = q.get(timeout=POLL_S)
                except queue.Empty:
                    _check_camera(name, threads[name], q, deadline[name], ended_at, stall_s)
                    continue
                if frame is END:
                    ended_at[name] = time.monotonic()
                    continue
                t_s = float(frame.t_s)
                if not math.isfinite(t_s):
                    raise DeviceError(f"camera {name} failed: its frame timestamp is {t_s}")
                deadline[name] = time.monotonic() + stall_s
                if t_s <= last_t[name]:
                    logger.info("camera %s: frame at %.6f s does not follow %.6f s; skipped",
                                name, t_s, last_t[name])  # fmt: skip
                    continue
                last_t[name] = t_s
                yield LiveFrame(name, t_s, frame.image, t_s)
            _check_ends(ended_at, threads, end_grace_s)
    if session.errors:
        name, error = next(iter(session.errors.items()))
        raise DeviceError(f"camera {name} failed: {error}")


def _check_camera(
    name: str,
    thread: CameraThread,
    q: queue.Queue,
    deadline: float,
    ended_at: dict[str, float],
    stall_s: float,
) -> None:
    """A camera with no frame waiting: DeviceError if it failed or stalled; note its end."""
    if thread.ended.is_set() and q.empty():
        if thread.error is not None:
            raise DeviceError(f"camera {name} failed: {thread.error}")
        ended_at.setdefault(name, time.monotonic())
    elif time.monotonic() > deadline:
        raise DeviceError(f"camera {name} failed: no frame for {stall_s:g} s (stalled)")


def _check_ends(ended_at: dict[str, float], threads: dict, grace_s: float) -> None:
    """DeviceError when a camera's source ended more than ``grace_s`` [s] before the others."""
    if not ended_at or len(ended_at) == len(threads):
        return
    name, when = min(ended_at.items(), key=lambda item: item[1])
    if time.monotonic() - when > grace_s:
        why = threads[name].end_reason
        raise DeviceError(
            f"camera {name} stopped sending frames while the others go on"
            + (f": {why}" if why is not None else "")
        )


def is_recording(source: str | os.PathLike[str]) -> bool:
    """Whether ``source`` is a recording on disk (video file, image folder or trial)."""
    text = str(source)
    return not text.startswith("/dev/") and Path(text).exists()


def open_frames(
    sources: Sequence[str | os.PathLike[str]],
    *,
    realtime: bool = False,
    fps: float | None = None,
    profile: str = "raw",
    camera_options: Mapping[str, float] | None = None,
) -> Iterator[LiveFrame]:
    """Frames of recordings (:func:`replay_frames`) or of live cameras (:func:`camera_frames`).

    Recordings and cameras are not mixed (one clock per stream): DeviceError.
    """
    recorded = [is_recording(s) for s in sources]
    if all(recorded):
        return replay_frames(list(sources), realtime=realtime, fps=fps)
    if any(recorded):
        raise DeviceError(
            "give either recordings (video files, image folders, a trial directory) or "
            "cameras, not both"
        )
    return camera_frames([str(s) for s in sources], profile=profile, camera_options=camera_options)
