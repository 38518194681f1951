"""Signals of non-linearly damped oscillators with a known small-amplitude decay rate.

For tests and benchmarks of the amplitude-damping fit
(:mod:`liquidtouch.fit.amplitude`): the oscillator is integrated numerically
(not drawn from the fit's own envelope), so the fit is checked against physics,
not against itself. Each returns ``u = ε''`` (what an accelerometer or a force
sensor sees) scaled to a peak of 1, plus a quadratic drift and white noise.

Harmonic balance (slowly varying amplitude ``A`` of ``ε``) gives the envelope
law each oscillator follows, ``λ(A) = λ0 (1 + κ A^p)`` in the units of ``ε``:

- :func:`cubic_damper_signal`: ``ε'' + 2λ0 (1 + k ε²) ε' + ω0² ε = 0`` →
  ``p = 2``, ``κ = k / 4``;
- :func:`quadratic_damper_signal`: ``ε'' + 2λ0 ε' + c |ε'| ε' + ω0² ε = 0`` (a
  velocity-squared damper) → ``p = 1``, ``κ = 4 c ω0 / (3π λ0)``;
- :func:`duffing_signal`: the cubic damper with a softening (or hardening) spring,
  ``ω0² ε (1 − s ε²)``: its frequency moves with the amplitude too,
  ``ω(A) ≈ ω0 (1 − 3 s A² / 8)`` (:mod:`liquidtouch.fit.drifting_line`).
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

#: default drift coefficients (c0, c1 [1/s], c2 [1/s²]) added to the signals
DRIFT = (0.1, -0.02, 0.0015)


def _signal(
    t: np.ndarray,
    acceleration,
    sigma: float,
    rng: np.random.Generator,
    drift: tuple[float, float, float],
) -> np.ndarray:
    sol = solve_ivp(
        lambda _t, y: [y[1], acceleration(y[0], y[1])],
        (float(t[0]), float(t[-1])),
        [1.0, 0.0],
        t_eval=t,
        rtol=1e-9,
        atol=1e-11,
    )
    acc = acceleration(*sol.y)
    acc = acc / np.abs(acc).max()
    return acc + drift[0] + drift[1] * t + drift[2] * t * t + rng.normal(0, sigma, t.size)


def cubic_damper_signal(
    t: np.ndarray,
    decay_rate: float,
    angular_frequency: float,
    gain: float,
    sigma: float,
    rng: np.random.Generator,
    drift: tuple[float, float, float] = DRIFT,
) -> np.ndarray:
    """``u = ε''`` of ``ε'' + 2λ0 (1 + k ε²) ε' + ω0² ε = 0``, ``ε(0) = 1``, ``ε'(0) = 0``.

    ``t`` [s] from 0; ``decay_rate`` λ0 [1/s], ``angular_frequency`` the damped
    small-amplitude ω [rad/s] (``ω0² = ω² + λ0²``), ``gain`` k [1/ε²]: the early
    rate is about ``λ0 (1 + k/4)``; ``sigma`` the noise std (peak of u is 1).
    """
    w0sq = angular_frequency**2 + decay_rate**2

    def acceleration(eps, vel):
        return -2 * decay_rate * (1 + gain * eps * eps) * vel - w0sq * eps

    return _signal(np.asarray(t, dtype=float), acceleration, sigma, rng, drift)


def quadratic_damper_signal(
    t: np.ndarray,
    decay_rate: float,
    angular_frequency: float,
    drag: float,
    sigma: float,
    rng: np.random.Generator,
    drift: tuple[float, float, float] = DRIFT,
) -> np.ndarray:
    """``u = ε''`` of ``ε'' + 2λ0 ε' + c |ε'| ε' + ω0² ε = 0``, ``ε(0) = 1``, ``ε'(0) = 0``.

    ``drag`` c [1/ε]: the early rate is about ``λ0 + 4 c ω0 / (3π)``; other
    arguments as :func:`cubic_damper_signal`.
    """
    w0sq = angular_frequency**2 + decay_rate**2

    def acceleration(eps, vel):
        return -2 * decay_rate * vel - drag * np.abs(vel) * vel - w0sq * eps

    return _signal(np.asarray(t, dtype=float), acceleration, sigma, rng, drift)


def duffing_signal(
    t: np.ndarray,
    decay_rate: float,
    angular_frequency: float,
    gain: float,
    softening: float,
    sigma: float,
    rng: np.random.Generator,
    drift: tuple[float, float, float] = DRIFT,
) -> np.ndarray:
    """``u = ε''`` of ``ε'' + 2λ0 (1 + k ε²) ε' + ω0² ε (1 − s ε²) = 0``, ``ε(0) = 1``,
    ``ε'(0) = 0``.

    ``softening`` s [1/ε²] (negative: a hardening spring); other arguments as
    :func:`cubic_damper_signal` (``angular_frequency`` the damped small-amplitude ω).
    """
    w0sq = angular_frequency**2 + decay_rate**2

    def acceleration(eps, vel):
        return -2 * decay_rate * (1 + gain * eps * eps) * vel - w0sq * eps * (
            1 - softening * eps * eps
        )

    return _signal(np.asarray(t, dtype=float), acceleration, sigma, rng, drift)
