"""Frame timing: the frame period fitted to timestamps, and the uniform clock built on it.

Real sensors jitter, drop frames and store rounded timestamps (Matroska keeps 1 ms).
The signal stage resamples every sensor onto one uniform clock whose step is the
period fitted to *all* timestamps (:func:`frame_period`), not the median interval:
the median misses the real period by ~0.3 % under jitter or rounding, and the
interpolation's phase against the frames then drifts through the decay and moves
λ by several per cent.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from liquidtouch._core.checks import as_number, check_times
from liquidtouch.errors import SignalError, VideoError

if TYPE_CHECKING:
    from liquidtouch.tracking.tracks import MarkerTracks

RATE_TOLERANCE = 0.01  # relative frame-rate difference allowed between the videos of a trial
SPAN_TOLERANCE = 0.05  # fraction of the longest video the others may not cover


def frame_period(t: np.ndarray) -> float:
    """The frame period [s] fitted to all timestamps ``t`` [s] (least squares).

    Frame ``k``'s index counts the frames dropped before it (each gap is
    ``round(gap / median gap)`` periods, at least 1); the period is the slope of
    ``t`` against that index. Unlike the median interval it is not pulled off by
    timestamp jitter or rounding (e.g. Matroska's 1 ms PTS), and drops do not bias it.
    """
    t = check_times(t, "frame timestamps")
    gaps = np.diff(t)
    steps = np.maximum(1.0, np.rint(gaps / np.median(gaps)))
    index = np.concatenate([[0.0], np.cumsum(steps)])
    index -= index.mean()  # centred: the slope without the cancellation of large times
    return float(np.dot(index, t - t.mean()) / np.dot(index, index))


def uniform_clock(t: np.ndarray, end_s: float | None = None) -> tuple[np.ndarray, float]:
    """A uniform clock from 0 at the fitted frame period of timestamps ``t`` [s]: (times, fps).

    The clock spans ``t[0]`` to ``end_s`` (a time on the clock of ``t``; default
    ``t[-1]``), shifted to start at 0; its step is :func:`frame_period`.
    """
    t = check_times(t, "frame timestamps")
    if end_s is not None and not t[0] < as_number(end_s) < math.inf:
        raise SignalError(
            f"end_s must be a finite time after the first timestamp {t[0]:g} s, got {end_s!r}"
        )
    step = frame_period(t)
    end = float(t[-1] if end_s is None else end_s) - float(t[0])
    n = int(np.floor(end / step + 1e-6)) + 1
    return np.arange(n) * step, 1.0 / step


def check_consistent(tracks: Sequence[MarkerTracks]) -> None:
    """The videos of one trial must be one recording: VideoError otherwise.

    Their frame rates (the period fitted to all timestamps,
    :func:`~liquidtouch.tracking.clock.frame_period`) agree within :data:`RATE_TOLERANCE`,
    and their time spans (on the trial's shared clock, ``MarkerTracks.start_s``)
    overlap over all but :data:`SPAN_TOLERANCE` of the longest (at least two frame
    periods). Frame counts may differ: sensors drop frames independently.
    """
    if len(tracks) < 2:
        return
    try:
        periods = [frame_period(tr.t) for tr in tracks]
    except SignalError:  # bad timestamps: the signal says so, per sensor
        return
    rates = [1.0 / p for p in periods]
    for tr, rate in zip(tracks[1:], rates[1:], strict=True):
        if not abs(rate - rates[0]) <= RATE_TOLERANCE * rates[0]:
            raise VideoError(
                f"videos of one trial differ in frame rate: {tracks[0].sensor} {rates[0]:.3f} "
                f"fps, {tr.sensor} {rate:.3f} fps; give the videos of one recording"
            )
    starts = [float(tr.start_s) for tr in tracks]
    ends = [s + float(tr.t[-1] - tr.t[0]) for s, tr in zip(starts, tracks, strict=True)]
    longest = max(e - s for s, e in zip(starts, ends, strict=True))
    overlap = min(ends) - max(starts)
    if longest - overlap > max(2 * max(periods), SPAN_TOLERANCE * longest):
        spans = ", ".join(
            f"{tr.sensor} {s:.2f}–{e:.2f} s" for tr, s, e in zip(tracks, starts, ends, strict=True)
        )
        raise VideoError(
            f"videos of one trial differ in length: {spans} (together {max(overlap, 0):.2f} s); "
            "give the videos of one recording"
        )
