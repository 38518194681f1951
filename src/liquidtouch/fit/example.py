"""A built-in example tactile signal with known parameters (for the demo and tests)."""

from __future__ import annotations

import numpy as np

from liquidtouch.fit.model import damped_cosine, quadratic_drift

#: true parameters of :func:`example_signal` (time from the first sample, u in px)
EXAMPLE_PARAMETERS: dict[str, float] = {
    "decay_rate": 0.35,
    "angular_frequency": 11.0,
    "amplitude": 1.0,
    "phase": 0.4,
    "fast_decay_rate": 1.8,
    "fast_angular_frequency": 12.6,
    "fast_amplitude": 0.7,
    "fast_phase": -1.1,
    "drift_c0": 0.15,
    "drift_c1": -0.04,
    "drift_c2": 0.0025,
    "noise_std": 0.02,
    "fps": 30.0,
    "duration_s": 13.0,
}


def example_signal(seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A realistic 13 s, 30 Hz two-mode slosh signal with drift, noise and dropped frames.

    Returns ``(t, u)``: time stamps [s] (1 ms jitter, ~2 % of frames dropped, as
    real sensors do) and the signal [px]; its true parameters are
    :data:`EXAMPLE_PARAMETERS`.
    """
    p = EXAMPLE_PARAMETERS
    rng = np.random.default_rng(seed)
    n = round(p["duration_s"] * p["fps"])
    t = np.arange(n) / p["fps"] + rng.normal(0.0, 1e-3, n)
    t[0] = 0.0
    keep = rng.random(n) > 0.02
    keep[[0, -1]] = True
    t = t[keep]
    slow = damped_cosine(t, p["amplitude"], p["decay_rate"], p["angular_frequency"], p["phase"])
    fast = damped_cosine(
        t, p["fast_amplitude"], p["fast_decay_rate"], p["fast_angular_frequency"], p["fast_phase"]
    )
    drift = quadratic_drift(t, p["drift_c0"], p["drift_c1"], p["drift_c2"])
    u = slow + fast + drift + rng.normal(0.0, p["noise_std"], t.size)
    return t, u
