"""The zero-phase low-pass of the marker motion, and how it runs across gaps.

:func:`lowpass` is a Butterworth low-pass run forwards and backwards (``sosfiltfilt``), at
:data:`DEFAULT_LOWPASS_HZ` unless asked otherwise. Frames that never came are not invented:
:func:`max_bridged_gap_s` says how long a stretch without frames may be and still be
interpolated, :func:`observed_samples` which clock samples lie in longer gaps, and
:func:`lowpass_observed` filters each observed stretch on its own, its ends at a gap first
continued by linear prediction. :mod:`liquidtouch.signal` builds ``u(t)`` with them.
"""

from __future__ import annotations

import math

import numpy as np

from liquidtouch._core.checks import as_number
from liquidtouch.clock import finite_array
from liquidtouch.errors import SignalError
from liquidtouch.linear_prediction import AR_ORDER, predict_edges

__all__ = [
    "DEFAULT_LOWPASS_HZ",
    "EDGE_PERIODS",
    "GAP_PERIODS",
    "LOWPASS_PADLEN",
    "SLOSH_MAX_HZ",
    "lowpass",
    "lowpass_observed",
    "max_bridged_gap_s",
    "observed_samples",
]

#: the low-pass cut-off [Hz] unless one is asked for, by the API and the command line alike.
#: Not 3 Hz: a broad slosh line (detergent: ω ≈ 14.5 rad/s, λ 3-6 1/s) reaches into a 3 Hz
#: roll-off, and the filter's response at the release biased a one-mode fit's λ 5-9 % low
#: (noise-free) and the default fit's 5-15 % low (0.02 px marker noise); at 4 Hz both are
#: within 2 % up to λ 4.5/s. Higher is not better: 5 Hz let in more noise, and the push
#: spread through video grew (1.7 % at 4 Hz, 4.8 % at 5 Hz, 3.1 % at 3 Hz). Measured by
#: ``benchmarks/lowpass_bias.py`` and ``push_invariance.py``; RESULTS.md "# low-pass bias".
DEFAULT_LOWPASS_HZ = 4.0
#: the fastest slosh the signal is for [Hz]: the catalogue's containers slosh at 1.9-2.6 Hz
#: (``_core.containers``); the stretches bridged across dropped frames keep it (Nyquist)
SLOSH_MAX_HZ = 3.0
#: without a low-pass, a stretch without frames longer than this many frame periods is a gap
GAP_PERIODS = 2.0
#: a stretch's end at a gap is predicted this many cut-off periods on before the low-pass
#: (the 4th-order Butterworth's response to a step has settled to < 1 % by then)
EDGE_PERIODS = 3.0


def max_bridged_gap_s(lowpass_hz: float | None, fps: float) -> float:
    """Longest stretch without frames [s] that is interpolated rather than left out.

    Half the period of the low-pass cut-off, ``1 / (2 f_c)``, with ``f_c`` at most
    :data:`SLOSH_MAX_HZ`: the filtered slosh holds nothing faster, so samples that far
    apart still catch it (Nyquist); a longer stretch lost motion that no interpolation
    can recover. A cut-off above the slosh (the default) passes the tail of a broad line
    and noise there, which interpolation need not keep, so it does not shorten the
    stretches bridged (0.17 s). At least :data:`GAP_PERIODS`
    frame periods; that alone without a low-pass.
    """
    least = GAP_PERIODS / fps
    if lowpass_hz is None:
        return least
    return max(least, 0.5 / min(float(lowpass_hz), SLOSH_MAX_HZ))


def observed_samples(t_frames: np.ndarray, t_clock: np.ndarray, max_gap_s: float) -> np.ndarray:
    """Which clock times ``t_clock`` [s] are observed: not inside a stretch without frames
    longer than ``max_gap_s`` [s]. ``t_frames`` [s], on the same clock, increasing."""
    gaps = np.diff(t_frames)
    k = np.clip(np.searchsorted(t_frames, t_clock, side="right"), 1, t_frames.size - 1)
    inside = (t_clock > t_frames[k - 1]) & (t_clock < t_frames[k])
    return ~(inside & (gaps[k - 1] > max_gap_s))


def lowpass_observed(
    x: np.ndarray, observed: np.ndarray, fps: float, cutoff_hz: float
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`lowpass` of each contiguous stretch of ``observed`` rows of ``x`` on its own.

    Returns ``(filtered, observed)``: a stretch too short to filter is marked not
    observed (its rows are left as they were). Without gaps this is :func:`lowpass`.
    An end of a stretch at a gap is first continued by linear prediction
    (:func:`~liquidtouch.linear_prediction.predict_edges`) over the filter's settling
    time and the continuation dropped after filtering: the filter's own
    odd-reflection padding bent the oscillation there by 3-19 % of its amplitude
    for ~0.5 s on each side of a stall. The continuation is never part of the output.
    """
    if observed.all():
        return lowpass(x, fps, cutoff_hz), observed
    out, observed = x.copy(), observed.copy()
    edges = np.flatnonzero(np.diff(np.concatenate([[0], observed.astype(int), [0]])))
    pad = math.ceil(EDGE_PERIODS * fps / cutoff_hz)
    for begin, end in zip(edges[0::2], edges[1::2], strict=True):
        if end - begin <= LOWPASS_PADLEN:
            observed[begin:end] = False
            continue
        # the recording's own ends are filtered as without gaps; a stretch too short to
        # fit a prediction to is filtered as it is
        predictable = end - begin >= 3 * AR_ORDER
        before = pad if begin > 0 and predictable else 0
        after = pad if end < len(x) and predictable else 0
        extended = predict_edges(x[begin:end], before, after) if predictable else x[begin:end]
        out[begin:end] = lowpass(extended, fps, cutoff_hz)[before : before + end - begin]
    return out, observed


def lowpass(
    x: np.ndarray, fps: float, cutoff_hz: float = DEFAULT_LOWPASS_HZ, order: int = 4
) -> np.ndarray:
    """Zero-phase Butterworth low-pass of ``x`` along axis 0 (``sosfiltfilt``)."""
    from scipy.signal import butter, sosfiltfilt

    x = finite_array(x, "the motion to low-pass", min_ndim=1)
    if not 0 < as_number(fps) < math.inf:
        raise SignalError(f"fps must be a frame rate > 0 in Hz, got {fps!r}")
    if isinstance(order, bool) or not isinstance(order, int | np.integer) or order < 1:
        raise SignalError(f"the filter order must be a whole number >= 1, got {order!r}")
    nyquist = 0.5 * fps
    if not 0 < cutoff_hz < nyquist:
        raise SignalError(
            f"low-pass cut-off {cutoff_hz} Hz must lie between 0 and the Nyquist "
            f"frequency {nyquist:.3g} Hz of a {fps:.3g} fps recording"
        )
    sos = butter(order, cutoff_hz, fs=fps, output="sos")
    padlen = 3 * (2 * len(sos) + 1)  # LOWPASS_PADLEN for the default order
    if x.shape[0] <= padlen:
        raise SignalError(
            f"only {x.shape[0]} frames; at least {padlen + 1} are needed to filter the motion"
        )
    return sosfiltfilt(sos, x, axis=0)


#: samples ``sosfiltfilt`` pads with for the default 4th-order low-pass (2 sections)
LOWPASS_PADLEN = 3 * (2 * 2 + 1)
