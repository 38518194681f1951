"""Least-squares solves of the amplitude-damping model (:mod:`liquidtouch.fit.amplitude`).

At a fixed exponent ``p`` from the start search around the single-mode optimum, then
with ``p`` free in :data:`~liquidtouch.fit.amplitude.EXPONENT_BOUNDS` from the optimum
at each end; and the combined model (the amplitude-damped mode plus a second,
exponentially damped one) at ``p`` = :data:`~liquidtouch.fit.amplitude.TWO_MODE_EXPONENT`.
Works on the normalised signal, as :mod:`liquidtouch.fit.solve`.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import least_squares

from liquidtouch.fit import model as om
from liquidtouch.fit.amplitude import (
    EXPONENT_BOUNDS,
    N_NONLINEAR,
    TWO_MODE_EXPONENT,
    AmplitudeState,
    basis,
    curve,
    exponent_derivative,
    jacobian,
    n_nonlinear,
    nonlinear_bounds,
)
from liquidtouch.fit.solve import MAX_EVALUATIONS, FitState, best_optimum, with_free_linear
from liquidtouch.fit.start import amplitude_starts, spectral_peaks

__all__ = [
    "optimise_amplitude",
    "optimise_amplitude_ends",
    "optimise_amplitude_two_mode",
    "without_gain",
]


def _solve(
    theta_nl: np.ndarray,
    exponent: float,
    tau: np.ndarray,
    drift_basis: np.ndarray,
    u: np.ndarray,
    sqrt_w: np.ndarray,
    band: tuple[float, float],
) -> AmplitudeState:
    """Least squares at a fixed exponent ``p``, from the start ``theta_nl``."""
    second = theta_nl.size == n_nonlinear(True)
    lo_nl, hi_nl = nonlinear_bounds(theta_nl.size, band)
    span = hi_nl - lo_nl
    theta_nl = np.clip(theta_nl, lo_nl + 1e-6 * span, hi_nl - 1e-6 * span)
    lin, _ = om.solve_linear(basis(tau, drift_basis, theta_nl, exponent, second), u, sqrt_w)
    theta0 = np.concatenate([theta_nl, lin])
    lo, hi = with_free_linear(lo_nl, hi_nl, theta0.size)

    def fun(theta: np.ndarray) -> np.ndarray:
        return sqrt_w * (curve(theta, tau, drift_basis, exponent, second) - u)

    def jac(theta: np.ndarray) -> np.ndarray:
        return sqrt_w[:, None] * jacobian(theta, tau, drift_basis, exponent, second)

    res = least_squares(
        fun, theta0, jac=jac, bounds=(lo, hi), method="trf", x_scale="jac", max_nfev=MAX_EVALUATIONS
    )
    cost = float(2 * res.cost)
    return AmplitudeState(
        1 + int(second), res.x, tau, drift_basis, u, sqrt_w, cost, exponent=exponent, second=second
    )


def _free_exponent(start: AmplitudeState, band: tuple[float, float]) -> AmplitudeState:
    """Least squares with ``p`` free in :data:`EXPONENT_BOUNDS`, from the optimum ``start``.

    The parameter vector is θ with ``p`` after the nonlinear parameters.
    """
    tau, drift_basis, u, sqrt_w, second = (
        start.tau,
        start.drift_basis,
        start.u,
        start.sqrt_w,
        start.second,
    )
    k = n_nonlinear(second)
    lo_nl, hi_nl = nonlinear_bounds(k, band)
    n_lin = start.theta.size - k
    lo = np.concatenate([lo_nl, [EXPONENT_BOUNDS[0]], np.full(n_lin, -np.inf)])
    hi = np.concatenate([hi_nl, [EXPONENT_BOUNDS[1]], np.full(n_lin, np.inf)])
    full = np.concatenate([start.theta[:k], [start.exponent], start.theta[k:]])
    span = np.where(np.isfinite(hi - lo), hi - lo, 0.0)
    full = np.clip(full, lo + 1e-6 * span, hi - 1e-6 * span)

    def split(v: np.ndarray) -> tuple[np.ndarray, float]:
        return np.concatenate([v[:k], v[k + 1 :]]), float(v[k])

    def fun(v: np.ndarray) -> np.ndarray:
        theta, exponent = split(v)
        return sqrt_w * (curve(theta, tau, drift_basis, exponent, second) - u)

    def jac(v: np.ndarray) -> np.ndarray:
        theta, exponent = split(v)
        full_jac = jacobian(theta, tau, drift_basis, exponent, second)
        d_exp = exponent_derivative(theta, tau, drift_basis, exponent, second)
        return sqrt_w[:, None] * np.column_stack([full_jac[:, :k], d_exp, full_jac[:, k:]])

    res = least_squares(
        fun, full, jac=jac, bounds=(lo, hi), method="trf", x_scale="jac", max_nfev=MAX_EVALUATIONS
    )
    theta, exponent = split(res.x)
    return AmplitudeState(
        start.n_modes,
        theta,
        tau,
        drift_basis,
        u,
        sqrt_w,
        float(2 * res.cost),
        exponent=exponent,
        second=second,
        exponent_free=True,
    )


def optimise_amplitude_ends(
    tau: np.ndarray,
    drift_basis: np.ndarray,
    u: np.ndarray,
    sqrt_w: np.ndarray,
    band: tuple[float, float],
    single: FitState,
) -> list[AmplitudeState]:
    """The amplitude-damping optimum at each end of :data:`EXPONENT_BOUNDS` (p held).

    Each is the best of the starts of :func:`~liquidtouch.fit.start.amplitude_starts`
    around the single-mode optimum ``single``.
    """
    lam, omega = float(single.rates[0]), float(single.freqs[0])
    return [
        best_optimum(
            _solve(np.array(s), p, tau, drift_basis, u, sqrt_w, band)
            for s in amplitude_starts(lam, omega)
        )
        for p in EXPONENT_BOUNDS
    ]


def optimise_amplitude(ends: list[AmplitudeState], band: tuple[float, float]) -> AmplitudeState:
    """Amplitude-damping fit with ``p`` free, from the fixed-exponent optima ``ends``.

    ``p`` is freed from each (:func:`optimise_amplitude_ends`) and the lower cost
    kept (module docstring). Whether the gain is supported at all (against the
    single mode) is decided by the caller (:mod:`liquidtouch.fit.selection`;
    :func:`without_gain`).
    """
    fits = [_free_exponent(s, band) for s in ends if math.isfinite(s.cost)]
    return best_optimum(fits or ends)


def without_gain(single: FitState, exponent: float) -> AmplitudeState:
    """The single-mode optimum as an amplitude-damping state with g = 0 held fixed.

    λ0 is then the single-mode λ with its std (a constant-rate signal, or too short
    a decay to tell λ0 from κ).
    """
    theta = np.concatenate([single.theta[:2], [0.0], single.theta[2:]])
    return AmplitudeState(
        1,
        theta,
        single.tau,
        single.drift_basis,
        single.u,
        single.sqrt_w,
        single.cost,
        exponent=exponent,
        gain_fixed=True,
    )


def optimise_amplitude_two_mode(
    tau: np.ndarray,
    drift_basis: np.ndarray,
    u: np.ndarray,
    sqrt_w: np.ndarray,
    band: tuple[float, float],
    amplitude: AmplitudeState,
    two: FitState | None,
) -> AmplitudeState:
    """Both together: the amplitude-damped mode plus a second, exponentially damped mode.

    Started from ``amplitude``, the amplitude fit at ``p =`` :data:`TWO_MODE_EXPONENT`
    (λ0, ω, g), with the second mode at the two-mode fit's other mode (``two``) and
    at the strongest peak of that fit's residual.
    """
    lam0, omega, gain = amplitude.theta[:N_NONLINEAR]
    gain = max(float(gain), 0.3)
    peak = spectral_peaks(tau, amplitude.residual(), band, n_peaks=1)[0]
    seconds = [(2.0 * lam0 + 0.5, peak)]
    if two is not None:  # its mode farther from ω
        i = int(np.argmax(np.abs(two.freqs - omega)))
        seconds.append((float(two.rates[i]), float(two.freqs[i])))
    fits = [
        _solve(
            np.array([lam0, omega, gain, r, w]),
            TWO_MODE_EXPONENT,
            tau,
            drift_basis,
            u,
            sqrt_w,
            band,
        )
        for r, w in seconds
    ]
    return best_optimum(fits)
