"""The GP regressor's log marginal likelihood and its gradient, in plain NumPy.

:class:`~liquidtouch.models.regressors.GPRegressor` fits one kernel,
``C · RBF(ℓ_1 … ℓ_d) + White(σ²)``, by maximising the log marginal likelihood of its
standardised training rows over ``θ = ln(C, ℓ_1 … ℓ_d, σ²)`` with L-BFGS-B from several
starts. scikit-learn's ``GaussianProcessRegressor`` evaluates that objective through its
generic kernel objects, whose bookkeeping costs more than the algebra on the tens to
hundreds of rows a calibration has. :class:`LikelihoodOptimizer` is the regressor's
``optimizer``: the same L-BFGS-B call on the same objective, computed here directly —
the same value and gradient to rounding (tested against scikit-learn), ~3× faster per
evaluation. The restarts, their random starts and everything after the optimum stay
scikit-learn's.

With ``K = C·R + σ²·I + diag(jitter)`` (``R`` the RBF correlation, ``jitter`` the
regressor's ``alpha`` added to the diagonal: one value, or each row's own noise) and
``α = K⁻¹ r``::

    ln p(r | θ) = −½ rᵀα − Σ ln diag(L) − n/2 · ln 2π,   K = L Lᵀ
    ∂ ln p / ∂θ_k = ½ Σ_ij (ααᵀ − K⁻¹)_ij (∂K/∂θ_k)_ji

with ∂K/∂ln C = C·R, ∂K/∂ln ℓ_j = C·R ⊙ (Δx_j / ℓ_j)², ∂K/∂ln σ² = σ²·I.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg.lapack import dpotrf, dpotri, dpotrs
from scipy.optimize import minimize

__all__ = ["LikelihoodOptimizer", "log_marginal_likelihood"]

_LOG_2PI = math.log(2.0 * math.pi)


def log_marginal_likelihood(
    theta: np.ndarray, squared_steps: np.ndarray, r: np.ndarray, jitter: float | np.ndarray
) -> tuple[float, np.ndarray]:
    """``(ln p(r | θ), its gradient over θ)`` (module docstring).

    ``squared_steps``: (d, n, n) squared differences of the training inputs per input
    dimension; ``r``: (n,) standardised targets; ``jitter``: added to the diagonal
    (a scalar, or (n,) per row).
    ``(-inf, 0)`` when ``K`` is not positive definite, as scikit-learn returns.
    """
    params = np.exp(theta)
    constant, scales, noise = params[0], params[1:-1], params[-1]
    n = r.shape[0]
    scaled = squared_steps / (scales**2)[:, None, None]
    covariance = constant * np.exp(-0.5 * scaled.sum(axis=0))
    kernel = covariance.copy()
    kernel.flat[:: n + 1] += noise + jitter
    # LAPACK directly: at tens of rows scipy.linalg's checks cost as much as the algebra
    lower, info = dpotrf(kernel, lower=1, clean=1)
    if info != 0:  # not positive definite
        return -math.inf, np.zeros_like(theta)
    alpha, _ = dpotrs(lower, r, lower=1)
    inverse, _ = dpotri(lower, lower=1)  # the lower triangle of K⁻¹
    inverse = np.tril(inverse) + np.tril(inverse, -1).T
    value = -0.5 * float(r @ alpha) - float(np.log(np.diag(lower)).sum()) - 0.5 * n * _LOG_2PI
    inner = np.outer(alpha, alpha) - inverse
    weighted = inner * covariance
    gradient = np.empty_like(theta)
    gradient[0] = 0.5 * weighted.sum()
    gradient[1:-1] = 0.5 * np.einsum("ij,kij->k", weighted, scaled)
    gradient[-1] = 0.5 * noise * np.trace(inner)
    return value, gradient


class LikelihoodOptimizer:
    """``GaussianProcessRegressor(optimizer=...)`` for the kernel ``C·RBF(ℓ) + White``:
    scikit-learn's L-BFGS-B call on :func:`log_marginal_likelihood` of ``Z``, ``r``.

    ``Z``: (n, d) standardised training inputs; ``r``: (n,) standardised targets;
    ``jitter``: the regressor's ``alpha`` (scalar or (n,)). The kernel's θ must be
    ``ln(C, ℓ_1 … ℓ_d, σ²)``.
    """

    def __init__(self, Z: np.ndarray, r: np.ndarray, jitter: float | np.ndarray) -> None:
        Z = np.asarray(Z, dtype=float)
        self.squared_steps = (Z.T[:, :, None] - Z.T[:, None, :]) ** 2
        self.r = np.asarray(r, dtype=float)
        self.jitter = np.asarray(jitter, dtype=float)

    def _negative(self, theta: np.ndarray) -> tuple[float, np.ndarray]:
        value, gradient = log_marginal_likelihood(theta, self.squared_steps, self.r, self.jitter)
        return -value, -gradient

    def __call__(self, obj_func, initial_theta: np.ndarray, bounds: np.ndarray):
        """Minimise −ln p from ``initial_theta`` within ``bounds``; ``obj_func`` (scikit-learn's
        own objective, the same function) is not used."""
        result = minimize(self._negative, initial_theta, method="L-BFGS-B", jac=True, bounds=bounds)
        return result.x, result.fun
