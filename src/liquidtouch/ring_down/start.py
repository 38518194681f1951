"""Where the free decay starts: the fit covers the sloshing after the push, not the push.

During the push the hand drives the liquid, so the signal there does not follow
the free damped-oscillation model (and a fit across it finds no oscillation).
The free decay starts at the largest excursion of the signal from its
pre-push level: after that peak the hand is still and the liquid rings down.
Slow in-hand slip adds a drift that can end further from the resting level
than the push went (a viscous liquid rings down in a second), so the
excursion is measured on the signal with its slow part removed: a zero-phase
high-pass well below any hand-held slosh (≥ ~1 Hz for containers up to ~30 cm
long), above the drift.

When the free decay after that peak is too short to fit, the peak is first
checked against the noise: a push stands out of the signal before it
(:func:`push_snr`: the peak's distance from the median of the high-passed
signal up to ``PUSH_GAP_S`` before it, over that signal's robust noise level,
1.4826 × MAD). Below :data:`MIN_PUSH_SNR` the largest excursion is just the
noise of a still recording, and the error says "no push found" instead of
asking for a longer recording. Measured: on 32 simulated trials (water, sugar
water, mirin, olive and corn oil, detergent; both sensor profiles; ~1 s of
signal before the push) a push stands 26–64× above the noise before it; on
low-passed (3 Hz) white noise (400 draws each at 25–100 fps, 4–60 s) the
largest excursion reaches at most 10.5× (filter edge effects), a still
simulated GelSight video 4.8×.

A whole trial (grasp, lift, push, hold, lower, release) is split by
:mod:`liquidtouch.ring_down.segments`, which also chooses the ring-down that
:func:`~liquidtouch.ring_down.free_decay` fits.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.signal import butter, sosfiltfilt

from liquidtouch._core.checks import as_number, check_times, finite_array
from liquidtouch.errors import SignalError
from liquidtouch.fit.oscillation import GAP_STEPS

__all__ = [
    "DRIFT_CUTOFF_HZ",
    "MIN_FREE_DECAY_S",
    "MIN_NOISE_S",
    "MIN_PUSH_SNR",
    "PUSH_GAP_S",
    "check_signal",
    "excursion",
    "free_decay_start",
    "highpass",
    "push_snr",
]

MIN_FREE_DECAY_S = 2.0
DRIFT_CUTOFF_HZ = 0.3  # slower than this is slip drift, not slosh
#: a push's excursion stands at least this many noise levels above the signal before it
MIN_PUSH_SNR = 15.0
PUSH_GAP_S = 0.5  # the push itself: left out of the noise level before the peak
MIN_NOISE_S = 2.0  # less signal before the peak: its noise level is not judged


def free_decay_start(
    t: np.ndarray, u: np.ndarray, baseline_s: float = 0.3, drift_cutoff_hz: float = DRIFT_CUTOFF_HZ
) -> int:
    """Index of the sample where the free decay starts (the largest excursion).

    ``t`` [s] (finite, strictly increasing) and ``u`` are 1-D of one length.
    ``baseline_s`` [s] of the start of the recording set the resting level;
    motion slower than ``drift_cutoff_hz`` [Hz] (slip drift) is ignored.
    """
    t, u = check_signal(t, u)
    return excursion(t, u, baseline_s, drift_cutoff_hz)[0]


def highpass(t: np.ndarray, x: np.ndarray, cutoff_hz: float) -> np.ndarray:
    """Zero-phase 2nd-order high-pass of ``x`` [(T,) or (T, C)] at ``cutoff_hz`` [Hz].

    ``t`` [s] may have gaps (samples never observed, longer than ``GAP_STEPS`` median
    steps): the filter then runs on a uniform grid through them and is read back at the
    observed samples only.
    """
    step = float(np.median(np.diff(t)))
    sos = butter(2, cutoff_hz, btype="highpass", fs=1.0 / step, output="sos")
    if np.diff(t).max() <= GAP_STEPS * step:
        return sosfiltfilt(sos, x, axis=0)
    grid = t[0] + step * np.arange(int(np.floor((t[-1] - t[0]) / step)) + 1)
    columns = x[:, None] if x.ndim == 1 else x
    filled = np.column_stack([np.interp(grid, t, c) for c in columns.T])
    back = np.column_stack([np.interp(t, grid, c) for c in sosfiltfilt(sos, filled, axis=0).T])
    return back[:, 0] if x.ndim == 1 else back


def excursion(
    t: np.ndarray,
    u: np.ndarray,
    baseline_s: float = 0.3,
    drift_cutoff_hz: float = DRIFT_CUTOFF_HZ,
) -> tuple[int, np.ndarray]:
    """Index of the largest excursion and the high-passed signal minus its resting level."""

    if not 0 <= as_number(baseline_s) < math.inf:
        raise SignalError(f"baseline_s must be a duration >= 0 in seconds, got {baseline_s!r}")
    if not 0 < as_number(drift_cutoff_hz) < math.inf:
        raise SignalError(
            f"drift_cutoff_hz must be a frequency > 0 in Hz, got {drift_cutoff_hz!r}; "
            f"the default is {DRIFT_CUTOFF_HZ}"
        )
    if len(u) > 30 and 1.0 / float(np.median(np.diff(t))) > 4 * drift_cutoff_hz:
        u = highpass(t, u, drift_cutoff_hz)
    resting = float(np.median(u[t <= t[0] + baseline_s]))
    excursion = np.abs(u - resting)
    return int(np.argmax(excursion)), u - resting


def push_snr(
    t: np.ndarray, u: np.ndarray, start: int | None = None, *, min_noise_s: float = MIN_NOISE_S
) -> float:
    """How far the largest excursion stands above the noise before it (module docstring).

    With ``b`` the high-passed signal up to ``PUSH_GAP_S`` before the peak, returns
    ``|peak − median(b)| / (1.4826 × MAD(b))``; NaN when ``b`` spans less than
    ``min_noise_s`` [s] (default ``MIN_NOISE_S``; the streaming estimator judges a
    push on less), inf when its samples are all equal.
    """
    t, u = check_signal(t, u)
    peak, centred = excursion(t, u)
    peak = peak if start is None else int(start)
    quiet = t < t[peak] - PUSH_GAP_S
    if not quiet.any() or t[quiet][-1] - t[0] < min_noise_s:
        return math.nan
    before = centred[quiet]
    level = float(np.median(before))
    noise = 1.4826 * float(np.median(np.abs(before - level)))
    return abs(float(centred[peak]) - level) / noise if noise > 0 else math.inf


def check_signal(t: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    t = check_times(t, "t")
    u = finite_array(u, "u", min_ndim=1)
    if u.shape != t.shape:
        raise SignalError(
            f"t and u must be 1-D arrays of equal length (got shapes {t.shape} and {u.shape})"
        )
    return t, u
