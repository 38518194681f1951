"""The streaming loop: :func:`live_updates` runs frames through a :class:`LiveEstimator`.

It yields every update, stops early when every ``until_std`` target's std is
below its threshold (:func:`~liquidtouch.live.stopping.stop_reached`) or the
stream time reaches ``max_duration_s``, and ends with the final update
(``final=True``, ``stopped_because``, and the per-frame ``timing``: the
latency of each ``add_frame`` [ms] and the lag of each frame's processing behind
the moment it became available [s], when frames are paced).
"""

from __future__ import annotations

import math
import os
import time
from collections import deque
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from pathlib import Path

import numpy as np

from liquidtouch.acquire.cameras import default_names
from liquidtouch.errors import LiquidTouchError, SignalError, VideoError
from liquidtouch.extraction.fit_settings import FitSettings
from liquidtouch.io.sources import resolve_sources
from liquidtouch.live.estimator import MAX_TIMED_FRAMES, REFRESH_S, LiveEstimator
from liquidtouch.live.sources import LiveFrame, is_recording, open_frames
from liquidtouch.live.stopping import parse_until_std, stop_reached
from liquidtouch.live.updates import LiveUpdate
from liquidtouch.models.kernel_limits import single_threaded_blas
from liquidtouch.models.modelfile import load_model
from liquidtouch.signal.lowpass import DEFAULT_LOWPASS_HZ
from liquidtouch.signal.tactile import DEFAULT_N_MARKERS
from liquidtouch.tracking.gel import DEFAULT_TRACKING, check_tracking

PathLike = str | os.PathLike[str]
#: ``on_frame(frame, positions (N, 2) [px], reference (N, 2) [px])`` after each tracked frame
FrameCallback = Callable[[LiveFrame, np.ndarray, np.ndarray], None]


def sensor_names(sources: Sequence[PathLike], *, fps: float | None = None) -> list[str]:
    """The sensor names the frames of ``sources`` will carry (:func:`open_frames`)."""
    if all(is_recording(s) for s in sources):
        return [name for name, _, _ in resolve_sources(list(sources), fps=fps)]
    return default_names(len(sources))


def live_updates(
    sources: PathLike | Sequence[PathLike] | Iterable[LiveFrame],
    *,
    model: object | PathLike | None = None,
    until_std: Mapping[str, float] | Sequence[str] | None = None,
    realtime: bool = False,
    max_duration_s: float | None = None,
    sensors: Sequence[str] | None = None,
    fps: float | None = None,
    lowpass_hz: float | None = DEFAULT_LOWPASS_HZ,
    n_markers: int = DEFAULT_N_MARKERS,
    fit_settings: FitSettings | None = None,
    refresh_s: float = REFRESH_S,
    threaded: bool | None = None,
    on_frame: FrameCallback | None = None,
    protocol: bool = False,
    on_event: Callable[[], Iterable[tuple[str, float]]] | None = None,
    stop: Callable[[], bool] | None = None,
    profile: str = "raw",
    camera_options: Mapping[str, float] | None = None,
    stop_on_until_std: bool = True,
    tracking: str = DEFAULT_TRACKING,
) -> Iterator[LiveUpdate]:
    """Updates of the streaming estimate of ``sources``; the last has ``final=True``.

    Parameters
    ----------
    sources : video files, image folders or one trial directory (replayed), camera
        sources (``open_camera``: ``"0"``, ``/dev/video2``, ``name:...``, URLs), or an
        iterable of :class:`LiveFrame` (then ``sensors`` names the sensors).
    model : a ``PropertyModel`` or the path of a model file: a regression model adds
        ``predicted`` properties with their std, a liquid classifier ``classified``
        probabilities.
    until_std : ``{target: std}`` or ``["target=std", ...]``: stop once every
        target's std is below its threshold (targets: ``decay_rate``,
        ``angular_frequency``, the model's targets). Checked before any frame.
    stop_on_until_std : False: ``until_std`` does not end the stream (the updates still
        judge the targets: ``combined``'s ``reach``); ``run-trial --max-pushes`` decides
        from the combined ring-downs when the trial ends.
    realtime : replay recordings at the pace of their timestamps (cameras always are).
    max_duration_s : stop after this much stream time [s] (default: the source's end).
    fps : frame rate of image folders without timestamps [Hz].
    lowpass_hz, n_markers, fit_settings : as ``extract``.
    refresh_s : stream time between refreshes [s].
    threaded : refresh on a worker thread (default: when frames are paced in real time).
    on_frame : called after each tracked frame (e.g. to show the markers).
    protocol, on_event : the protocol's events come (``run-trial``): ``on_event()`` returns
        the new ``(name, t_s)`` since its last call [s, on the frames' clock]; the push and
        the end of the hold are then taken from them.
    stop : called after each frame; True ends the stream (``stopped_because="stopped"``).
    profile, camera_options : cameras only: the sensor profile (``mini``, ...) and
        ``open_camera``'s deadlines (``open_timeout_s``, ``read_timeout_s``,
        ``warmup_timeout_s`` [s]).
    tracking : ``auto`` (printed markers, or the gel's own image on a markerless gel),
        ``markers`` or ``flow``, as ``extract``. Checked before any frame.

    Ctrl-C (a ``KeyboardInterrupt`` in the loop, or thrown into this generator by the
    caller with ``.throw``) ends the stream with its final update
    (``stopped_because="interrupted"``).
    """
    limits = _until_std(until_std)
    check_tracking(tracking)
    if isinstance(model, str | os.PathLike):
        model = load_model(Path(model))
    if isinstance(sources, str | os.PathLike):
        sources = [sources]
    if isinstance(sources, Sequence) and all(isinstance(s, str | os.PathLike) for s in sources):
        names = list(sensors) if sensors else sensor_names(sources, fps=fps)
        paced = realtime or not all(is_recording(s) for s in sources)
        frames: Iterable[LiveFrame] = open_frames(
            sources, realtime=realtime, fps=fps, profile=profile, camera_options=camera_options
        )
    else:
        if not sensors:
            raise VideoError("give the sensor names (sensors=...) of a stream of LiveFrame objects")
        names, paced, frames = list(sensors), realtime, sources
    if max_duration_s is not None and not 0 < float(max_duration_s) < math.inf:
        raise SignalError(f"max_duration_s must be a time > 0 in seconds, got {max_duration_s!r}")
    estimator = LiveEstimator(
        names,
        model=model,
        until_std=limits,
        lowpass_hz=lowpass_hz,
        n_markers=n_markers,
        fit_settings=fit_settings,
        refresh_s=refresh_s,
        threaded=paced if threaded is None else threaded,
        protocol=protocol,
        tracking=tracking,
    )
    lags: deque[float] = deque(maxlen=MAX_TIMED_FRAMES)
    stopped = "end_of_stream"
    source_error = ""
    first_t = math.nan
    iterator = iter(frames)
    blas = single_threaded_blas()  # small matrices: BLAS threads only spin on a busy machine
    try:
        try:
            try:
                for frame in _until_source_fails(iterator):
                    if isinstance(frame, LiquidTouchError):  # a camera died after frames came
                        stopped, source_error = "source_error", str(frame)
                        break
                    if math.isfinite(frame.due_s):
                        lags.append(time.monotonic() - frame.due_s)
                    first_t = frame.t_s if math.isnan(first_t) else first_t
                    if max_duration_s is not None and frame.t_s - first_t > max_duration_s:
                        stopped = "max_duration"
                        break
                    if on_event is not None:
                        for name, t_s in on_event():
                            estimator.add_event(name, t_s)
                    update = estimator.add_frame(frame.sensor, frame.t_s, frame.image, frame.due_s)
                    grown = estimator.tracks[frame.sensor]
                    if on_frame is not None and grown.n:  # (a markerless gel may wait)
                        on_frame(frame, grown.positions[grown.n - 1], grown.reference)
                    if update is not None:
                        yield update
                        stds = {target: update.std_of(target) for target in limits}
                        if stop_on_until_std and stop_reached(limits, stds):
                            stopped = "until_std"
                            break
                    if stop is not None and stop():
                        stopped = "stopped"
                        break
            except KeyboardInterrupt:  # Ctrl-C (here or thrown in by the caller): the final update
                stopped = "interrupted"
        finally:
            close = getattr(iterator, "close", None)
            if close is not None:
                close()
        final = estimator.finish(stopped)
    finally:
        blas.restore_original_limits()
    if source_error:
        final.message = f"{source_error}; {final.message}" if final.message else source_error
    final.timing = estimator.timing()
    if lags:
        final.timing.update(
            frame_lag_s_median=float(np.median(lags)),
            frame_lag_s_p95=float(np.percentile(lags, 95)),
            frame_lag_s_max=float(np.max(lags)),
        )
    yield final


def _until_source_fails(
    frames: Iterator[LiveFrame],
) -> Iterator[LiveFrame | LiquidTouchError]:
    """The frames; a source error after the first frame is yielded (ends the stream).

    A camera that stops mid-stream should not lose the estimate so far: the
    final update says why it stopped. An error before any frame is raised.
    """
    seen = False
    while True:
        try:
            frame = next(frames)
        except StopIteration:
            return
        except LiquidTouchError as exc:
            if not seen:
                raise
            yield exc
            return
        seen = True
        yield frame


def _until_std(until_std: Mapping[str, float] | Sequence[str] | None) -> dict[str, float]:
    if until_std is None:
        return {}
    if isinstance(until_std, Mapping):
        return {str(k): float(v) for k, v in until_std.items()}
    if isinstance(until_std, str):
        until_std = [until_std]
    return parse_until_std(until_std)
