"""Simulated camera timing: when each frame of a GelSight recording was taken.

Real sensor clocks run slightly off nominal, jitter and drop frames; the signal
stage must cope with all three (:mod:`liquidtouch.tracking.clock`), so the simulator
produces them (:attr:`~liquidtouch.sim.sensors.SensorProfile.rate_factor`,
``jitter_std_s``, ``drop_probability``).
"""

from __future__ import annotations

import numpy as np

from liquidtouch.errors import LiquidTouchError
from liquidtouch.sim.encode import PTS_RATE_HZ
from liquidtouch.sim.sensors import SensorProfile, get_sensor_profile


def frame_timestamps(
    duration_s: float,
    profile: SensorProfile | str,
    rng: np.random.Generator,
    *,
    jitter: bool = True,
    drops: bool = True,
) -> tuple[np.ndarray, np.ndarray]:
    """Frame times [s] and nominal frame indices of a recording lasting ``duration_s``.

    With ``jitter`` the clock runs at ``rate_factor`` × nominal rate and each frame
    is shifted by Gaussian jitter (clipped to ±30 % of a period, so times stay
    increasing); with ``drops`` frames are dropped independently with
    ``drop_probability`` (never the first). Times are rounded to the video time
    base (1/90000 s) so that stored timestamps equal the decoded PTS.
    """
    profile = get_sensor_profile(profile)
    if not np.isfinite(duration_s) or duration_s <= 0:
        raise LiquidTouchError(f"recording duration must be positive, got {duration_s}")
    period = 1.0 / (profile.fps * (profile.rate_factor if jitter else 1.0))
    n = int(np.floor(duration_s / period + 1e-9)) + 1
    index = np.arange(n)
    t = index * period
    if jitter and profile.jitter_std_s > 0:
        noise = rng.normal(0.0, profile.jitter_std_s, n)
        noise[0] = 0.0
        t = t + np.clip(noise, -0.3 * period, 0.3 * period)
        t = np.clip(t, 0.0, duration_s)
    if drops and profile.drop_probability > 0:
        keep = rng.random(n) >= profile.drop_probability
        keep[0] = True
        t, index = t[keep], index[keep]
    t = np.round(t * PTS_RATE_HZ) / PTS_RATE_HZ
    keep = np.concatenate([[True], np.diff(t) > 0])
    return t[keep], index[keep]
