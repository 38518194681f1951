"""Physics-informed Gaussian-process regression (beyond the paper).

The first sloshing mode of a liquid of depth h in a container of inner
length L (along the slosh) follows linear potential theory,
``ω0² = g k tanh(k h)`` with ``k = π / L``, and viscous damping lowers the
observed frequency slightly, ``ω² = ω0² − λ²``. Hence the fill height implied
by the dispersion relation::

    h_phys(λ, ω) = atanh((ω² + λ²) / (g k)) / k

The container length is unknown to the model, so the effective wavenumber k
is fitted on the training data. For viscosity, Stokes boundary-layer damping
gives ``λ ∝ sqrt(ν ω)``, i.e. ``log10 ν ≈ 2 log10 λ − log10 ω + const``.

:class:`PhysicsGPRegressor` uses the physics feature p(λ, ω) as the GP's prior
mean ``b0 + b1 p`` (least squares); for viscosity p is also a third GP input
(measured: that helps viscosity, but lets the height GP overfit). The
GP then only learns what the simple physics misses, which needs fewer points
and extrapolates along the physics outside the training range.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from sklearn.utils.validation import check_is_fitted

from liquidtouch._core.checks import check_positive
from liquidtouch.errors import TableError
from liquidtouch.models.regressors import GPRegressor

GRAVITY_M_S2 = 9.81
# effective container lengths searched when fitting k = π / L
_LENGTH_BOUNDS_M = (0.02, 2.0)
# which physics feature suits which label column
PRIORS = ("height", "viscosity")
PRIOR_OF_TARGET = {
    "height_mm": "height",
    "log10_viscosity_cst": "viscosity",
    "viscosity_cst": "viscosity",
    "sugar_concentration": "viscosity",
}


def _same_length(**arrays: Any) -> list[np.ndarray]:
    values = [np.asarray(v, dtype=float).ravel() for v in arrays.values()]
    sizes = {v.size for v in values}
    if len(sizes) != 1 or 0 in sizes:
        shown = ", ".join(f"{k} ({v.size})" for k, v in zip(arrays, values, strict=True))
        raise TableError(f"need equally many values, at least one, of: {shown}")
    for name, v in zip(arrays, values, strict=True):
        if not np.isfinite(v).all():
            raise TableError(f"{name} contains NaN or infinite values; drop or fix those rows")
    return values


def dispersion_height_mm(
    decay_rate: np.ndarray, angular_frequency: np.ndarray, wavenumber: float
) -> np.ndarray:
    """Fill height [mm] implied by ``ω² + λ² = g k tanh(k h)`` for wavenumber ``k`` [1/m].

    Frequencies at or above the deep-liquid limit ``sqrt(g k)`` are clipped
    just below it (the height would be infinite). Raises :class:`TableError`
    unless ``wavenumber`` is a finite number > 0.
    """
    wavenumber = check_positive(wavenumber, "wavenumber")
    omega0_sq = np.square(angular_frequency) + np.square(decay_rate)
    ratio = np.clip(omega0_sq / (GRAVITY_M_S2 * wavenumber), 0.0, 1.0 - 1e-9)
    return 1000.0 * np.arctanh(ratio) / wavenumber


def fit_wavenumber(
    decay_rate: np.ndarray, angular_frequency: np.ndarray, height_mm: np.ndarray
) -> float:
    """Effective wavenumber k = π / L [1/m] that best explains the heights (least squares).

    The three arrays must be finite and of equal length (at least one value).
    """
    from scipy.optimize import minimize_scalar

    decay_rate, angular_frequency, height_mm = _same_length(
        decay_rate=decay_rate, angular_frequency=angular_frequency, height_mm=height_mm
    )

    def loss(log_k: float) -> float:
        h = dispersion_height_mm(decay_rate, angular_frequency, float(np.exp(log_k)))
        return float(np.mean(np.square(h - height_mm)))

    lo, hi = np.pi / _LENGTH_BOUNDS_M[1], np.pi / _LENGTH_BOUNDS_M[0]
    # the loss can have plateaus where everything clips: seed the bounded search from a grid
    grid = np.linspace(np.log(lo), np.log(hi), 60)
    best = grid[int(np.argmin([loss(g) for g in grid]))]
    step = grid[1] - grid[0]
    result = minimize_scalar(
        loss, bounds=(max(best - step, grid[0]), min(best + step, grid[-1])), method="bounded"
    )
    return float(np.exp(result.x))


def stokes_viscosity_feature(decay_rate: np.ndarray, angular_frequency: np.ndarray) -> np.ndarray:
    """``2 log10 λ − log10 ω``: log10 kinematic viscosity up to a constant (Stokes layer)."""
    # an undamped fit (λ = 0) would give -inf; 1e-4 1/s is far below any liquid's damping
    return 2.0 * np.log10(np.maximum(decay_rate, 1e-4)) - np.log10(angular_frequency)


class PhysicsGPRegressor(GPRegressor):
    """GP regression with a physics prior mean (and, for viscosity, a physics input).

    A scikit-learn regressor like :class:`GPRegressor` (one target per
    estimator; ``predict(X, return_std=False)``), but ``X`` must have exactly the
    two columns (decay_rate λ [1/s], angular_frequency ω [rad/s]) with ω > 0,
    since the prior is a formula in them.

    Parameters
    ----------
    prior : {"height", "viscosity"}
        ``"height"`` uses the dispersion-relation height (fitted wavenumber);
        ``"viscosity"`` the Stokes-layer viscosity feature. Use
        :func:`prior_for_target` to choose from a label column's name.
    n_restarts, random_state
        As for :class:`GPRegressor`.

    Notes
    -----
    Extra fitted attributes: ``wavenumber_`` [1/m] (0 for a viscosity prior) and
    ``prior_coef_`` (b0, b1) of the prior mean ``b0 + b1 p(λ, ω)``.
    """

    model_name = "physics-gpr"

    def __init__(self, prior: str = "height", n_restarts: int = 5, random_state: Any = 0) -> None:
        self.prior = prior
        self.n_restarts = n_restarts
        self.random_state = random_state

    def _check_params(self) -> None:
        super()._check_params()
        if self.prior not in PRIORS:
            raise TableError(
                f"unknown physics prior {self.prior!r}; use one of {', '.join(map(repr, PRIORS))}"
            )

    def __sklearn_tags__(self) -> Any:
        tags = super().__sklearn_tags__()
        tags.input_tags.positive_only = True  # λ >= 0, ω > 0
        return tags

    def _check_input(self, X: np.ndarray) -> None:
        name = type(self).__name__
        if (X < 0).any():
            raise TableError(
                f"{name}: Negative values in data: decay_rate λ must be >= 0 and "
                "angular_frequency ω > 0 (drop failed oscillation fits)"
            )
        if X.shape[1] != 2:
            raise TableError(
                f"{name} needs exactly 2 features (decay_rate λ [1/s], "
                f"angular_frequency ω [rad/s]); got n_features={X.shape[1]}"
            )
        if (X[:, 1] == 0).any():
            raise TableError(
                f"{name}: angular_frequency ω (column 1) must be > 0 in every row; "
                "drop failed oscillation fits"
            )

    def _physics_feature(self, X: np.ndarray) -> np.ndarray:
        if self.prior == "height":
            return dispersion_height_mm(X[:, 0], X[:, 1], self.wavenumber_)
        return stokes_viscosity_feature(X[:, 0], X[:, 1])

    def _fit_prior(self, X: np.ndarray, y: np.ndarray) -> None:
        self.wavenumber_ = fit_wavenumber(X[:, 0], X[:, 1], y) if self.prior == "height" else 0.0
        p = self._physics_feature(X)
        design = np.column_stack([np.ones_like(p), p])
        self.prior_coef_, *_ = np.linalg.lstsq(design, y, rcond=None)

    def _prior_mean(self, X: np.ndarray) -> np.ndarray:
        return self.prior_coef_[0] + self.prior_coef_[1] * self._physics_feature(X)

    def _inputs(self, X: np.ndarray) -> np.ndarray:
        if self.prior == "height":
            # as an extra input h_phys let the GP overfit its noise (0.37 vs 0.19 mm MAE)
            return X
        return np.column_stack([X, self._physics_feature(X)])

    def _prior_state(self) -> dict[str, Any]:
        return {
            "kind": self.prior,
            "wavenumber": self.wavenumber_,
            "coef": [float(c) for c in self.prior_coef_],
        }

    def _set_prior_state(self, state: dict[str, Any]) -> None:
        self.prior = state["kind"]
        self.wavenumber_ = float(state["wavenumber"])
        self.prior_coef_ = np.asarray(state["coef"], dtype=float)

    def describe(self) -> str:
        """Summary: the physics prior's parameters and the residual kernel."""
        check_is_fitted(self, "prior_coef_")
        b0, b1 = self.prior_coef_
        if self.prior == "height":
            length_m = np.pi / self.wavenumber_
            head = f"prior {b0:+.3g} {b1:+.3g}·h_phys (effective L = {1000 * length_m:.0f} mm)"
        else:
            head = f"prior {b0:+.3g} {b1:+.3g}·(2 log10 λ − log10 ω)"
        return f"{head}; residual GP {super().describe()}"

    @classmethod
    def _construct(cls, state: dict[str, Any]) -> PhysicsGPRegressor:
        return cls(state["prior"]["kind"], state["n_restarts"], state["random_state"])


def prior_for_target(target: str) -> str:
    """The physics prior for a label column; raise :class:`TableError` if there is none."""
    try:
        return PRIOR_OF_TARGET[target]
    except KeyError:
        known = ", ".join(PRIOR_OF_TARGET)
        raise TableError(
            f"no physics prior for column {target!r} (known: {known}); use --model gpr"
        ) from None
