"""Classifying the liquid from (λ, ω): an RBF-kernel SVM with class probabilities.

Inputs are standardised; ``C`` and ``gamma`` are chosen by stratified
cross-validation over a small grid unless given. Probabilities come from
sigmoid (Platt) calibration on cross-validated decision values
(``CalibratedClassifierCV(SVC(), ensemble=False)``, scikit-learn's replacement
for ``SVC(probability=True)``). Everything is deterministic, so a model file
storing the training data and the chosen ``C``/``gamma`` rebuilds it exactly.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.utils.validation import check_is_fitted

from liquidtouch._core.checks import check_positive
from liquidtouch.errors import ModelFileError, TableError
from liquidtouch.models.kernel_limits import check_kernel_rows, single_threaded_blas
from liquidtouch.models.validation import mean_and_scale, validate_X, validate_X_y

MIN_ROWS_PER_CLASS = 3
# Moderate values first: on a tie of cross-validated accuracy (small, well-separated
# training sets score 100 % everywhere) the first is taken, and the most regularised
# corner (C = 0.1, γ = 0.1) underfits so much that it misclassifies its own training data.
C_GRID = (10.0, 1.0, 100.0, 0.1, 1000.0)
GAMMA_GRID = (1.0, 0.3, 3.0, 0.1, 10.0)


class LiquidClassifier(ClassifierMixin, BaseEstimator):
    """RBF-kernel SVM on standardised (λ, ω) with calibrated class probabilities.

    A scikit-learn classifier. ``C`` and ``gamma`` (in standardised units)
    default to ``None``: choose them by stratified cross-validated accuracy on
    :data:`C_GRID` × :data:`GAMMA_GRID`. Needs at least 2 classes and
    :data:`MIN_ROWS_PER_CLASS` rows of each, and at most
    :data:`~liquidtouch.models.kernel_limits.MAX_KERNEL_ROWS` rows. Class labels keep their type
    (model files store them as strings; ``train_classifier`` converts them).

    Fitted attributes: ``classes_``, ``C_``, ``gamma_`` (the values used),
    ``model_`` (the calibrated SVM), ``X_train_``, ``labels_train_``, ``x_mean_``,
    ``x_scale_``, ``n_features_in_``.
    """

    model_name = "svm"

    def __init__(self, C: float | None = None, gamma: float | None = None) -> None:
        self.C = C
        self.gamma = gamma

    def _folds(self, labels: np.ndarray) -> int:
        _, counts = np.unique(labels, return_counts=True)
        return int(min(5, counts.min()))

    def _select(self, Z: np.ndarray, labels: np.ndarray) -> tuple[float, float]:
        from sklearn.model_selection import GridSearchCV, StratifiedKFold
        from sklearn.svm import SVC

        grid = {
            "C": [float(self.C)] if self.C is not None else list(C_GRID),
            "gamma": [float(self.gamma)] if self.gamma is not None else list(GAMMA_GRID),
        }
        if len(grid["C"]) * len(grid["gamma"]) == 1:
            return grid["C"][0], grid["gamma"][0]
        search = GridSearchCV(SVC(kernel="rbf"), grid, cv=StratifiedKFold(self._folds(labels)))
        search.fit(Z, labels)
        return float(search.best_params_["C"]), float(search.best_params_["gamma"])

    def fit(self, X: Any, y: Any) -> LiquidClassifier:
        """Fit on (n, d) features ``X`` and class labels ``y`` (n,); return ``self``.

        Raises :class:`TableError` for C or gamma not > 0, bad features, continuous
        labels, fewer than 2 classes or fewer than 3 rows of a class.
        """
        from sklearn.calibration import CalibratedClassifierCV
        from sklearn.model_selection import StratifiedKFold
        from sklearn.svm import SVC

        for name in ("C", "gamma"):
            if getattr(self, name) is not None:
                check_positive(getattr(self, name), name)
        X, labels = validate_X_y(self, X, y, classification=True)
        check_kernel_rows(self, X.shape[0])
        classes, counts = np.unique(labels, return_counts=True)
        if classes.size < 2:
            raise TableError(
                f"classification needs at least 2 classes; got 1 class: {classes.tolist()}"
            )
        if counts.min() < MIN_ROWS_PER_CLASS:
            few = ", ".join(
                f"{c} ({n})" for c, n in zip(classes, counts, strict=True) if n < MIN_ROWS_PER_CLASS
            )
            raise TableError(
                f"classification needs at least {MIN_ROWS_PER_CLASS} rows per class; "
                f"too few for: {few} (add trials)"
            )
        self.X_train_, self.labels_train_ = X, labels
        self.x_mean_, self.x_scale_ = mean_and_scale(X)
        Z = (X - self.x_mean_) / self.x_scale_
        with single_threaded_blas():  # small problems: BLAS threads only contend (3× slower)
            self.C_, self.gamma_ = self._select(Z, labels)
            self.model_ = CalibratedClassifierCV(
                SVC(kernel="rbf", C=self.C_, gamma=self.gamma_),
                method="sigmoid",
                cv=StratifiedKFold(self._folds(labels)),
                ensemble=False,
            ).fit(Z, labels)
        self.classes_ = self.model_.classes_
        return self

    def _z(self, X: Any) -> np.ndarray:
        check_is_fitted(self, "model_")
        return (validate_X(self, X) - self.x_mean_) / self.x_scale_

    def predict(self, X: Any) -> np.ndarray:
        """The most probable class of each row (consistent with :meth:`predict_proba`)."""
        check_is_fitted(self, "model_")
        return self.classes_[np.argmax(self.predict_proba(X), axis=1)]

    def predict_proba(self, X: Any) -> np.ndarray:
        """Calibrated class probabilities (n, n_classes), columns in the order of ``classes_``."""
        Z = self._z(X)
        return self.model_.predict_proba(Z)

    def describe(self) -> str:
        """The chosen hyperparameters and class names."""
        check_is_fitted(self, "model_")
        return (
            f"RBF SVM, C={self.C_:.3g}, gamma={self.gamma_:.3g} (standardised λ, ω); "
            f"classes: {', '.join(map(str, self.classes_))}"
        )

    def to_state(self) -> dict[str, Any]:
        """Plain-data state: chosen hyperparameters and training data (labels as strings)."""
        check_is_fitted(self, "model_")
        if not all(isinstance(label, str) for label in self.labels_train_.tolist()):
            raise ModelFileError(
                "a model file stores class names as strings; fit the classifier on string "
                "labels (train_classifier converts them)"
            )
        return {
            "model": self.model_name,
            "C": self.C_,
            "gamma": self.gamma_,
            "X_train": self.X_train_.tolist(),
            "labels_train": self.labels_train_.tolist(),
        }

    @classmethod
    def from_state(cls, state: dict[str, Any]) -> LiquidClassifier:
        """Rebuild exactly by the deterministic refit with the stored C and gamma."""
        labels = np.asarray(state["labels_train"], dtype=str)
        return cls(C=state["C"], gamma=state["gamma"]).fit(state["X_train"], labels)
