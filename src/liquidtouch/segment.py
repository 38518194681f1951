"""Where the free decay starts: the fit covers the sloshing after the push, not the push.

During the push the hand drives the liquid, so the signal there does not follow
the free damped-oscillation model (and a fit across it finds no oscillation).
The free decay starts at the largest excursion of the signal from its
pre-push level: after that peak the hand is still and the liquid rings down.
"""

from __future__ import annotations

import numpy as np

from liquidtouch.errors import SignalError

MIN_FREE_DECAY_S = 2.0


def free_decay_start(t: np.ndarray, u: np.ndarray, baseline_s: float = 0.3) -> int:
    """Index of the sample where the free decay starts (the largest excursion).

    ``baseline_s`` [s] of the start of the recording set the resting level.
    """
    t, u = np.asarray(t, float), np.asarray(u, float)
    resting = float(np.median(u[t <= t[0] + baseline_s])) if len(u) else 0.0
    return int(np.argmax(np.abs(u - resting)))


def free_decay(t: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(t, u)`` from the start of the free decay on; time is kept absolute [s]."""
    start = free_decay_start(t, u)
    if t[-1] - t[start] < MIN_FREE_DECAY_S:
        raise SignalError(
            f"the free decay after the push lasts only {t[-1] - t[start]:.2g} s "
            f"(peak at {t[start]:.2f} s of {t[-1]:.2f} s); record at least "
            f"{MIN_FREE_DECAY_S:.0f} s after the push"
        )
    return t[start:], u[start:]
