"""Regression of liquid properties from the slow sloshing mode's (λ, ω).

Both estimators are scikit-learn estimators (``RegressorMixin`` +
``BaseEstimator``): ``__init__`` only stores its arguments, ``fit(X, y)``
validates and returns ``self``, fitted attributes end with ``_``, and they work
with :func:`sklearn.base.clone`, pipelines, ``cross_val_score`` and
``GridSearchCV``. In this project ``X`` is the (n, 2) array of
(decay_rate λ [1/s], angular_frequency ω [rad/s]); the estimators themselves
accept any number of feature columns (only model files and
:class:`~liquidtouch.models.property_model.PropertyModel` require exactly these two).

**One target per estimator** (single-output, like ``sklearn.svm.SVR``): ``y``
is one numeric label (``height_mm``, ``sugar_concentration``,
``log10_viscosity_cst``, ...) of shape (n,), and ``predict(X)`` returns shape
(n,); ``predict(X, return_std=True)`` returns ``(mean, std)``, both (n,), as
``sklearn.gaussian_process.GaussianProcessRegressor`` does. Several targets are
several estimators, each with its own hyperparameters (and physics prior):
:func:`~liquidtouch.models.property_model.train_regression` builds one per
target; ``sklearn.multioutput.MultiOutputRegressor`` does the same and returns (n, k).

- :class:`GPRegressor` — Gaussian-process regression with an anisotropic RBF +
  white-noise kernel on standardised inputs and targets (the paper's model).
- :class:`QuadraticRegressor` — the paper's 6-parameter quadratic in (λ, ω).

Every fitted estimator can be written as a plain dict (``to_state``) holding
its hyperparameters and training data, and rebuilt exactly from it
(``from_state``): the rebuild refits deterministically with the stored
hyperparameters (no optimiser), so predictions are bit-identical.
"""

from __future__ import annotations

import numbers
import warnings
from itertools import combinations_with_replacement
from typing import Any

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.utils.validation import check_is_fitted

from liquidtouch.errors import ModelFileError, TableError
from liquidtouch.models.validation import (
    check_int,
    mean_and_scale,
    require_rows,
    validate_X,
    validate_X_y,
)

MIN_ROWS_GPR = 5
# RBF length scales in standardised input units. Labels are usually set on a grid
# (a few fill heights, exactly); with noisy inputs a shorter length scale lets the GP
# fit a staircase through the grid levels with zero noise — a higher likelihood
# but a worse interpolant (3 mm vs 0.2 mm test MAE on the sugar benchmark).
LENGTH_SCALE_BOUNDS = (0.3, 100.0)
MIN_ROWS_QUADRATIC = 7  # (λ, ω): six coefficients plus one degree of freedom for the noise
# A kernel model (GP, SVM) is refit on its stored training rows whenever a model file is
# loaded: O(n³) time, O(n²) memory. Measured (2 cores, BLAS single-threaded, peak RSS
# above the 150 MB of the imports): one GP refit takes 0.13 s and +40 MB at 1000 rows,
# 0.6-1.3 s and +145 MB at 2000, 2.6 s and +225 MB at 3000, 9.6 s and +600 MB at 5000
# (20 000 rows: 136 s and 9.6 GB); the SVM refit with random labels (every row a support
# vector, the worst case) 0.4 s at 1000 rows, 2.4 s at 2000, 11 s at 5000.
#: Most training rows of one kernel model (GP regressor or SVM classifier).
MAX_KERNEL_ROWS = 2000
#: Most kernel-model training rows of one model file, summed over its targets.
MAX_KERNEL_ROWS_TOTAL = 4000
#: Rows predicted at once by a GP (bounds the (rows × training rows) cross-kernel matrix).
PREDICT_CHUNK_ROWS = 2048


def check_kernel_rows(estimator: Any, n_rows: int) -> None:
    """:class:`TableError` if a kernel model would have more than :data:`MAX_KERNEL_ROWS` rows."""
    if n_rows > MAX_KERNEL_ROWS:
        raise TableError(
            f"{type(estimator).__name__}: {n_rows} training rows, but a kernel model (GP, SVM) "
            f"is limited to {MAX_KERNEL_ROWS} rows (a model file refits it on loading, which "
            "takes O(n³) time and O(n²) memory); subsample the training table, or use the "
            "quadratic model (--model quadratic)"
        )


def single_threaded_blas() -> Any:
    """Context limiting BLAS to one thread.

    Our matrices are small (a few hundred rows): BLAS threads only add
    synchronisation, and on a loaded machine spinning threads made a GP fit
    10× slower (16 s instead of 1.6 s for 150 points).
    """
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=1, user_api="blas")


def _check_random_state(value: Any) -> None:
    if value is None or isinstance(value, np.random.RandomState):
        return
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 0:
        raise TableError(
            f"random_state must be None, an integer >= 0 or a numpy RandomState; got {value!r}"
        )


class GPRegressor(RegressorMixin, BaseEstimator):
    """Gaussian-process regression of one property from (λ, ω).

    Kernel ``C · RBF(ℓ_1, …, ℓ_d) + White(σ²)`` on standardised inputs and a
    standardised target; hyperparameters by maximum marginal likelihood with
    ``n_restarts`` random restarts (seeded by ``random_state``). Subclasses may
    add a prior mean and extra physics inputs (:mod:`liquidtouch.models.physics_prior`).

    Parameters
    ----------
    n_restarts : int >= 0
        Restarts of the marginal-likelihood optimiser from random kernels.
    random_state : int >= 0, None or numpy RandomState
        Seed of the restarts. Saving to a model file needs an int.

    Fitted attributes: ``X_train_``, ``y_train_``, ``x_mean_``, ``x_scale_``,
    ``y_mean_``, ``y_scale_``, ``gp_`` (the inner scikit-learn GP),
    ``kernel_params_``, ``n_features_in_`` (and ``feature_names_in_`` when fitted on
    a DataFrame).
    """

    model_name = "gpr"
    min_rows = MIN_ROWS_GPR

    def __init__(self, n_restarts: int = 5, random_state: Any = 0) -> None:
        self.n_restarts = n_restarts
        self.random_state = random_state

    # hooks for physics-informed subclasses ---------------------------------
    def _check_params(self) -> None:
        """Validate the hyperparameters (at fit time, as scikit-learn wants)."""
        check_int(self.n_restarts, "n_restarts", 0)
        _check_random_state(self.random_state)

    def _check_input(self, X: np.ndarray) -> None:
        """Extra checks of validated features, in fit and predict (none for the plain GP)."""

    def _fit_prior(self, X: np.ndarray, y: np.ndarray) -> None:
        """Fit the prior mean's parameters (none for the plain GP)."""

    def _prior_mean(self, X: np.ndarray) -> np.ndarray:
        return np.zeros(X.shape[0])

    def _inputs(self, X: np.ndarray) -> np.ndarray:
        return X

    def _prior_state(self) -> dict[str, Any] | None:
        return None

    def _set_prior_state(self, state: dict[str, Any] | None) -> None:
        """Restore the prior's parameters (none for the plain GP)."""

    # -------------------------------------------------------------------------
    def _kernel(self, constant: float, length_scale: list[float], noise_level: float, fixed: bool):
        from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel

        bounds = "fixed" if fixed else None
        return ConstantKernel(constant, bounds or (1e-2, 1e2)) * RBF(
            length_scale, bounds or LENGTH_SCALE_BOUNDS
        ) + WhiteKernel(noise_level, bounds or (1e-5, 1.0))

    def _fit_gp(self, kernel: Any, optimise: bool) -> None:
        from sklearn.exceptions import ConvergenceWarning
        from sklearn.gaussian_process import GaussianProcessRegressor

        self.gp_ = GaussianProcessRegressor(
            kernel=kernel,
            optimizer="fmin_l_bfgs_b" if optimise else None,
            n_restarts_optimizer=self.n_restarts if optimise else 0,
            random_state=self.random_state,
        )
        Z = (self._inputs(self.X_train_) - self.x_mean_) / self.x_scale_
        r = (self.y_train_ - self._prior_mean(self.X_train_) - self.y_mean_) / self.y_scale_
        with warnings.catch_warnings(), single_threaded_blas():
            # a hyperparameter at its bound is a legitimate optimum on tiny data sets
            warnings.simplefilter("ignore", ConvergenceWarning)
            self.gp_.fit(Z, r)

    def fit(self, X: Any, y: Any) -> GPRegressor:
        """Fit on (n, d) features ``X`` and one target ``y`` of shape (n,); return ``self``.

        Raises :class:`TableError` for bad hyperparameters, a bad shape, NaN or
        infinity, fewer than :data:`MIN_ROWS_GPR` or more than :data:`MAX_KERNEL_ROWS` rows.
        """
        self._check_params()
        X, y = validate_X_y(self, X, y, self.min_rows)
        check_kernel_rows(self, X.shape[0])
        self._check_input(X)
        self.X_train_, self.y_train_ = X, y
        self._fit_prior(self.X_train_, self.y_train_)
        self.x_mean_, self.x_scale_ = mean_and_scale(self._inputs(self.X_train_))
        residual = self.y_train_ - self._prior_mean(self.X_train_)
        self.y_mean_, self.y_scale_ = float(residual.mean()), float(residual.std() or 1.0)
        n_inputs = self.x_mean_.shape[0]
        self._fit_gp(self._kernel(1.0, [1.0] * n_inputs, 0.1, fixed=False), optimise=True)
        return self

    @property
    def kernel_params_(self) -> dict[str, Any]:
        """Fitted kernel: ``constant``, ``length_scale`` (standardised), ``noise_level``."""
        check_is_fitted(self, "gp_")
        params = self.gp_.kernel_.get_params()
        length_scale = np.atleast_1d(params["k1__k2__length_scale"]).astype(float)
        return {
            "constant": float(params["k1__k1__constant_value"]),
            "length_scale": [float(v) for v in length_scale],
            "noise_level": float(params["k2__noise_level"]),
        }

    def predict(self, X: Any, return_std: bool = False) -> Any:
        """Predicted target at ``X``, shape (n,).

        With ``return_std=True`` return ``(mean, std)``, both (n,); the standard
        deviation is that of a new observation (it includes the fitted noise).
        """
        check_is_fitted(self, "gp_")
        X = validate_X(self, X)
        self._check_input(X)
        Z = (self._inputs(X) - self.x_mean_) / self.x_scale_
        prior = self._prior_mean(X)
        starts = range(0, Z.shape[0], PREDICT_CHUNK_ROWS)
        if not return_std:
            parts = [self.gp_.predict(Z[i : i + PREDICT_CHUNK_ROWS]) for i in starts]
            return prior + self.y_mean_ + self.y_scale_ * np.concatenate(parts)
        chunks = [self.gp_.predict(Z[i : i + PREDICT_CHUNK_ROWS], return_std=True) for i in starts]
        mean = np.concatenate([m for m, _ in chunks])
        std = np.concatenate([sd for _, sd in chunks])
        return prior + self.y_mean_ + self.y_scale_ * mean, self.y_scale_ * std

    def describe(self) -> str:
        """A one-line summary of the fitted kernel (in standardised units)."""
        k = self.kernel_params_
        scales = ", ".join(f"{v:.3g}" for v in k["length_scale"])
        return f"{k['constant']:.3g}·RBF(ℓ=[{scales}]) + White({k['noise_level']:.3g})"

    def to_state(self) -> dict[str, Any]:
        """Plain-data state: hyperparameters, scaling, kernel and training data."""
        check_is_fitted(self, "gp_")
        if isinstance(self.random_state, bool) or not isinstance(
            self.random_state, numbers.Integral
        ):
            raise ModelFileError(
                f"a model file stores an integer random_state; this {type(self).__name__} has "
                f"random_state={self.random_state!r} (refit it with an integer)"
            )
        return {
            "model": self.model_name,
            "n_restarts": int(self.n_restarts),
            "random_state": int(self.random_state),
            "kernel": self.kernel_params_,
            "prior": self._prior_state(),
            "x_mean": self.x_mean_.tolist(),
            "x_scale": self.x_scale_.tolist(),
            "y_mean": self.y_mean_,
            "y_scale": self.y_scale_,
            "X_train": self.X_train_.tolist(),
            "y_train": self.y_train_.tolist(),
        }

    @classmethod
    def _construct(cls, state: dict[str, Any]) -> GPRegressor:
        return cls(n_restarts=state["n_restarts"], random_state=state["random_state"])

    @classmethod
    def from_state(cls, state: dict[str, Any]) -> GPRegressor:
        """Rebuild exactly: refit the stored kernel on the stored data without optimiser."""
        self = cls._construct(state)
        self.X_train_ = np.asarray(state["X_train"], dtype=float)
        self.y_train_ = np.asarray(state["y_train"], dtype=float)
        self.n_features_in_ = self.X_train_.shape[1]
        self._set_prior_state(state["prior"])
        self.x_mean_ = np.asarray(state["x_mean"], dtype=float)
        self.x_scale_ = np.asarray(state["x_scale"], dtype=float)
        self.y_mean_, self.y_scale_ = float(state["y_mean"]), float(state["y_scale"])
        k = state["kernel"]
        kernel = self._kernel(k["constant"], k["length_scale"], k["noise_level"], fixed=True)
        self._fit_gp(kernel, optimise=False)
        return self


def n_quadratic_terms(n_features: int) -> int:
    """Coefficients of a full quadratic in ``n_features`` variables (6 for (λ, ω))."""
    return (n_features + 1) * (n_features + 2) // 2


class QuadraticRegressor(RegressorMixin, BaseEstimator):
    """The paper's 6-parameter model ``y = a0 + a1 λ + a2 ω + a3 λ² + a4 λω + a5 ω²``.

    Least squares on standardised (λ, ω) for conditioning; the predictive
    standard deviation is the ordinary-least-squares one,
    ``s · sqrt(1 + φᵀ (ΦᵀΦ)⁻¹ φ)``. With d features the model is the full
    quadratic in d variables; fitting needs one row more than coefficients
    (:data:`MIN_ROWS_QUADRATIC` = 7 for (λ, ω)). No hyperparameters.

    Fitted attributes: ``coef_``, ``noise_variance_``, ``covariance_``,
    ``X_train_``, ``y_train_``, ``x_mean_``, ``x_scale_``, ``n_features_in_``.
    """

    model_name = "quadratic"

    @staticmethod
    def _design(Z: np.ndarray) -> np.ndarray:
        d = Z.shape[1]
        linear = [Z[:, i] for i in range(d)]
        pairs = [Z[:, i] * Z[:, j] for i, j in combinations_with_replacement(range(d), 2)]
        return np.column_stack([np.ones_like(Z[:, 0]), *linear, *pairs])

    def fit(self, X: Any, y: Any) -> QuadraticRegressor:
        """Least-squares fit on (n, d) features ``X`` and one target ``y`` (n,); return ``self``."""
        X, y = validate_X_y(self, X, y)
        require_rows(self, X.shape[0], n_quadratic_terms(X.shape[1]) + 1)
        self.X_train_, self.y_train_ = X, y
        self.x_mean_, self.x_scale_ = mean_and_scale(self.X_train_)
        design = self._design((self.X_train_ - self.x_mean_) / self.x_scale_)
        self.coef_, *_ = np.linalg.lstsq(design, self.y_train_, rcond=None)
        residual = self.y_train_ - design @ self.coef_
        dof = max(design.shape[0] - design.shape[1], 1)
        self.noise_variance_ = float(residual @ residual / dof)
        self.covariance_ = np.linalg.pinv(design.T @ design)
        return self

    def predict(self, X: Any, return_std: bool = False) -> Any:
        """Predicted target at ``X``, shape (n,); with ``return_std=True`` also its OLS std."""
        check_is_fitted(self, "coef_")
        design = self._design((validate_X(self, X) - self.x_mean_) / self.x_scale_)
        mean = design @ self.coef_
        if not return_std:
            return mean
        leverage = np.einsum("ij,jk,ik->i", design, self.covariance_, design)
        return mean, np.sqrt(self.noise_variance_ * (1.0 + leverage))

    def describe(self) -> str:
        """The fitted coefficients (on standardised features)."""
        check_is_fitted(self, "coef_")
        d = self.n_features_in_
        if d == 2:
            names = ("1", "λ", "ω", "λ²", "λω", "ω²")
            where = "standardised (λ, ω)"
        else:
            pairs = combinations_with_replacement(range(d), 2)
            names = ("1", *(f"x{i}" for i in range(d)), *(f"x{i}·x{j}" for i, j in pairs))
            where = f"{d} standardised features"
        terms = " ".join(f"{c:+.4g}·{n}" for c, n in zip(self.coef_, names, strict=True))
        return f"quadratic in {where}: {terms}"

    def to_state(self) -> dict[str, Any]:
        """Plain-data state: training data (the fit is deterministic) and the coefficients."""
        check_is_fitted(self, "coef_")
        return {
            "model": self.model_name,
            "coef": self.coef_.tolist(),
            "X_train": self.X_train_.tolist(),
            "y_train": self.y_train_.tolist(),
        }

    @classmethod
    def from_state(cls, state: dict[str, Any]) -> QuadraticRegressor:
        """Rebuild by refitting on the stored data; the stored coefficients must agree."""
        self = cls().fit(state["X_train"], state["y_train"])
        if not np.allclose(self.coef_, state["coef"], rtol=1e-9, atol=1e-12):
            raise ModelFileError(
                "the quadratic model's stored coefficients do not match its training data "
                "(the model file was edited or is corrupt); retrain it"
            )
        return self
