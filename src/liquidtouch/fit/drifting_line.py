"""A frequency that drifts with the amplitude: one slosh mode whose damping and frequency both
change as it dies (the "drifting line").

A restoring force that is not linear (a softening or hardening spring, ``ω0² ε (1 − s ε²)``;
a slosh's frequency falls with its height) moves the frequency with the amplitude ``A``:
harmonic balance (the Duffing oscillator) gives ``ω(A) ≈ ω0 (1 − 3 s A² / 8)``, a shift
growing with ``A²``. Its damping grows with ``A²`` as well (:mod:`liquidtouch.fit.amplitude`
at ``p = 2``: a cubic damper, the slosh's steepness-squared losses), so::

    λ(A) = λ0 (1 + κ A²),   ω(A) = ω0 (1 + η A²).

``λ0`` and ``ω0`` are the small-amplitude limits: the same features as every other model
reports (a property of the liquid and fill, whatever the push). With ``g = κ A0²`` and
``f = η A0²`` (the relative excess damping and frequency shift at the window start, free of
the unit of ``u``) the envelope is :func:`~liquidtouch.fit.amplitude.envelope` at ``p = 2``
and the phase is::

    φ(τ) = ω0 τ + ω0 f ∫_0^τ (A/A0)² ds = ω0 τ + ω0 f L(τ),
    L(τ) = ln(1 + g (1 − e^{−2λ0τ})) / (2 λ0 g)     (→ (1 − e^{−2λ0τ}) / (2λ0) as g → 0).

A non-linear oscillation is not a pure cosine: the same non-linearity drives a third
harmonic, ``∝ A³`` at the phase ``3φ`` (harmonic balance; a sensor that sees acceleration or
force sees it 9× stronger than the displacement's). On the validation's cubic dampers it is
2-9 % of the fundamental; left out, a second "mode" at 3ω took its place and moved ω by
0.2-0.4 % (``benchmarks/fit/validation.py``). The fitted signal is::

    u(τ) = A(τ) cos(φ(τ) + ψ) + A3 (A(τ)/A0)³ cos(3φ(τ) + ψ3) + quadratic drift,

linear in the cosine/sine amplitudes of both harmonics and the drift (solved exactly for any
start, as in :mod:`liquidtouch.fit.model`). Parameter vector:
``[λ0, ω0, g, f, a1, b1, a3, b3, d0, d1, d2]``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from liquidtouch.fit import model as om
from liquidtouch.fit.amplitude import GAIN_MAX, AmplitudeState, envelope
from liquidtouch.fit.solve import (
    MAX_EVALUATIONS,
    RATE_MAX,
    FitState,
    std_from_variance,
    with_free_linear,
)

__all__ = ["DriftingLineState", "drifting_cosine", "optimise_drifting_line"]

#: the exponent of both laws: A², the lowest order of a symmetric non-linearity (module docstring)
EXPONENT = 2.0
#: largest |f| = |ω(A0)/ω0 − 1|: a line that moves by half its frequency is no longer one
#: slosh mode (a bound for the optimiser; the validation's softening springs move by ≤ 8 %)
SHIFT_MAX = 0.5
#: smallest λ0 [1/s] of the solve: L(τ) divides by λ0; far below any slosh's (≥ 0.01 1/s)
RATE_MIN = 1e-6
#: g·(1 − e^{−2λ0τ}) below this: the series of L and dL/dg in g (error < 1e-8 of the term)
SERIES_BELOW = 1e-4
#: the harmonics of the mode fitted: the fundamental and the third, the first that a
#: symmetric non-linearity (cubic spring or damper) drives, with the envelope E³ and phase 3φ
#: (harmonic balance); a sensor that sees acceleration or force sees it 9× stronger than ε
HARMONICS = (1, 3)
N_NONLINEAR = 4


def _phase_integral(tau: np.ndarray, rate: float, gain: float) -> tuple[np.ndarray, ...]:
    """``L(τ)``, ``dL/dλ0``, ``dL/dg`` and ``q = e^{−2λ0τ}``, ``G = 1 + g(1 − q)`` (docstring)."""
    q = np.exp(-EXPONENT * rate * tau)
    m = -np.expm1(-EXPONENT * rate * tau)
    grown = 1.0 + gain * m
    gm = gain * m
    small = gm < SERIES_BELOW
    safe_gain = gain if gain > 0 else 1.0
    # ℓ = ln(1 + g m) / g and dℓ/dg, by their series in g where g m is small
    ell = np.where(small, m * (1.0 - 0.5 * gm), np.log1p(gm) / safe_gain)
    d_ell_gain = np.where(
        small, -0.5 * m * m + (2.0 / 3.0) * gain * m**3, (m / grown - ell) / safe_gain
    )
    integral = ell / (EXPONENT * rate)
    d_rate = (tau * q / grown - integral) / rate  # dℓ/dλ0 = 2τq/G
    d_gain = d_ell_gain / (EXPONENT * rate)
    return integral, d_rate, d_gain, q, grown


def _basis(tau: np.ndarray, drift_basis: np.ndarray, theta_nl: np.ndarray) -> np.ndarray:
    """Design matrix: ``E^k cos kφ``, ``E^k sin kφ`` for each harmonic k, the drift's columns."""
    rate, omega, gain, shift = theta_nl[:N_NONLINEAR]
    integral = _phase_integral(tau, rate, gain)[0]
    phase = omega * (tau + shift * integral)
    env = envelope(tau, rate, gain, EXPONENT)
    cols = np.empty((tau.size, 2 * len(HARMONICS) + drift_basis.shape[1]))
    for i, k in enumerate(HARMONICS):
        cols[:, 2 * i] = env**k * np.cos(k * phase)
        cols[:, 2 * i + 1] = env**k * np.sin(k * phase)
    cols[:, -drift_basis.shape[1] :] = drift_basis
    return cols


def curve(theta: np.ndarray, tau: np.ndarray, drift_basis: np.ndarray) -> np.ndarray:
    """The model's value at each sample."""
    return _basis(tau, drift_basis, theta) @ theta[N_NONLINEAR:]


def jacobian(theta: np.ndarray, tau: np.ndarray, drift_basis: np.ndarray) -> np.ndarray:
    """Analytic Jacobian ``d curve / d theta``, shape ``(n, theta.size)``."""
    rate, omega, gain, shift = theta[:N_NONLINEAR]
    design = _basis(tau, drift_basis, theta)
    integral, d_int_rate, d_int_gain, q, grown = _phase_integral(tau, rate, gain)
    # ln E = −λ0 τ − ln G / 2 and φ = ω0 (τ + f L): their derivatives by λ0, ω0, g, f
    d_log_env = (-tau - gain * tau * q / grown, 0.0, -(1.0 - q) / (EXPONENT * grown), 0.0)
    d_phase = (
        omega * shift * d_int_rate,
        tau + shift * integral,
        omega * shift * d_int_gain,
        omega * integral,
    )
    jac = np.zeros((tau.size, theta.size))
    for i, k in enumerate(HARMONICS):
        a, b = theta[N_NONLINEAR + 2 * i : N_NONLINEAR + 2 * i + 2]
        ec, es = design[:, 2 * i], design[:, 2 * i + 1]
        wave = a * ec + b * es  # E^k (a cos kφ + b sin kφ)
        quadrature = b * ec - a * es  # its derivative by kφ
        for j in range(N_NONLINEAR):
            jac[:, j] += k * (d_log_env[j] * wave + d_phase[j] * quadrature)
    jac[:, N_NONLINEAR:] = design
    return jac


def drifting_cosine(
    tau: np.ndarray,
    amplitude: float,
    rate: float,
    angular_frequency: float,
    phase: float,
    damping_gain: float,
    frequency_shift: float,
    harmonic_amplitude: float = 0.0,
    harmonic_phase: float = 0.0,
) -> np.ndarray:
    """``A(τ) cos(φ(τ) + ψ) + A3 (A(τ)/A0)³ cos(3φ(τ) + ψ3)`` with ``A(0)`` = ``amplitude``
    (unit of u) (module docstring).

    ``rate`` λ0 [1/s], ``angular_frequency`` ω0 [rad/s], ``phase`` ψ [rad],
    ``damping_gain`` κ [1/u²], ``frequency_shift`` f = ω(A0)/ω0 − 1 at ``τ = 0``, the third
    harmonic's ``harmonic_amplitude`` A3 (unit of u) and ``harmonic_phase`` ψ3 [rad] at
    ``τ = 0``; ``tau`` [s] from the model's origin.
    """
    tau = np.asarray(tau, dtype=float)
    gain = damping_gain * amplitude**EXPONENT
    integral = _phase_integral(tau, max(rate, RATE_MIN), gain)[0]
    env = envelope(tau, rate, gain, EXPONENT)
    phi = angular_frequency * (tau + frequency_shift * integral)
    third = harmonic_amplitude * env**3 * np.cos(3 * phi + harmonic_phase)
    return amplitude * env * np.cos(phi + phase) + third


@dataclass
class DriftingLineState(FitState):
    """An optimum of the drifting-line model on the normalised signal (module docstring)."""

    @property
    def rates(self) -> np.ndarray:
        return self.theta[:1]

    @property
    def freqs(self) -> np.ndarray:
        return self.theta[1:2]

    def nonlinear_bounds(self, band: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
        return _nonlinear_bounds(band)

    @property
    def gain(self) -> float:
        """Excess damping g = λ(A0)/λ0 − 1 at the window start."""
        return float(self.theta[2])

    @property
    def shift(self) -> float:
        """Frequency shift f = ω(A0)/ω0 − 1 at the window start."""
        return float(self.theta[3])

    def model_curve(self) -> np.ndarray:
        return curve(self.theta, self.tau, self.drift_basis)

    def model_jacobian(self) -> np.ndarray:
        return jacobian(self.theta, self.tau, self.drift_basis)

    def reported_mode(self) -> int:
        return 0

    def amplitudes_phases(self) -> tuple[np.ndarray, np.ndarray]:
        a, b = self.theta[N_NONLINEAR : N_NONLINEAR + 2]
        return np.array([math.hypot(a, b)]), np.array([math.atan2(-b, a)])

    def harmonic(self) -> tuple[float, float]:
        """Amplitude (normalised signal) and phase [rad] of the third harmonic at ``τ = 0``."""
        a, b = self.theta[N_NONLINEAR + 2 : N_NONLINEAR + 4]
        return math.hypot(a, b), math.atan2(-b, a)

    def standard_errors(self, weights: np.ndarray, *, correlated: bool) -> list[float]:
        """Standard errors of [λ0, ω0, λ', ω'] (no second mode: NaN)."""
        cov = self.covariance(weights, correlated=correlated)
        if cov is None:
            return [math.nan] * 4
        return [std_from_variance(cov[0, 0]), std_from_variance(cov[1, 1]), math.nan, math.nan]

    def shift_std(self, weights: np.ndarray, *, correlated: bool) -> float:
        """Standard error of f (dimensionless)."""
        cov = self.covariance(weights, correlated=correlated)
        return math.nan if cov is None else std_from_variance(cov[3, 3])

    def damping_gain(self, scale: float) -> float:
        """κ = g / A0² [1/u²] for a signal normalised by ``scale`` (unit of u)."""
        return self.gain / (self.amplitudes_phases()[0][0] * scale) ** EXPONENT

    def damping_gain_std(self, weights: np.ndarray, *, correlated: bool, scale: float) -> float:
        """Standard error of κ [1/u²] (delta method through g, a and b)."""
        cov = self.covariance(weights, correlated=correlated)
        if cov is None:
            return math.nan
        a, b = self.theta[N_NONLINEAR : N_NONLINEAR + 2]
        r2 = a * a + b * b
        # κ = g / (r2 scale²) with A0² = r2 = a² + b² on the normalised signal
        grad = np.zeros(cov.shape[0])
        grad[2] = 1.0 / r2
        grad[N_NONLINEAR] = -2.0 * self.gain * a / r2**2
        grad[N_NONLINEAR + 1] = -2.0 * self.gain * b / r2**2
        return std_from_variance(float(grad @ cov @ grad) / scale**4)


def _nonlinear_bounds(band: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of ``[λ0, ω0, g, s]`` in the solve."""
    return (
        np.array([RATE_MIN, band[0], 0.0, -SHIFT_MAX]),
        np.array([RATE_MAX, band[1], GAIN_MAX, SHIFT_MAX]),
    )


def _solve(
    theta_nl: np.ndarray,
    tau: np.ndarray,
    drift_basis: np.ndarray,
    u: np.ndarray,
    sqrt_w: np.ndarray,
    band: tuple[float, float],
) -> DriftingLineState:
    lo_nl, hi_nl = _nonlinear_bounds(band)
    span = hi_nl - lo_nl
    theta_nl = np.clip(theta_nl, lo_nl + 1e-6 * span, hi_nl - 1e-6 * span)
    lin, _ = om.solve_linear(_basis(tau, drift_basis, theta_nl), u, sqrt_w)
    lo, hi = with_free_linear(lo_nl, hi_nl, len(lo_nl) + lin.size)

    def fun(theta: np.ndarray) -> np.ndarray:
        return sqrt_w * (curve(theta, tau, drift_basis) - u)

    def jac(theta: np.ndarray) -> np.ndarray:
        return sqrt_w[:, None] * jacobian(theta, tau, drift_basis)

    with np.errstate(all="ignore"):
        res = least_squares(
            fun,
            np.concatenate([theta_nl, lin]),
            jac=jac,
            bounds=(lo, hi),
            method="trf",
            x_scale="jac",
            max_nfev=MAX_EVALUATIONS,
        )
    cost = float(2 * res.cost) if np.all(np.isfinite(res.x)) else math.inf
    return DriftingLineState(1, res.x, tau, drift_basis, u, sqrt_w, cost)


def optimise_drifting_line(
    band: tuple[float, float], amplitude: AmplitudeState
) -> DriftingLineState:
    """The drifting-line optimum, started from the amplitude fit at ``p = 2`` (λ0, ω, g) with
    no frequency shift (f = 0): the optimiser moves f from there (further starts at f = ±4 %
    reached the same optima on all 180 validation signals, ``benchmarks/fit/validation.py``).
    """
    s = amplitude
    return _solve(np.array([*s.theta[:3], 0.0]), s.tau, s.drift_basis, s.u, s.sqrt_w, band)
