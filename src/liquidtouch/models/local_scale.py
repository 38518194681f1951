"""Where the model's std is wrong: a local factor on it, learnt from out-of-fold scores.

A GP with one white-noise level has one std for every liquid, but its errors are
not the same everywhere: on the simulated benchmark the out-of-fold height error is
0.4-0.7 mm for water, the oils, mirin and sugar water and 2 mm for detergent, and
new trials show the same (0.35-0.6 mm, 2.0 mm). One scale for all (the conformal
quantile of the scores) is then too wide for most liquids and too narrow for
detergent. :class:`LocalScale` smooths the logarithm of the squared out-of-fold
scores ``z_i² = ((y_i − ŷ_i) / σ̂_i)²`` over the (λ, ω) plane (Nadaraya–Watson, a
Gaussian kernel of ``bandwidth`` in standardised features; the logarithm, so that a
few large scores next to a quiet region do not swamp it) and shrinks the result
towards their mean with ``prior_weight`` pseudo-rows::

    log ρ²(x) = (Σ_i w_i(x) ℓ_i + n0 · mean(ℓ)) / (Σ_i w_i(x) + n0) + LOG_CHI2_BIAS,
    ℓ_i = log z_i²,   w_i = exp(−|x − x_i|² / 2h²)

(``LOG_CHI2_BIAS`` = −E[log χ²₁] = 1.27: for Gaussian errors ρ² is then the local mean
of z², as the likelihood below needs; the conformal quantile rescales it in any case)

so the std ``σ̂ · ρ`` is wider where the held-out rows showed larger errors and,
far from every training row (no weight), falls back to the global scale. The
bandwidth is chosen by cross-validation (:func:`fit_local_scale`: the Gaussian
log-likelihood of each row's score under the ρ learnt without its group); "no
local factor" (ρ constant) is one of the candidates, so a table whose errors are
homogeneous keeps one scale.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from liquidtouch.errors import TableError

__all__ = ["BANDWIDTHS", "LOG_CHI2_BIAS", "PRIOR_WEIGHT", "LocalScale", "fit_local_scale"]

#: candidate kernel bandwidths [standardised feature units]; the CV picks one or none
BANDWIDTHS = (0.25, 0.5, 1.0, 2.0)
#: pseudo-rows at the mean score: how far ρ moves from the global scale on few rows
PRIOR_WEIGHT = 1.0
#: −E[log z²] for a standard normal z (log 2 + γ): turns a mean of log z² into log E[z²]
LOG_CHI2_BIAS = math.log(2.0) + 0.5772156649015329
#: scores are floored at this before the logarithm (an exact prediction must not give −∞)
MIN_SCORE = 1e-3


@dataclass(frozen=True)
class LocalScale:
    """ρ(x) of the module docstring: the rows' features, their squared scores, the kernel.

    ``points`` (n, 2): training (λ [1/s], ω [rad/s]); ``z2`` (n,): their squared
    out-of-fold scores (floored at ``MIN_SCORE²``); ``centre``/``spread``: the
    standardisation of the features;
    ``bandwidth`` h and ``prior_weight`` n0.
    """

    points: tuple[tuple[float, float], ...]
    z2: tuple[float, ...]
    centre: tuple[float, float]
    spread: tuple[float, float]
    bandwidth: float
    prior_weight: float = PRIOR_WEIGHT

    def __post_init__(self) -> None:
        points = np.asarray(self.points, dtype=float)
        z2 = np.asarray(self.z2, dtype=float)
        spread = np.asarray(self.spread, dtype=float)
        ok = (
            points.ndim == 2
            and points.shape[1:] == (2,)
            and z2.shape == (points.shape[0],)
            and np.all(np.isfinite(points))
            and np.all(np.isfinite(z2))
            and np.all(z2 >= 0)
            and np.shape(self.centre) == (2,)
            and spread.shape == (2,)
            and np.all(spread > 0)
            and math.isfinite(self.bandwidth)
            and self.bandwidth > 0
            and self.prior_weight > 0
        )
        if not ok or points.shape[0] < 2:
            raise TableError(
                "a local scale needs n >= 2 rows of 2 features, n scores >= 0 and h > 0"
            )

    def _weights(self, X: np.ndarray) -> np.ndarray:
        centre, spread = np.asarray(self.centre), np.asarray(self.spread)
        Z = (np.asarray(self.points) - centre) / spread
        Q = (np.asarray(X, dtype=float).reshape(-1, 2) - centre) / spread
        d2 = ((Q[:, None, :] - Z[None, :, :]) ** 2).sum(axis=-1)
        return np.exp(-0.5 * d2 / self.bandwidth**2)

    def factor(self, X: Any) -> np.ndarray:
        """ρ (n,) at the (n, 2) features ``X`` (dimensionless, > 0)."""
        ell = _log_z2(np.asarray(self.z2))
        return np.exp(0.5 * _smoothed(self._weights(X), ell, float(ell.mean()), self.prior_weight))

    def to_state(self) -> dict[str, Any]:
        """Plain-data state (model file)."""
        return {
            "points": [list(p) for p in self.points],
            "z2": list(self.z2),
            "centre": list(self.centre),
            "spread": list(self.spread),
            "bandwidth": self.bandwidth,
            "prior_weight": self.prior_weight,
        }

    @classmethod
    def from_state(cls, state: dict[str, Any]) -> LocalScale:
        """Rebuild from :meth:`to_state`."""
        return cls(
            points=tuple((float(a), float(b)) for a, b in state["points"]),
            z2=tuple(float(v) for v in state["z2"]),
            centre=(float(state["centre"][0]), float(state["centre"][1])),
            spread=(float(state["spread"][0]), float(state["spread"][1])),
            bandwidth=float(state["bandwidth"]),
            prior_weight=float(state.get("prior_weight", PRIOR_WEIGHT)),
        )


def _log_z2(z2: np.ndarray) -> np.ndarray:
    return np.log(np.maximum(z2, MIN_SCORE**2))


def _smoothed(w: np.ndarray, ell: np.ndarray, prior: Any, n0: float) -> np.ndarray:
    """log ρ²: the kernel mean of ``ell`` with ``n0`` pseudo-rows at ``prior``."""
    return (w @ ell + n0 * prior) / (w.sum(axis=1) + n0) + LOG_CHI2_BIAS


def fit_local_scale(
    X: Any, scores: Any, groups: Any = None, bandwidths: tuple[float, ...] = BANDWIDTHS
) -> tuple[LocalScale | None, np.ndarray]:
    """The cross-validated :class:`LocalScale` of out-of-fold ``scores`` (n,) at ``X`` (n, 2).

    Each candidate bandwidth (and "none": ρ constant) is judged by the mean Gaussian
    log-likelihood of every row's score under the ρ smoothed from the rows outside its
    ``groups`` value (every row its own group when ``None``); the best is returned with
    those held-out ρ of the rows (n,), by which the conformal scores are divided
    (all ones for "none", returned as ``None``).
    """
    X = np.asarray(X, dtype=float)
    z2 = np.maximum(np.asarray(scores, dtype=float) ** 2, MIN_SCORE**2)
    ell = _log_z2(z2)
    n = z2.shape[0]
    groups = np.arange(n) if groups is None else np.asarray(groups)
    others = groups[:, None] != groups[None, :]
    centre, spread = X.mean(axis=0), X.std(axis=0)
    spread = np.where(spread > 0, spread, 1.0)

    def loglik(log_rho2: np.ndarray) -> float:
        return float(np.mean(-0.5 * z2 / np.exp(log_rho2) - 0.5 * log_rho2))

    kept = others.sum(axis=1)
    mean_others = np.where(kept > 0, (others @ ell) / np.maximum(kept, 1), ell.mean())
    flat = mean_others + LOG_CHI2_BIAS
    best_ll, best = loglik(flat), None
    for h in bandwidths:
        scale = LocalScale(
            tuple((float(a), float(b)) for a, b in X),
            tuple(float(v) for v in z2),
            (float(centre[0]), float(centre[1])),
            (float(spread[0]), float(spread[1])),
            float(h),
        )
        log_rho2 = _smoothed(scale._weights(X) * others, ell, mean_others, PRIOR_WEIGHT)
        ll = loglik(log_rho2)
        if ll > best_ll:
            best_ll, best = ll, (scale, np.exp(0.5 * log_rho2))
    if best is None:
        return None, np.ones(n)
    return best
