"""Frame timing: the frame period fitted to timestamps, and the uniform clock built on it.

Real sensors jitter, drop frames and store rounded timestamps (Matroska keeps 1 ms).
The signal stage resamples every sensor onto one uniform clock whose step is the
period fitted to *all* timestamps (:func:`frame_period`), not the median interval:
the median misses the real period by ~0.3 % under jitter or rounding, and the
interpolation's phase against the frames then drifts through the decay and moves
λ by several per cent.

**Two kinds of timestamps.** A camera's own stamps (a driver's buffer time, an
MJPEG part's ``X-Timestamp``, a recorder's sidecar of them) lie on its frame lattice:
consecutive frames one period apart, or a whole number of periods where frames were
dropped. Stamps taken when a frame was *delivered* (a grab on arrival, a folder stamped
as its files were written) do not on a loaded machine: frames come in bursts, a
stall of several periods and then the frames held back, a fraction of a millisecond
apart. Counting each gap as whole periods (what the lattice needs) then counts every
burst's stall as drops and fits 31-55 fps for a 30 fps camera (534 fps for a folder
stamped in bursts). :func:`fit_frame_period` fits both readings and keeps the one whose
lattice the stamps fit better (:class:`PeriodFit`); delivered frames are all counted,
so drops among them cannot be told from delays (the period is then
``span / (frames - 1)``, long by the share of frames dropped).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from liquidtouch._core.checks import as_number, check_times
from liquidtouch.errors import LiquidTouchError, SignalError, VideoError

if TYPE_CHECKING:
    from liquidtouch.tracking.tracks import MarkerTracks

__all__ = [
    "RATE_TOLERANCE",
    "SPAN_TOLERANCE",
    "STALL_PERIODS",
    "PeriodFit",
    "check_consistent",
    "check_consistent_times",
    "fit_frame_period",
    "frame_period",
    "frame_times",
    "uniform_clock",
]

RATE_TOLERANCE = 0.01  # relative frame-rate difference allowed between the videos of a trial
SPAN_TOLERANCE = 0.05  # fraction of the longest video the others may not cover
STALL_PERIODS = 30
"""A gap of more frame periods than this is a stall, not drops (:func:`fit_frame_period`):
the median gap that counts the periods is 0.3 % off under a rounded PTS, so a count of
up to ~(0.5 - 0.3 jitter) / 0.003 = 66 periods is exact; a second at 30 fps."""
MAX_COLLISIONS = 0.01
"""Largest share of gaps under half a period that stamps on a camera's lattice may hold: its
own stamps never are (a glitch timed on arrival 1 µs after the frame before may be,
``acquire.cameras``); frames delivered in bursts hold 30-50 % of them."""


@dataclass(frozen=True)
class PeriodFit:
    """The frame period fitted to one sensor's timestamps (:func:`fit_frame_period`).

    Attributes
    ----------
    period_s : the frame period [s].
    uncertainty_s : how far off ``period_s`` can be [s] given how far the stamps stray
        from the fitted lattice: the spread (max - min) of the residuals over the span
        of frame slots. A few µs for a camera's stamps; tens of µs for frames
        delivered in bursts.
    slots : frame periods the recording spans (frames - 1 + frames dropped).
    frames : timestamps fitted.
    delivered : ``True`` when the stamps are delivery times (bursts; module docstring).
    """

    period_s: float
    uncertainty_s: float
    slots: int
    frames: int
    delivered: bool

    @property
    def fps(self) -> float:
        """The frame rate [Hz]."""
        return 1.0 / self.period_s

    @property
    def dropped(self) -> int:
        """Frames missing between the first and the last."""
        return self.slots - (self.frames - 1)


def _line(index: np.ndarray, t: np.ndarray, piece: np.ndarray) -> tuple[float, np.ndarray]:
    """Least-squares slope of ``t`` against ``index``, one intercept per ``piece`` (labels
    0, 1, ... in order), and the residuals [s]."""
    counts = np.bincount(piece).astype(float)
    # centred per piece: the slope without the cancellation of large times
    index = index - (np.bincount(piece, index) / counts)[piece]
    centred = t - (np.bincount(piece, t) / counts)[piece]
    slope = float(np.dot(index, centred) / np.dot(index, index))
    return slope, centred - slope * index


def _floor_line(index: np.ndarray, t: np.ndarray) -> tuple[float, float]:
    """``(slope, intercept)`` [s per frame, s] of the line under all of ``t`` (frame slot
    ``index[k]`` at ``t[k]``, both increasing) that lies closest to them on the whole:
    the lower convex hull's edge at the middle slot (module docstring)."""
    y = t - t[0]  # small numbers: the hull's cross products without cancellation
    hull: list[int] = []
    for k in range(t.size):  # Andrew's monotone chain, lower half
        while len(hull) >= 2:
            i, j = hull[-2], hull[-1]
            turn = (index[j] - index[i]) * (y[k] - y[i]) - (y[j] - y[i]) * (index[k] - index[i])
            if turn > 0:
                break
            hull.pop()
        hull.append(k)
    edges = np.asarray(hull)
    middle = 0.5 * (index[0] + index[-1])
    right = min(max(int(np.searchsorted(index[edges], middle, side="right")), 1), edges.size - 1)
    i, j = edges[right - 1], edges[right]
    slope = float((y[j] - y[i]) / (index[j] - index[i]))
    return slope, float(t[0] + y[i] - slope * index[i])


def _latest_slots(slots: np.ndarray) -> np.ndarray:
    """Frame slots, strictly increasing, each the latest that is not after ``slots[k]``
    rounded (a frame's place on the lattice from its stamp) and before the next frame's:
    a delayed frame takes the slot before the next frame's (delivered frames, module
    docstring). ``k + min over j >= k of (round(slots[j]) - j)``."""
    k = np.arange(slots.size, dtype=float)
    latest = np.minimum.accumulate((np.rint(slots) - k)[::-1])[::-1]
    return k + latest - latest[0]


def fit_frame_period(t: np.ndarray) -> PeriodFit:
    """The frame period fitted to all timestamps ``t`` [s] (least squares; module docstring).

    Two readings of the stamps, each a line of ``t`` against a frame index:

    - *on the lattice*: each gap is ``round(gap / median gap)`` periods (at least 1), so
      drops are counted and do not bias the period. A gap over :data:`STALL_PERIODS`
      is a stall: its count of periods is not trusted (0.3 % off in the median gap, a
      rounded PTS, makes a 170-period count wrong by one), so the runs of frames between
      stalls share the period and each has its own start. Only a reading when most
      frames come in runs of at least :data:`STALL_PERIODS` frames: frames delivered in
      bursts would otherwise read as a camera ``1 / median gap`` fast that stalls after
      every burst (a folder stamped in bursts, 24.5 fps, read as 534 fps); and only
      when at most :data:`MAX_COLLISIONS` of the gaps are under half a period (two
      frames in one slot: a camera's own stamps are never that close);
    - *delivered*: every frame is one period (the index counts frames). A frame is never
      delivered before it was taken, so the least delayed frames lie on the lattice: the
      period is the slope of the line under all stamps that lies closest to them (the
      lower convex hull's edge at the middle frame; Moon, Skelly and Towsley (1999),
      "Estimation and removal of clock skew from network delay measurements", IEEE
      INFOCOM), not the least-squares line, which the delays' drift over a recording
      moved by up to 1 %. Drops are only counted before the last frames delivered
      together: no later frame tells their delay from drops.

    The reading kept is the one whose least-squares line leaves the smaller RMS
    residual: a camera's stamps lie on
    their lattice within their jitter, while bursts put the lattice reading's count off
    by whole periods at every stall. Either way not pulled off by timestamp jitter or
    rounding (e.g. Matroska's 1 ms PTS), unlike the median interval.
    """
    t = check_times(t, "frame timestamps")
    gaps = np.diff(t)
    frames = np.arange(t.size, dtype=float)
    whole = np.zeros(t.size, int)
    period, residual = _line(frames, t, whole)
    index, piece, delivered = frames, whole, True
    periods = np.rint(gaps / np.median(gaps))
    steps = np.maximum(1.0, periods)
    stall = steps > STALL_PERIODS
    runs = np.concatenate([[0], np.cumsum(stall)])
    in_runs = np.bincount(runs)[runs] >= min(STALL_PERIODS, t.size)
    collisions = np.count_nonzero(periods == 0)  # two frames in one slot
    if 2 * np.count_nonzero(in_runs) > t.size and collisions <= MAX_COLLISIONS * gaps.size:
        lattice = np.concatenate([[0.0], np.cumsum(np.where(stall, 1.0, steps))])
        slope, rest = _line(lattice, t, runs)
        if np.dot(rest, rest) <= np.dot(residual, residual):  # a tie: no drops, same index
            period, residual, index, piece, delivered = slope, rest, lattice, runs, False
    if delivered:  # the least delayed frames lie on the lattice (module docstring)
        for _ in range(2):  # the line under the stamps, and the slots it gives them
            period, start = _floor_line(index, t)
            index = _latest_slots((t - start) / period)
        period, start = _floor_line(index, t)
        residual = t - start - period * index
    if delivered:
        # a delivered frame's slot is only the latest it can have, bounded by the next
        # frame's; the last frames, delivered together (within half a period), have no
        # next frame: held back rather than after drops (a recording that ends inside a
        # burst), one slot each after the frame before them
        held = np.flatnonzero(gaps >= 0.5 * period)
        last_bounded = int(held[-1]) if held.size else 0
        slots = int(index[last_bounded]) + t.size - 1 - last_bounded
    else:  # the runs' own slots, and each stall's length in periods
        slots = int(index[-1] + np.sum(np.rint(gaps[stall] / period) - 1.0))
    n_pieces = int(piece[-1]) + 1
    first, last = np.full(n_pieces, np.inf), np.full(n_pieces, -np.inf)
    np.minimum.at(first, piece, index)
    np.maximum.at(last, piece, index)
    measured = max(float(np.sum(last - first)), 1.0)  # periods the slope is measured over
    spread = float(residual.max() - residual.min())
    return PeriodFit(period, spread / measured, slots, int(t.size), delivered)


def frame_period(t: np.ndarray) -> float:
    """The frame period [s] fitted to all timestamps ``t`` [s] (:func:`fit_frame_period`)."""
    return fit_frame_period(t).period_s


def frame_times(t: np.ndarray) -> np.ndarray:
    """The frames' times [s] the signal is built on: a camera's own stamps ``t`` as they
    are; stamps taken on delivery (:attr:`PeriodFit.delivered`) moved back to when the
    frames were taken at the latest: each frame a period before the next, and not after
    its own delivery, ``min(t[k], time[k + 1] - period)``. A burst's stamps are late by
    up to the stall before it (0.25 s on a loaded machine, two radians of a 1.3 Hz
    slosh); its last frame came as it was sent, and the ones before it were a period
    apart. Not the lattice under all stamps: a frame dropped among delivered ones cannot
    be seen, and on that lattice every later frame would be a period early."""
    fit = fit_frame_period(t)
    if not fit.delivered:
        return np.asarray(t, dtype=float)
    k = np.arange(fit.frames) * fit.period_s
    latest = np.minimum.accumulate((np.asarray(t, dtype=float) - k)[::-1])[::-1]
    return latest + k


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
    """The videos of one trial must be one recording: VideoError otherwise
    (:func:`check_consistent_times` on each sensor's timestamps and ``start_s``)."""
    if len(tracks) < 2:
        return
    try:
        check_consistent_times(
            [tr.sensor for tr in tracks],
            [tr.t for tr in tracks],
            [float(tr.start_s) for tr in tracks],
            error=VideoError,
            what="videos",
        )
    except SignalError:  # bad timestamps: the signal says so, per sensor
        return


def check_consistent_times(
    names: Sequence[str],
    times: Sequence[np.ndarray],
    starts_s: Sequence[float],
    *,
    error: type[LiquidTouchError] = VideoError,
    what: str = "videos",
    hint: str = "give the videos of one recording",
) -> None:
    """The sensors' frame times must be one recording: ``error`` otherwise.

    ``times[i]`` are sensor ``names[i]``'s timestamps [s] (any origin), ``starts_s[i]``
    its first frame on the trial's shared clock [s]. Their frame rates
    (:func:`fit_frame_period`) agree within :data:`RATE_TOLERANCE` plus what their
    timing allows (each fit's ``uncertainty_s``: frames delivered in bursts fix the rate
    less well), and their time spans overlap over all but :data:`SPAN_TOLERANCE` of the
    longest (at least two frame periods). Frame counts may differ: sensors drop frames
    independently. Bad timestamps raise :class:`~liquidtouch.errors.SignalError`.
    """
    if len(times) < 2:
        return
    fits = [fit_frame_period(t) for t in times]
    for name, fit in zip(names[1:], fits[1:], strict=True):
        allowed = RATE_TOLERANCE + fits[0].uncertainty_s / fits[0].period_s
        allowed += fit.uncertainty_s / fit.period_s
        if not abs(fit.fps - fits[0].fps) <= allowed * fits[0].fps:
            raise error(
                f"{what} of one trial differ in frame rate: {names[0]} {fits[0].fps:.3f} "
                f"fps, {name} {fit.fps:.3f} fps (their timing allows {allowed:.1%}); {hint}"
            )
    ends = [s + float(t[-1] - t[0]) for s, t in zip(starts_s, times, strict=True)]
    longest = max(e - s for s, e in zip(starts_s, ends, strict=True))
    overlap = min(ends) - max(starts_s)
    if longest - overlap > max(2 * max(f.period_s for f in fits), SPAN_TOLERANCE * longest):
        spans = ", ".join(
            f"{n} {s:.2f}–{e:.2f} s" for n, s, e in zip(names, starts_s, ends, strict=True)
        )
        raise error(
            f"{what} of one trial differ in length: {spans} (together {max(overlap, 0):.2f} "
            f"s); {hint}"
        )
