"""Argument validation of the models layer: bad input raises :class:`TableError`.

Two levels:

- :func:`check_features` — the project's edge (``train_regression``,
  ``PropertyModel.predict``, ``fit_transfer``): exactly the two features
  ``FEATURE_COLUMNS`` (decay_rate λ [1/s], angular_frequency ω [rad/s]).
- :func:`validate_X` / :func:`validate_X_y` — inside the scikit-learn
  estimators: any number of features, scikit-learn's bookkeeping
  (``n_features_in_``, ``feature_names_in_``, the "X has 1 features, but ... is
  expecting 2" check) and its messages, re-raised as :class:`TableError`
  (a ``ValueError``, as scikit-learn expects). Passing the wrong Python type
  (a sparse matrix, a dict) stays a ``TypeError``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from liquidtouch.errors import TableError
from liquidtouch.io.tables import FEATURE_COLUMNS

_FEATURES_TEXT = ", ".join(FEATURE_COLUMNS)


def _rows(mask: np.ndarray) -> str:
    rows = np.flatnonzero(mask)
    shown = ", ".join(str(r) for r in rows[:5])
    return shown + (f" and {rows.size - 5} more" if rows.size > 5 else "")


def _check_finite(values: np.ndarray, what: str) -> None:
    finite = np.isfinite(values)
    if not finite.all():
        bad = ~finite.reshape(values.shape[0], -1).all(axis=1)
        raise TableError(
            f"{what} contains NaN or infinite values in row(s) {_rows(bad)} (0-based); "
            "drop or fix those rows"
        )


def check_features(X: Any, n_columns: int = len(FEATURE_COLUMNS)) -> np.ndarray:
    """``X`` as a finite, C-contiguous float (n, 2) array of (λ [1/s], ω [rad/s]).

    Raises :class:`TableError` for another shape, no rows, text, NaN or infinity.
    """
    try:
        # one memory layout, so that a refit on stored data repeats the same float operations
        X = np.ascontiguousarray(X, dtype=float)
    except (TypeError, ValueError) as exc:
        raise TableError(f"features must be numeric ({_FEATURES_TEXT}); {exc}") from None
    if X.ndim != 2 or X.shape[1] != n_columns or X.shape[0] == 0:
        raise TableError(
            f"features must be an (n, {n_columns}) array of ({_FEATURES_TEXT}) with n >= 1; "
            f"got shape {X.shape}"
        )
    _check_finite(X, "features")
    return X


def _validate_data(estimator: Any, **kwargs: Any) -> Any:
    try:
        from sklearn.utils.validation import validate_data  # scikit-learn >= 1.6
    except ImportError:  # pragma: no cover - scikit-learn 1.4 and 1.5
        kwargs["force_all_finite"] = kwargs.pop("ensure_all_finite")
        return estimator._validate_data(**kwargs)
    return validate_data(estimator, **kwargs)


def _sklearn_validate(estimator: Any, **kwargs: Any) -> Any:
    try:
        return _validate_data(
            estimator,
            dtype=np.float64,
            order="C",
            ensure_all_finite=False,  # checked below, with our message
            **kwargs,
        )
    except TableError:
        raise
    except ValueError as exc:
        raise TableError(f"{type(estimator).__name__}: {exc}") from None


def validate_X(estimator: Any, X: Any) -> np.ndarray:
    """Validate prediction input against the fitted ``estimator`` (same features as in fit)."""
    if (
        type(X) is np.ndarray
        and X.dtype == np.float64
        and X.ndim == 2
        and X.flags.c_contiguous
        and not hasattr(estimator, "feature_names_in_")
    ):
        # fast path (fit_transfer predicts thousands of times): what scikit-learn would check
        if X.shape[1] != estimator.n_features_in_:
            raise TableError(
                f"X has {X.shape[1]} features, but {type(estimator).__name__} is expecting "
                f"{estimator.n_features_in_} features as input."
            )
        if X.shape[0] == 0:
            raise TableError("features X: found array with 0 sample(s); need at least 1 row")
    else:
        X = _sklearn_validate(estimator, X=X, reset=False)
    _check_finite(X, "features X")
    return X


def _n_rows(values: Any) -> int | None:
    """Rows of an array-like without converting it (``None`` if unknown: let sklearn say)."""
    shape = getattr(values, "shape", None)
    if shape is not None:
        return int(shape[0]) if len(shape) == 2 or len(shape) == 1 else None
    if isinstance(values, list | tuple):
        return len(values)
    return None


def validate_X_y(
    estimator: Any, X: Any, y: Any, min_rows: int = 1, classification: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """Validate a training set and record ``n_features_in_`` (and ``feature_names_in_``).

    Regression (one target per estimator): ``y`` must be numeric and 1-D (an
    (n, 1) column is accepted with scikit-learn's ``DataConversionWarning``).
    Classification: ``y`` holds class labels (strings or integers), not
    continuous values. At least ``min_rows`` rows.
    """
    name = type(estimator).__name__
    n_x, n_y = _n_rows(X), _n_rows(y)
    if n_x is not None and n_y is not None and n_x != n_y:
        what = "labels" if classification else "target values"
        raise TableError(f"{n_x} feature rows but {n_y} {what}")
    shape_y = getattr(y, "shape", None)
    if not classification and shape_y is not None and len(shape_y) == 2 and shape_y[1] > 1:
        raise TableError(
            f"{name} learns one target (y of shape (n,)); got y of shape {shape_y}. "
            "Fit one estimator per target (train_regression does) or wrap it in "
            "sklearn.multioutput.MultiOutputRegressor"
        )
    X, y = _sklearn_validate(estimator, X=X, y=y, reset=True, y_numeric=not classification)
    _check_finite(X, "features X")
    if classification:
        from sklearn.utils.multiclass import check_classification_targets

        try:
            check_classification_targets(y)
        except ValueError as exc:
            raise TableError(f"{name}: {exc} (class labels must be names or integers)") from None
    else:
        y = np.ascontiguousarray(y, dtype=float)
        _check_finite(y, "target y")
    require_rows(estimator, X.shape[0], min_rows)
    return X, y


def require_rows(estimator: Any, n_samples: int, min_rows: int) -> None:
    """:class:`TableError` unless ``n_samples >= min_rows``."""
    if n_samples < min_rows:
        raise TableError(
            f"{type(estimator).__name__} needs at least {min_rows} training rows; "
            f"got n_samples={n_samples} (add trials)"
        )


def mean_and_scale(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Column means and standard deviations (1 for a constant column) for standardising."""
    mean = values.mean(axis=0)
    scale = values.std(axis=0)
    # a constant column carries no information; keep it finite instead of dividing by zero
    return mean, np.where(scale > 0, scale, 1.0)
