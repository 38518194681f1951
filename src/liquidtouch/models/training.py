"""Training property models: a feature table's (λ, ω) and labels in, a :class:`PropertyModel` out.

:func:`train_regression` fits one regressor per target (:data:`MODEL_KINDS`) and, with
``calibration_folds``, calibrates each target's std and intervals by cross-conformal
prediction; :func:`train_classifier` fits the liquid classifier.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from liquidtouch.errors import TableError
from liquidtouch.models.classifier import LiquidClassifier
from liquidtouch.models.conformal import (
    DEFAULT_FOLDS,
    calibrate_regressor,
    calibration_folds,
    feature_std_param,
)
from liquidtouch.models.kernel_limits import MAX_KERNEL_ROWS_TOTAL, check_kernel_rows
from liquidtouch.models.physics_prior import PhysicsGPRegressor, prior_for_target
from liquidtouch.models.property_model import MODEL_KINDS, REGRESSORS, PropertyModel
from liquidtouch.models.quadratic import QuadraticRegressor
from liquidtouch.models.regressors import GPRegressor
from liquidtouch.models.validation import check_features

__all__ = ["can_calibrate", "make_regressor", "train_classifier", "train_regression"]


def make_regressor(model: str, target: str, random_state: int = 0) -> Any:
    """A fresh (unfitted) regressor of kind ``model`` (one of :data:`MODEL_KINDS`) for ``target``.

    ``target`` picks the physics prior of a ``physics-gpr``
    (:func:`~liquidtouch.models.physics_prior.prior_for_target`).
    """
    if model not in REGRESSORS:
        raise TableError(f"unknown model {model!r}; choose one of {', '.join(MODEL_KINDS)}")
    if model == "physics-gpr":
        return PhysicsGPRegressor(prior_for_target(target), random_state=random_state)
    if model == "gpr":
        return GPRegressor(random_state=random_state)
    return QuadraticRegressor()


def train_regression(
    X: Any,
    targets: Mapping[str, Any],
    model: str = "gpr",
    progress: Callable[[str], None] | None = None,
    calibration_folds: int | None = None,
    calibration_groups: Any = None,
    calibration_std: Any = None,
) -> PropertyModel:
    """Fit one regressor of kind ``model`` per target; ``targets`` maps column → values.

    ``X`` is the (n, 2) array of (λ [1/s], ω [rad/s]); each target has n finite
    values. ``progress(target)`` is called after each target (for progress bars).
    ``calibration_folds`` K: also calibrate each target's std and intervals by K-fold
    cross-conformal (:func:`~liquidtouch.models.conformal.calibrate_regressor`; K more
    fits per target), when every fold keeps the estimator's minimum of rows; ``None``:
    no calibration. ``calibration_groups`` (n,): rows held out together (e.g. the fill
    height of each row: a row is then predicted by a model that never saw its height).
    ``calibration_std`` (n, 2): the rows' own fit std of (λ, ω) (a features table's
    ``*_std`` columns); a GP then gives each row its own noise
    (:class:`~liquidtouch.models.regressors.GPRegressor`), and the scores are normalised
    by the total std the model predicts with (:mod:`~liquidtouch.models.conformal`,
    ``normalised_by="total-std"``).
    Raises :class:`TableError` for bad input, before any fitting.
    """
    if model not in REGRESSORS:
        raise TableError(f"unknown model {model!r}; choose one of {', '.join(MODEL_KINDS)}")
    X = check_features(X)
    if not isinstance(targets, Mapping) or not targets:
        raise TableError("give at least one target column to train on (a dict column → values)")
    if model != "quadratic":  # kernel models are refit on loading: bounded size
        check_kernel_rows(make_regressor(model, next(iter(targets))), X.shape[0])
        if X.shape[0] * len(targets) > MAX_KERNEL_ROWS_TOTAL:
            raise TableError(
                f"{len(targets)} GP targets × {X.shape[0]} rows = "
                f"{X.shape[0] * len(targets)} GP training rows, but a model file holds at most "
                f"{MAX_KERNEL_ROWS_TOTAL} (each GP is refit on loading); train one model per "
                "target, subsample the training table, or use the quadratic model "
                "(`model` quadratic)"
            )
    if progress is not None and not callable(progress):
        raise TableError("progress must be a callable taking the target name, or None")
    for target, y in targets.items():
        n_y = np.shape(y)[0] if np.ndim(y) >= 1 else 0
        if n_y != X.shape[0]:
            raise TableError(f"target {target}: {X.shape[0]} feature rows but {n_y} values")
        if model == "physics-gpr":
            prior_for_target(target)  # an unknown target fails before the first (slow) fit
    regressors, calibration = {}, {}
    for target, y in targets.items():
        regressor = make_regressor(model, target)
        regressors[target] = regressor.fit(X, y, **feature_std_param(regressor, calibration_std))
        if calibration_folds is not None and can_calibrate(
            model, X.shape[0], calibration_folds, calibration_groups
        ):
            calibration[target] = calibrate_regressor(
                make_regressor(model, target),
                X,
                y,
                calibration_folds,
                groups=calibration_groups,
                X_std=calibration_std,
            )
        if progress is not None:
            progress(target)
    return PropertyModel(regressors=regressors, calibration=calibration)


def can_calibrate(
    model: str, n_rows: int, n_folds: int = DEFAULT_FOLDS, groups: Any = None
) -> bool:
    """Whether every cross-conformal fold leaves the estimator its minimum of training rows."""
    try:
        folds = calibration_folds(int(n_rows), int(n_folds), groups)
    except TableError:
        return False
    need = getattr(REGRESSORS[model], "min_rows", 7)
    return all(len(train) >= need for train, _ in folds)


def train_classifier(X: Any, labels: Any, label: str = "liquid") -> PropertyModel:
    """Fit the RBF-SVM liquid classifier on (n, 2) features ``X`` and class names ``labels``.

    Labels are converted to strings (model files store class names).
    """
    X = check_features(X)
    if not isinstance(label, str) or not label:
        raise TableError(f"label must be a non-empty column name; got {label!r}")
    labels = np.asarray(labels)
    if labels.ndim != 1 or labels.shape[0] != X.shape[0]:
        raise TableError(f"{X.shape[0]} feature rows but labels of shape {labels.shape}")
    labels = labels.astype(str)
    return PropertyModel(classifier=LiquidClassifier().fit(X, labels), label=label)
