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
:func:`~liquidtouch.models.training.train_regression` builds one per
target; ``sklearn.multioutput.MultiOutputRegressor`` does the same and returns (n, k).

- :class:`GPRegressor` — Gaussian-process regression with an anisotropic RBF +
  white-noise kernel on standardised inputs and targets (the paper's model). Given
  the training rows' own feature std (``fit(X, y, X_std=...)``), each row also gets
  its own noise: its (λ, ω) std propagated through a first fit, added to the kernel's
  diagonal before the kernel is fitted again (a noisy-input GP, McHutchon & Rasmussen
  2011), the common white noise kept at least at the first fit's level (a fit's std
  under-states its error on some rows: ``benchmarks/RESULTS.md``, fit_std). A row whose
  fit is uncertain then pulls the model less: one white-noise level for every row let
  simulated detergent's scattered rows (ω std ~1 %, against 0.01-0.2 % for the other
  liquids) bend the height surface, its test height error 1.9 mm against 1.2 mm with the
  rows' own noise (``benchmarks/RESULTS.md``, calibration).
- :class:`~liquidtouch.models.quadratic.QuadraticRegressor` — the paper's
  6-parameter quadratic in (λ, ω) (:mod:`liquidtouch.models.quadratic`).

Every fitted estimator can be written as a plain dict (``to_state``) holding
its hyperparameters and training data, and rebuilt exactly from it
(``from_state``): the rebuild refits deterministically with the stored
hyperparameters (no optimiser), so predictions are bit-identical.
"""

from __future__ import annotations

import numbers
import warnings
from typing import Any

import numpy as np
from scipy.spatial.distance import cdist
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.utils.validation import check_is_fitted

from liquidtouch._core.checks import check_int
from liquidtouch.errors import ModelFileError, TableError
from liquidtouch.models.gp_likelihood import LikelihoodOptimizer
from liquidtouch.models.kernel_limits import (
    check_kernel_rows,
    single_threaded_blas,
)
from liquidtouch.models.propagation import clean_feature_std, propagated_variance
from liquidtouch.models.validation import mean_and_scale, validate_X, validate_X_y

__all__ = ["LENGTH_SCALE_BOUNDS", "MIN_ROWS_GPR", "PREDICT_CHUNK_ROWS", "GPRegressor"]

MIN_ROWS_GPR = 5
# RBF length scales in standardised input units. Labels are usually set on a grid
# (a few fill heights, exactly); with noisy inputs a shorter length scale lets the GP
# fit a staircase through the grid levels with zero noise — a higher likelihood
# but a worse interpolant (3 mm vs 0.2 mm test MAE on the sugar benchmark).
LENGTH_SCALE_BOUNDS = (0.3, 100.0)
#: added to the kernel's diagonal for numerical stability (scikit-learn's default ``alpha``)
GP_JITTER = 1e-10
#: bounds of the white-noise level (standardised target variance)
MIN_NOISE_LEVEL, MAX_NOISE_LEVEL = 1e-5, 1.0
#: bounds of the kernel's constant (standardised target variance)
CONSTANT_BOUNDS = (1e-2, 1e2)
#: most optimiser restarts of a GP fit (each costs a fit; 5 by default): a model file's
#: count is refused beyond it (a refit that may take minutes)
MAX_RESTARTS = 50
#: Rows predicted at once by a GP (bounds the (rows × training rows) cross-kernel matrix).
PREDICT_CHUNK_ROWS = 2048


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

    Notes
    -----
    Fitted attributes: ``X_train_``, ``y_train_``, ``x_mean_``, ``x_scale_``,
    ``y_mean_``, ``y_scale_``, ``row_noise_`` (each row's own noise variance in
    standardised target units, ``None`` without ``X_std``), ``gp_`` (the inner
    scikit-learn GP), ``kernel_params_``, ``n_features_in_`` (and
    ``feature_names_in_`` when fitted on a DataFrame).
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
        if self.n_restarts > MAX_RESTARTS:
            raise TableError(f"n_restarts must be at most {MAX_RESTARTS}; got {self.n_restarts}")
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
    def _kernel(
        self,
        constant: float,
        length_scale: list[float],
        noise_level: float,
        fixed: bool,
        min_noise: float = MIN_NOISE_LEVEL,
    ):
        from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel

        bounds = "fixed" if fixed else None
        return ConstantKernel(constant, bounds or CONSTANT_BOUNDS) * RBF(
            length_scale, bounds or LENGTH_SCALE_BOUNDS
        ) + WhiteKernel(noise_level, bounds or (min_noise, MAX_NOISE_LEVEL))

    def _fit_gp(self, kernel: Any, optimise: bool) -> None:
        from sklearn.exceptions import ConvergenceWarning
        from sklearn.gaussian_process import GaussianProcessRegressor

        Z = (self._inputs(self.X_train_) - self.x_mean_) / self.x_scale_
        r = (self.y_train_ - self._prior_mean(self.X_train_) - self.y_mean_) / self.y_scale_
        diagonal = GP_JITTER if self.row_noise_ is None else GP_JITTER + self.row_noise_
        self.gp_ = GaussianProcessRegressor(
            kernel=kernel,
            optimizer=LikelihoodOptimizer(Z, r, diagonal) if optimise else None,
            alpha=diagonal,
            n_restarts_optimizer=self.n_restarts if optimise else 0,
            random_state=self.random_state,
        )
        with warnings.catch_warnings(), single_threaded_blas():
            # a hyperparameter at its bound is a legitimate optimum on tiny data sets
            warnings.simplefilter("ignore", ConvergenceWarning)
            self.gp_.fit(Z, r)
        self.gp_.optimizer = None  # fitted: the optimiser's copy of the data is not kept

    def fit(self, X: Any, y: Any, X_std: Any = None) -> GPRegressor:
        """Fit on (n, 2) features ``X`` and one target ``y`` of shape (n,); return ``self``.

        ``X_std`` (n, 2): the rows' own std of (λ, ω) (NaN counts as 0); each row's
        noise is then its std propagated through a first fit, and the kernel is fitted
        again with it (module docstring; twice the cost).

        Raises :class:`TableError` for bad hyperparameters, a bad shape, NaN or
        infinity, fewer than :data:`MIN_ROWS_GPR` or more than :data:`MAX_KERNEL_ROWS` rows.
        """
        self._check_params()
        X, y = validate_X_y(self, X, y, self.min_rows)
        check_kernel_rows(self, X.shape[0])
        self._check_input(X)
        X_std = None if X_std is None else clean_feature_std(X_std, X.shape[0])
        self.X_train_, self.y_train_, self.row_noise_ = X, y, None
        self._fit_prior(self.X_train_, self.y_train_)
        self.x_mean_, self.x_scale_ = mean_and_scale(self._inputs(self.X_train_))
        residual = self.y_train_ - self._prior_mean(self.X_train_)
        self.y_mean_, self.y_scale_ = float(residual.mean()), float(residual.std() or 1.0)
        n_inputs = self.x_mean_.shape[0]
        self._fit_gp(self._kernel(1.0, [1.0] * n_inputs, 0.1, fixed=False), optimise=True)
        if X_std is not None and np.any(X_std > 0):
            _, var = propagated_variance(lambda rows: {"y": self.predict(rows)}, X, X_std)
            self.row_noise_ = var["y"] / self.y_scale_**2
            # the common noise stays at least the level found without the rows' own:
            # a fit's std under-states its error on some rows, so it widens, not replaces it
            k = self.kernel_params_
            kernel = self._kernel(
                k["constant"], k["length_scale"], k["noise_level"], fixed=False,
                min_noise=k["noise_level"],
            )  # fmt: skip
            self._fit_gp(kernel, optimise=True)
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
            parts = [self._gp_mean(Z[i : i + PREDICT_CHUNK_ROWS]) for i in starts]
            return prior + self.y_mean_ + self.y_scale_ * np.concatenate(parts)
        chunks = [self.gp_.predict(Z[i : i + PREDICT_CHUNK_ROWS], return_std=True) for i in starts]
        mean = np.concatenate([m for m, _ in chunks])
        std = np.concatenate([sd for _, sd in chunks])
        return prior + self.y_mean_ + self.y_scale_ * mean, self.y_scale_ * std

    def _gp_mean(self, Z: np.ndarray) -> np.ndarray:
        """The GP's posterior mean at standardised inputs ``Z``: scikit-learn's
        ``gp_.predict(Z)`` to the bit, without its input checks (``predict`` made them),
        which cost ~10× the algebra on a few rows (``fit_transfer`` predicts thousands
        of times)."""
        product = self.gp_.kernel_.k1  # C · RBF; the white kernel adds 0 between points
        scale = product.k2.length_scale
        sq = cdist(Z / scale, self.gp_.X_train_ / scale, metric="sqeuclidean")
        return (product.k1.constant_value * np.exp(-0.5 * sq)) @ self.gp_.alpha_

    def describe(self) -> str:
        """A one-line summary of the fitted kernel (in standardised units)."""
        k = self.kernel_params_
        scales = ", ".join(f"{v:.3g}" for v in k["length_scale"])
        text = f"{k['constant']:.3g}·RBF(ℓ=[{scales}]) + White({k['noise_level']:.3g})"
        if self.row_noise_ is None:
            return text
        median, largest = np.median(self.row_noise_), np.max(self.row_noise_)
        return f"{text} + each row's own noise (median {median:.3g}, max {largest:.3g})"

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
            "row_noise": None if self.row_noise_ is None else self.row_noise_.tolist(),
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
        row_noise = state.get("row_noise")  # format version 7
        self.row_noise_ = None if row_noise is None else np.asarray(row_noise, dtype=float)
        self.n_features_in_ = self.X_train_.shape[1]
        self._set_prior_state(state["prior"])
        self.x_mean_ = np.asarray(state["x_mean"], dtype=float)
        self.x_scale_ = np.asarray(state["x_scale"], dtype=float)
        self.y_mean_, self.y_scale_ = float(state["y_mean"]), float(state["y_scale"])
        k = state["kernel"]
        kernel = self._kernel(k["constant"], k["length_scale"], k["noise_level"], fixed=True)
        self._fit_gp(kernel, optimise=False)
        return self
