"""Frame timing: the frame period fitted to timestamps, and the uniform clock built on it.

Real sensors jitter, drop frames and store rounded timestamps (Matroska keeps 1 ms).
The signal stage resamples every sensor onto one uniform clock whose step is the
period fitted to *all* timestamps (:func:`frame_period`), not the median interval:
the median misses the real period by ~0.3 % under jitter or rounding, and the
interpolation's phase against the frames then drifts through the decay and moves
λ by several per cent. Also the input checks of time arrays shared by the stages.
"""

from __future__ import annotations

import math

import numpy as np

from liquidtouch.errors import SignalError
from liquidtouch.tracking.detect import as_number


def finite_array(x: object, what: str, min_ndim: int) -> np.ndarray:
    try:
        x = np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        raise SignalError(f"{what} must be an array of real numbers") from None
    if x.ndim < min_ndim or x.size == 0:
        raise SignalError(f"{what} must be a non-empty {min_ndim}-D array, got shape {x.shape}")
    if not np.isfinite(x).all():
        raise SignalError(f"{what} holds NaN/inf values; interpolate or drop them first")
    return x


def check_times(t: object, what: str) -> np.ndarray:
    """Timestamps [s] as a 1-D float array: finite, strictly increasing, at least 2."""
    t = finite_array(t, what, min_ndim=1)
    if t.ndim != 1 or t.size < 2 or not np.all(np.diff(t) > 0):
        raise SignalError(
            f"{what} must be a 1-D array of at least 2 strictly increasing times [s] "
            f"(got shape {t.shape}); sort the frames and drop duplicates"
        )
    return t


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
