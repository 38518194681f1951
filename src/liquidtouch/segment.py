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
"""

from __future__ import annotations

import math

import numpy as np

from liquidtouch.errors import SignalError
from liquidtouch.signal import _check_times, _finite_array
from liquidtouch.tracking.detect import as_number

MIN_FREE_DECAY_S = 2.0
DRIFT_CUTOFF_HZ = 0.3  # slower than this is slip drift, not slosh


def free_decay_start(
    t: np.ndarray, u: np.ndarray, baseline_s: float = 0.3, drift_cutoff_hz: float = DRIFT_CUTOFF_HZ
) -> int:
    """Index of the sample where the free decay starts (the largest excursion).

    ``t`` [s] (finite, strictly increasing) and ``u`` are 1-D of one length.
    ``baseline_s`` [s] of the start of the recording set the resting level;
    motion slower than ``drift_cutoff_hz`` [Hz] (slip drift) is ignored.
    """
    from scipy.signal import butter, sosfiltfilt

    t, u = _check_signal(t, u)
    if not 0 <= as_number(baseline_s) < math.inf:
        raise SignalError(f"baseline_s must be a duration >= 0 in seconds, got {baseline_s!r}")
    if not 0 < as_number(drift_cutoff_hz) < math.inf:
        raise SignalError(
            f"drift_cutoff_hz must be a frequency > 0 in Hz, got {drift_cutoff_hz!r}; "
            f"the default is {DRIFT_CUTOFF_HZ}"
        )
    rate_hz = 1.0 / float(np.median(np.diff(t)))
    if len(u) > 30 and rate_hz > 4 * drift_cutoff_hz:
        sos = butter(2, drift_cutoff_hz, btype="highpass", fs=rate_hz, output="sos")
        u = sosfiltfilt(sos, u)
    resting = float(np.median(u[t <= t[0] + baseline_s]))
    return int(np.argmax(np.abs(u - resting)))


def free_decay(t: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(t, u)`` from the start of the free decay on; time is kept absolute [s].

    Raises :class:`SignalError` for a malformed signal (see :func:`free_decay_start`)
    or when less than ``MIN_FREE_DECAY_S`` follows the push.
    """
    t, u = _check_signal(t, u)
    start = free_decay_start(t, u)
    if t[-1] - t[start] < MIN_FREE_DECAY_S:
        raise SignalError(
            f"the free decay after the push lasts only {t[-1] - t[start]:.2g} s "
            f"(peak at {t[start]:.2f} s of {t[-1]:.2f} s); record at least "
            f"{MIN_FREE_DECAY_S:.0f} s after the push"
        )
    return t[start:], u[start:]


def _check_signal(t: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    t = _check_times(t, "t")
    u = _finite_array(u, "u", min_ndim=1)
    if u.shape != t.shape:
        raise SignalError(
            f"t and u must be 1-D arrays of equal length (got shapes {t.shape} and {u.shape})"
        )
    return t, u
