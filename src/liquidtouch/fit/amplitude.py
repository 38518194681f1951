"""Amplitude-dependent damping: one slosh mode whose decay rate grows with its amplitude.

A slosh loses energy faster while it is large (wave breaking, steep-wave and
boundary-layer losses), so the decay rate is a function of the amplitude ``A``::

    λ(A) = λ0 (1 + κ A^p),   1 ≤ p ≤ 2,

with ``λ0`` [1/s] the small-amplitude rate — a property of the liquid and fill,
whatever the push — and ``κ`` [1/u^p] the damping gain. ``p = 2`` is the
simulator's ``λ0 + k A²`` (wave steepness squared) and a damper growing with the
displacement squared; ``p = 1`` is a velocity-squared (quadratic) damper
``c |v| v``, for which harmonic balance gives ``λ(A) = λ0 + (4 / 3π) c ω A``.

The exponent is fitted, bounded to ``[1, 2]`` (:data:`EXPONENT_BOUNDS`): a
continuous parameter, so λ0 moves smoothly with the data. Choosing between
``p = 1`` and ``p = 2`` instead flipped the exponent between the pushes of one
trial and between gapped copies of one recording (λ0 jumping 10-50 %), and
``p = 2`` alone biases a velocity-squared damper's λ0 by 6 % (``benchmarks/RESULTS.md``,
fit_accuracy). The fit (:mod:`liquidtouch.fit.amplitude_solve`) starts from both
ends (``p = 1`` and ``p = 2``, each with the start search of
:func:`~liquidtouch.fit.start.amplitude_starts`) and frees ``p`` from each; the
lower cost is kept. The price: a p = 2 damper whose envelope is not exactly this
one (a cubic damper's, to first order in harmonic balance) is fitted at p ≈ 1.5,
which moves λ0 by a few per cent. With a second mode beside it
(``amplitude-two-mode``) p stays at :data:`TWO_MODE_EXPONENT`: with p free there
too, λ0 followed p between the pushes of one trial.

Envelope
--------
``dA/dτ = −λ(A) A`` becomes, for ``y = A^p``, ``dy/dτ = −p λ0 y (1 + κ y)`` whose
solution is ``y / (1 + κ y) = y0 / (1 + κ y0) · e^{−p λ0 τ}``, i.e.::

    A(τ) = A0 e^{−λ0 τ} / (1 + g (1 − e^{−p λ0 τ}))^{1/p},   g = κ A0^p,

with ``A0`` the amplitude at the window start. ``g = λ(A0)/λ0 − 1`` is the excess
damping there: dimensionless and free of the unit of ``u``, so the optimiser
works with ``g`` (bounded to ``[0, GAIN_MAX]``) and ``κ = g / A0^p`` is reported.
The fitted signal is ``u(τ) = A(τ) cos(ωτ + ψ)`` + quadratic drift; written with
``A(τ) cos(ωτ + ψ) = E(τ)(a cos ωτ + b sin ωτ)``, ``E = A/A0``, it is linear in
``(a, b)`` and the drift, so those are solved exactly for any start (as in
:mod:`liquidtouch.fit.model`).

Parameter vector: ``[λ0, ω, g, a, b, d0, d1, d2]``; ``p`` is held in the state
(``AmplitudeState.exponent``) and is a parameter of the covariance and of the
information criterion when it was fitted (``exponent_free``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from liquidtouch.fit.solve import RATE_MAX, FitState, std_from_variance

#: range of the exponent p of λ(A) = λ0 (1 + κ A^p): a velocity-squared damper (flow past
#: a baffle, p = 1) to the slosh's steepness-squared damping (and a cubic damper, p = 2)
EXPONENT_BOUNDS = (1.0, 2.0)
#: exponent of the amplitude-damped mode when a second mode is fitted beside it (the slosh's);
#: with p free as well the combined model's λ0 followed p between pushes of one trial
TWO_MODE_EXPONENT = 2.0
#: below this excess damping g the exponent has no effect on the curve (not identifiable):
#: the covariance then takes p as given
GAIN_IDENTIFIES_EXPONENT = 1e-2
#: largest excess damping g = λ(A0)/λ0 − 1 at the window start
GAIN_MAX = 100.0
N_NONLINEAR = 3


def envelope(tau: np.ndarray, rate: float, gain: float, exponent: float) -> np.ndarray:
    """Relative envelope ``A(τ)/A0`` at times ``tau`` [s] (module docstring).

    ``rate`` λ0 [1/s], ``gain`` g = κ A0^p (dimensionless, ≥ 0), ``exponent`` p.
    """
    tau = np.asarray(tau, dtype=float)
    grown = 1.0 + gain * -np.expm1(-exponent * rate * tau)
    return np.exp(-rate * tau) * grown ** (-1.0 / exponent)


def amplitude_damped_cosine(
    tau: np.ndarray,
    amplitude: float,
    rate: float,
    angular_frequency: float,
    phase: float,
    damping_gain: float,
    exponent: float,
) -> np.ndarray:
    """``A(τ) cos(ωτ + ψ)`` with ``A(0)`` = ``amplitude`` (unit of u) and λ(A) = λ0 (1 + κ A^p).

    ``rate`` λ0 [1/s], ``angular_frequency`` ω [rad/s], ``phase`` ψ [rad],
    ``damping_gain`` κ [1/u^p], ``exponent`` p; ``tau`` [s] from the model's origin.
    """
    gain = damping_gain * amplitude**exponent
    tau = np.asarray(tau, dtype=float)
    return amplitude * envelope(tau, rate, gain, exponent) * np.cos(angular_frequency * tau + phase)


def n_nonlinear(second: bool) -> int:
    """Nonlinear parameters: ``λ0, ω, g`` and, with a second mode, its ``λ', ω'``."""
    return N_NONLINEAR + 2 * int(second)


def nonlinear_bounds(size: int, band: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of ``[λ0, ω, g]`` (and a second mode's ``λ', ω'``) in the solve."""
    lo = np.array([0.0, band[0], 0.0, 0.0, band[0]][:size])
    hi = np.array([RATE_MAX, band[1], GAIN_MAX, RATE_MAX, band[1]][:size])
    return lo, hi


def basis(
    tau: np.ndarray,
    drift_basis: np.ndarray,
    theta_nl: np.ndarray,
    exponent: float,
    second: bool = False,
) -> np.ndarray:
    """Design matrix: ``E cos ωτ``, ``E sin ωτ`` (with ``second``: ``e^{−λ'τ} cos ω'τ``,
    ``e^{−λ'τ} sin ω'τ``), the drift's columns."""
    rate, omega, gain = theta_nl[:N_NONLINEAR]
    env = envelope(tau, rate, gain, exponent)
    n_modes = 1 + int(second)
    cols = np.empty((tau.size, 2 * n_modes + drift_basis.shape[1]))
    cols[:, 0] = env * np.cos(omega * tau)
    cols[:, 1] = env * np.sin(omega * tau)
    if second:
        rate_2, omega_2 = theta_nl[N_NONLINEAR : N_NONLINEAR + 2]
        env_2 = np.exp(-rate_2 * tau)
        cols[:, 2] = env_2 * np.cos(omega_2 * tau)
        cols[:, 3] = env_2 * np.sin(omega_2 * tau)
    cols[:, -drift_basis.shape[1] :] = drift_basis
    return cols


def curve(
    theta: np.ndarray,
    tau: np.ndarray,
    drift_basis: np.ndarray,
    exponent: float,
    second: bool = False,
) -> np.ndarray:
    """The model's value at each sample."""
    return basis(tau, drift_basis, theta, exponent, second) @ theta[n_nonlinear(second) :]


def _first_mode(
    theta: np.ndarray, tau: np.ndarray, drift_basis: np.ndarray, exponent: float, second: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The design matrix, the amplitude-damped mode, ``q = e^{−p λ0 τ}``, ``G = 1 + g (1 − q)``."""
    k = n_nonlinear(second)
    rate, _, gain = theta[:N_NONLINEAR]
    a, b = theta[k : k + 2]
    design = basis(tau, drift_basis, theta, exponent, second)
    mode = a * design[:, 0] + b * design[:, 1]
    q = np.exp(-exponent * rate * tau)
    return design, mode, q, 1.0 + gain * (1.0 - q)


def jacobian(
    theta: np.ndarray,
    tau: np.ndarray,
    drift_basis: np.ndarray,
    exponent: float,
    second: bool = False,
) -> np.ndarray:
    """Analytic Jacobian ``d curve / d theta``, shape ``(n, theta.size)``."""
    k = n_nonlinear(second)
    gain = theta[2]
    a, b = theta[k : k + 2]
    design, mode, q, grown = _first_mode(theta, tau, drift_basis, exponent, second)
    ec, es = design[:, 0], design[:, 1]
    jac = np.empty((tau.size, theta.size))
    # ln E = −λ0 τ − ln(1 + g (1 − q)) / p,  q = e^{−p λ0 τ}
    jac[:, 0] = mode * (-tau - gain * tau * q / grown)
    jac[:, 1] = tau * (b * ec - a * es)
    jac[:, 2] = mode * (-(1.0 - q) / (exponent * grown))
    if second:
        a2, b2 = theta[k + 2 : k + 4]
        ec2, es2 = design[:, 2], design[:, 3]
        jac[:, 3] = -tau * (a2 * ec2 + b2 * es2)
        jac[:, 4] = tau * (b2 * ec2 - a2 * es2)
    jac[:, k:] = design
    return jac


def exponent_derivative(
    theta: np.ndarray,
    tau: np.ndarray,
    drift_basis: np.ndarray,
    exponent: float,
    second: bool = False,
) -> np.ndarray:
    """``d curve / d p``: ``ln E = −λ0 τ − ln G / p`` with ``G = 1 + g (1 − e^{−p λ0 τ})``."""
    rate, _, gain = theta[:N_NONLINEAR]
    _, mode, q, grown = _first_mode(theta, tau, drift_basis, exponent, second)
    return mode * (np.log(grown) / exponent**2 - gain * rate * tau * q / (exponent * grown))


@dataclass
class AmplitudeState(FitState):
    """An optimum of the amplitude-damping model on the normalised signal.

    ``gain_fixed``: g is held at 0 (the constant-rate fallback), so it is not a
    free parameter of the covariance. ``exponent_free``: p was fitted (a parameter
    of the criterion, and of the covariance while the gain makes it identifiable).
    """

    exponent: float = 2.0
    gain_fixed: bool = False
    exponent_free: bool = False
    #: a second, exponentially damped mode (λ', ω') besides the amplitude-damped one
    second: bool = False

    @property
    def n_params(self) -> int:
        return self.theta.size - int(self.gain_fixed) + int(self.exponent_free)

    def nonlinear_bounds(self, band: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
        return nonlinear_bounds(n_nonlinear(self.second), band)

    def _exponent_in_covariance(self) -> bool:
        return self.exponent_free and self.gain > GAIN_IDENTIFIES_EXPONENT

    @property
    def gain(self) -> float:
        """Excess damping g = λ(A0)/λ0 − 1 at the window start."""
        return float(self.theta[2])

    @property
    def rates(self) -> np.ndarray:
        return self.theta[[0, 3]] if self.second else self.theta[:1]

    @property
    def freqs(self) -> np.ndarray:
        return self.theta[[1, 4]] if self.second else self.theta[1:2]

    def model_curve(self) -> np.ndarray:
        return curve(self.theta, self.tau, self.drift_basis, self.exponent, self.second)

    def model_jacobian(self) -> np.ndarray:
        """Jacobian of the free parameters: θ (without g when held), then p when fitted."""
        jac = jacobian(self.theta, self.tau, self.drift_basis, self.exponent, self.second)
        if self.gain_fixed:
            return np.delete(jac, 2, axis=1)
        if self._exponent_in_covariance():
            d_exp = exponent_derivative(
                self.theta, self.tau, self.drift_basis, self.exponent, self.second
            )
            return np.column_stack([jac, d_exp])
        return jac

    def theta_jacobian(self) -> np.ndarray:
        return jacobian(self.theta, self.tau, self.drift_basis, self.exponent, self.second)

    def free_parameters(self) -> np.ndarray:
        """Indices of ``theta`` a solve moves: all but g when it is held (p is not in theta)."""
        free = np.arange(self.theta.size)
        return np.delete(free, 2) if self.gain_fixed else free

    def slow_mode_energy_share(self) -> float:
        """Energy of the amplitude-damped mode over the window relative to the second's (the
        damped envelope is not ``e^{−λτ}``: from the modes' own curves). Through
        :meth:`FitState.reported_mode`, a damped mode that is a sliver beside the second is
        not reported: the fit put a faint persistent line there, its λ0 at 0."""
        design = basis(self.tau, self.drift_basis, self.theta, self.exponent, self.second)
        k = n_nonlinear(self.second)
        modes = design[:, :4] * self.theta[k : k + 4]
        damped, plain = modes[:, :2].sum(axis=1), modes[:, 2:].sum(axis=1)
        return float(damped @ damped) / float(plain @ plain)

    def amplitudes_phases(self) -> tuple[np.ndarray, np.ndarray]:
        k = n_nonlinear(self.second)
        lin = self.theta[k : k + 2 * self.n_modes]
        a, b = lin[0::2], lin[1::2]
        return np.hypot(a, b), np.arctan2(-b, a)

    def standard_errors(self, weights: np.ndarray, *, correlated: bool) -> list[float]:
        """Standard errors of [λ0, ω, λ', ω'] (NaN without a second mode)."""
        cov = self.covariance(weights, correlated=correlated)
        if cov is None:
            return [math.nan] * 4
        var = np.diag(cov)
        if not self.second:
            return [std_from_variance(var[0]), std_from_variance(var[1]), math.nan, math.nan]
        i = 3 - int(self.gain_fixed)
        return [
            std_from_variance(var[0]),
            std_from_variance(var[1]),
            std_from_variance(var[i]),
            std_from_variance(var[i + 1]),
        ]

    def damping_gain(self, scale: float) -> float:
        """κ = g / A0^p [1/u^p] for a signal normalised by ``scale`` (unit of u)."""
        amp = self.amplitudes_phases()[0][0] * scale
        return self.gain / amp**self.exponent

    def damping_gain_std(self, weights: np.ndarray, *, correlated: bool, scale: float) -> float:
        """Standard error of κ [1/u^p] (delta method through g, a, b and a fitted p).

        With g held at 0 it is the std of κ at g = 0 with g free: how large a
        gain the data cannot tell from none.
        """
        free = AmplitudeState(**{**self.__dict__, "gain_fixed": False})
        k = n_nonlinear(self.second)
        cov = free.covariance(weights, correlated=correlated)
        if cov is None:
            return math.nan
        a, b = self.theta[k : k + 2]
        r2 = a * a + b * b
        p = self.exponent
        # κ = g / (A0 scale)^p in the unit of u, A0 = √(a² + b²) on the normalised signal
        grad = np.zeros(cov.shape[0])
        grad[2] = r2 ** (-p / 2)
        grad[k] = -p * self.gain * a * r2 ** (-p / 2 - 1)
        grad[k + 1] = -p * self.gain * b * r2 ** (-p / 2 - 1)
        grad /= scale**p
        if cov.shape[0] > self.theta.size:  # p fitted, last: dκ/dp = −κ ln(A0 scale)
            grad[-1] = -self.damping_gain(scale) * math.log(math.sqrt(r2) * scale)
        var = float(grad @ cov @ grad)
        return math.sqrt(var) if var >= 0 else math.nan
