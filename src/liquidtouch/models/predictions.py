"""A model's predictions for a feature table, as ``predict``, ``live`` and a notebook give them.

One definition of what a prediction row says, whoever asks:

- ``predicted_<target>`` and ``predicted_<target>_std`` (regression), or
  ``predicted_<label>`` (a class name, ``"unknown"`` far from every trained class) and
  ``probability_<class>`` (:data:`PROBABILITY_PREFIX`) for a classifier;
- ``out_of_domain`` (:func:`out_of_domain`): (λ, ω) lies outside what the model knows —
  outside its training domain (range plus margin), or a classifier's answer is
  ``"unknown"``;
- ``unknown_rule`` (classifiers, :func:`unknown_rule`): ``"available"``, or
  ``"unavailable, needs N rows per class"`` when the classifier was trained on too few rows
  to ever answer "unknown".

:func:`predict_rows` gives them for a features table: rows whose feature extraction
failed are kept with empty predictions (and their error), the rest predicted, and the
rows extracted with other settings than the model's training features are named
(:mod:`liquidtouch.models.extraction_match`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from liquidtouch.errors import TableError
from liquidtouch.io.tables import feature_matrix
from liquidtouch.models.classifier import UNKNOWN
from liquidtouch.models.conformal import min_rows_for_level
from liquidtouch.models.extraction_match import row_differences
from liquidtouch.models.feature_rows import error_messages, failed_rows

__all__ = [
    "PROBABILITY_PREFIX",
    "Predictions",
    "check_level",
    "out_of_domain",
    "predict_rows",
    "unknown_rule",
]

#: a class's probability column: ``probability_<class>``
PROBABILITY_PREFIX = "probability_"


def unknown_rule(model: object) -> str | None:
    """A classifier's ``unknown_rule`` (module docstring); ``None`` for a regression model."""
    classifier = getattr(model, "classifier", None)
    return None if classifier is None else classifier.unknown_status()


def out_of_domain(model: object, X: np.ndarray, predicted: np.ndarray | None = None) -> np.ndarray:
    """Boolean (n,): the rows of the (n, 2) features ``X`` (λ [1/s], ω [rad/s]) outside what
    ``model`` knows: outside its training domain, or ``predicted`` (a classifier's answers,
    n) is ``"unknown"``."""
    outside = ~np.asarray(model.in_domain(np.asarray(X, dtype=float)), dtype=bool)
    if predicted is not None:
        outside |= np.asarray(predicted, dtype=object) == UNKNOWN
    return outside


def check_level(model: object, level: float | None) -> str | None:
    """Check ``predict --level`` against ``model`` before any feature is extracted.

    :class:`TableError` for a classifier, a level outside (0, 1) or outside what the
    model's calibration resolves, or a model without calibration; returns a warning
    (``None``: none) when no level is asked and the model's std is not calibrated.
    """
    if level is None:
        if model.kind == "regression" and not model.calibrated:
            return (
                "the model's std is not calibrated (an older model file or --calibration-folds "
                "0); retrain it with `liquidtouch train` for a calibrated std and --level"
            )
        return None
    if model.kind != "regression":
        raise TableError("--level needs a regression model (from train), not a classifier")
    need = min_rows_for_level(level)  # refuses a level outside (0, 1), NaN too
    for target in model.targets:
        cal = model.calibration.get(target)
        if cal is None:
            raise TableError(
                f"--level: the model has no interval calibration for {target} (an older "
                f"model file, or --calibration-folds 0); retrain it with `liquidtouch "
                f"train` on at least {need} rows"
            )
        cal.quantile(level)  # refuses a calibration on too few rows, or a level too low
    return None


@dataclass
class Predictions:
    """``predict_rows``'s result: the table with its predicted columns, and per row whether its
    features failed (``failed``, with ``errors``: the reason, "" for a good row) and whether it
    lies out of domain (``outside``: outside the training domain, ``outside_domain``, or
    named unknown by a classifier, ``unknown``). ``other_settings`` marks the rows
    extracted otherwise than the model's training features, ``settings_differences``
    says how (``"n_markers: 16 -> 1000"``; empty when every row matches or either side's
    settings are not known)."""

    table: pd.DataFrame
    failed: np.ndarray
    outside: np.ndarray
    errors: list[str] = field(default_factory=list)
    outside_domain: np.ndarray | None = None
    unknown: np.ndarray | None = None
    other_settings: np.ndarray | None = None
    settings_differences: list[str] = field(default_factory=list)

    def who(self, i: int) -> str:
        """Row ``i`` in words: ``trial <name>``, else ``row <i + 1>``."""
        if "trial" in self.table.columns:
            return f"trial {self.table['trial'].iloc[i]}"
        return f"row {i + 1}"


def predict_rows(model: object, table: pd.DataFrame, level: float | None = None) -> Predictions:
    """Predict every row of a features ``table`` (module docstring: the columns).

    ``level``: a regression model's calibrated interval (``predicted_<target>_lower`` and
    ``_upper``). Rows whose extraction failed keep their ``error`` and get empty predictions;
    :class:`TableError` when no row has features.
    """
    failed = failed_rows(table)
    if failed is None:
        failed = np.zeros(len(table), dtype=bool)
    errors = [""] * len(table)
    if failed.any():
        messages = error_messages(table)
        for i in np.flatnonzero(failed):
            errors[i] = messages.iloc[i] or "empty decay_rate or angular_frequency"
    if failed.all():
        raise TableError(f"no row has features: {errors[0]}" if errors else "the table is empty")
    good = table[~failed]
    predicted = model.predict_table(good, level=level)
    result = table.copy()
    for column in predicted.columns:
        if column not in table.columns or column.startswith(("predicted_", PROBABILITY_PREFIX)):
            result[column] = predicted[column].reindex(table.index)
    answers = None
    if getattr(model, "kind", "") == "classification":
        answers = predicted[f"predicted_{model.targets[0]}"].to_numpy()
    rows = np.flatnonzero(~failed)
    outside_domain = np.zeros(len(table), dtype=bool)
    outside_domain[rows] = out_of_domain(model, feature_matrix(good))
    unknown = np.zeros(len(table), dtype=bool)
    if answers is not None:
        unknown[rows] = np.asarray(answers, dtype=object) == UNKNOWN
    outside = outside_domain | unknown  # out_of_domain (module docstring)
    rule = unknown_rule(model)
    if rule is not None:
        result["unknown_rule"] = rule
    result["out_of_domain"] = outside  # the last column, as it always was
    other, differ = _other_settings(model, table, failed)
    return Predictions(result, failed, outside, errors, outside_domain, unknown, other, differ)


def _other_settings(
    model: object, table: pd.DataFrame, failed: np.ndarray
) -> tuple[np.ndarray, list[str]]:
    """The rows of ``table`` with features (not ``failed``) extracted otherwise than
    ``model``'s training features, and every difference (in order of first appearance)."""
    trained = getattr(model, "extraction_settings", None)
    if trained is None:
        return np.zeros(len(table), dtype=bool), []
    rows = row_differences(trained, table)
    found = [[] if bad else differ for differ, bad in zip(rows, failed, strict=True)]
    other = np.array([bool(differ) for differ in found], dtype=bool)
    return other, list(dict.fromkeys(name for differ in found for name in differ))
