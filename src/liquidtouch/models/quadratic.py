"""The paper's 6-parameter quadratic regression of one property from (λ [1/s], ω [rad/s]).

A scikit-learn estimator like :class:`~liquidtouch.models.regressors.GPRegressor`
(see :mod:`liquidtouch.models.regressors` for the conventions: one target per
estimator, ``predict(X, return_std=True)``, ``to_state``/``from_state``).
"""

from __future__ import annotations

from itertools import combinations_with_replacement
from typing import Any

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.utils.validation import check_is_fitted

from liquidtouch.errors import ModelFileError
from liquidtouch.models.validation import mean_and_scale, require_rows, validate_X, validate_X_y

MIN_ROWS_QUADRATIC = 7  # (λ, ω): six coefficients plus one degree of freedom for the noise


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
