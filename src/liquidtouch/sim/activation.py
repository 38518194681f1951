"""What the hand does to the container over time: the lateral push and the grasp's slip.

- The push is a minimum-jerk lateral move of the hand by ``d`` over ``D``
  seconds from ``t0``: with ``τ = (t − t0)/D`` in [0, 1] its acceleration is
  ``d/D² · (60τ − 180τ² + 120τ³)`` [m/s²], zero before and after.
- After the push the grasp creeps/slips: the loads drift by a fixed amount
  along the profile ``1 − exp(−(t − t_end)/τ)``.
"""

from __future__ import annotations

import numpy as np


def min_jerk_acceleration(
    t_s: float | np.ndarray, distance_m: float, start_s: float, duration_s: float
) -> float | np.ndarray:
    """Acceleration [m/s²] at time ``t_s`` [s] of a minimum-jerk move of ``distance_m`` [m].

    The move starts at ``start_s`` [s] and lasts ``duration_s`` [s]; zero outside.
    ``t_s`` is a float (the ODE's hot path) or an array.
    """
    tau = (t_s - start_s) / duration_s
    tau = np.clip(tau, 0.0, 1.0) if isinstance(tau, np.ndarray) else min(max(tau, 0.0), 1.0)
    scale = distance_m / duration_s**2
    return scale * (60.0 * tau - 180.0 * tau * tau + 120.0 * tau * tau * tau)


def slip_profile(t_s: np.ndarray, start_s: float, time_constant_s: float) -> np.ndarray:
    """Fraction (0-1) of the slip drift reached at ``t_s`` [s]: ``1 − exp(−(t − start)/τ)``."""
    rel = np.clip(t_s - start_s, 0.0, None)
    return 1.0 - np.exp(-rel / time_constant_s)
