"""Training, classification and container transfer on the selected rows of a features table.

What ``liquidtouch train``, ``classify`` and ``transfer`` compute, callable from a
notebook: the rows chosen by ``split`` / ``where`` (all rows without either;
:mod:`liquidtouch.models.held_out`) are fitted on, and the labelled rows not chosen are
evaluated afterwards (MAE per target, in the target's unit). The table holds
``decay_rate`` [1/s], ``angular_frequency`` [rad/s] and the label columns; rows whose
feature extraction failed are dropped first
(:func:`~liquidtouch.models.feature_rows.drop_failed`).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from liquidtouch.errors import TableError
from liquidtouch.io.tables import feature_matrix, label_column, numeric_column
from liquidtouch.models.conformal import default_groups
from liquidtouch.models.extraction_match import table_settings
from liquidtouch.models.held_out import (
    classification_accuracy,
    regression_errors,
    selection_summary,
    split_rows,
)
from liquidtouch.models.property_model import PropertyModel, feature_std_matrix
from liquidtouch.models.training import train_classifier, train_regression
from liquidtouch.models.transfer import TransferResult, fit_transfer

#: ``calibration_folds`` of :func:`train_on_table` when not given (``train``'s default)
DEFAULT_CALIBRATION_FOLDS = 10


@dataclass
class TableTraining:
    """A model fitted on the chosen rows of a table, and its evaluation on the others.

    ``selection`` is :func:`~liquidtouch.models.held_out.selection_summary`'s (None: every
    row was chosen); ``held_out`` maps each target with labelled rows among the others to
    its errors (``{"n_rows", "mae"}`` after training, ``{"n_rows", "mae_before",
    "mae_after"}`` after a transfer; None: no rows left over); ``n_held_out`` is the
    number of rows not chosen. ``transfer`` is the transfer's result (None after training).
    """

    model: PropertyModel
    n_rows: int
    selection: dict[str, object] | None
    held_out: dict[str, dict[str, float | int]] | dict[str, float | int] | None
    n_held_out: int
    transfer: TransferResult | None = None


def calibration_groups(table: pd.DataFrame, column: str | None) -> np.ndarray | None:
    """The calibration's groups: ``column``'s values (None: the default groups of
    :func:`~liquidtouch.models.conformal.default_groups`; ``"none"``: every row alone).

    Raises :class:`TableError` for a missing column or one with empty values.
    """
    if column is None:
        if "height_mm" in table.columns and table["height_mm"].isna().any():
            raise TableError("`calibration_group` height_mm: the column has empty values")
        return default_groups(table)
    if column.strip().lower() == "none":
        return None
    if column not in table.columns:
        raise TableError(f"`calibration_group` {column!r}: no such column in the training table")
    values = table[column]
    if values.isna().any():
        raise TableError(f"`calibration_group` {column}: the column has empty values")
    return values.astype(str).to_numpy()


def train_on_table(
    table: pd.DataFrame,
    targets: Sequence[str],
    *,
    model: str = "gpr",
    split: str | None = None,
    where: Sequence[str] | None = None,
    calibration_folds: int = DEFAULT_CALIBRATION_FOLDS,
    calibration_group: str | None = None,
    source: str | os.PathLike[str] = "the table",
    progress: Callable[[str], None] | None = None,
) -> TableTraining:
    """Train one regressor of kind ``model`` per target on the chosen rows of ``table``.

    ``table`` holds the features and the ``targets`` columns, its failed rows already
    dropped; ``calibration_folds`` K calibrates each target's std and intervals by K-fold
    cross-conformal (at least 2; 0: no calibration) over ``calibration_group``
    (:func:`calibration_groups`). ``source`` names the table in error messages;
    ``progress(target)`` is called after each target.
    """
    table, X, rest, chosen = split_rows(table, feature_matrix(table), split, where, source)
    columns = {t: numeric_column(table, t) for t in dict.fromkeys(targets)}
    fitted = train_regression(
        X,
        columns,
        model,
        progress,
        calibration_folds=None if calibration_folds == 0 else max(calibration_folds, 2),
        calibration_groups=calibration_groups(table, calibration_group),
        calibration_std=feature_std_matrix(table),
    )
    fitted.extraction_settings = table_settings(table)
    held_out = None if rest is None else regression_errors(fitted, rest, list(columns))
    return TableTraining(
        model=fitted,
        n_rows=int(X.shape[0]),
        selection=selection_summary(chosen, split, where),
        held_out=held_out,
        n_held_out=0 if rest is None else len(rest),
    )


def classify_on_table(
    table: pd.DataFrame,
    label: str = "liquid",
    *,
    split: str | None = None,
    where: Sequence[str] | None = None,
    source: str | os.PathLike[str] = "the table",
) -> TableTraining:
    """Train the liquid classifier on the chosen rows of ``table`` (its ``label`` column).

    ``held_out`` is the accuracy on the labelled rows not chosen (``{"n_rows",
    "accuracy"}``); ``source`` names the table in error messages.
    """
    table, X, rest, chosen = split_rows(table, feature_matrix(table), split, where, source)
    fitted = train_classifier(X, label_column(table, label), label=label)
    fitted.extraction_settings = table_settings(table)
    return TableTraining(
        model=fitted,
        n_rows=int(X.shape[0]),
        selection=selection_summary(chosen, split, where),
        held_out=None if rest is None else classification_accuracy(fitted, rest, label),
        n_held_out=0 if rest is None else len(rest),
    )


def transfer_on_table(
    model: PropertyModel,
    table: pd.DataFrame,
    *,
    split: str | None = None,
    where: Sequence[str] | None = None,
    source: str | os.PathLike[str] = "the table",
) -> TableTraining:
    """Transfer the regression ``model`` (container A) to the container of ``table``'s
    chosen rows: f_B(λ, ω) = f_A(α1 λ + α2, β1 ω + β2)
    (:func:`~liquidtouch.models.transfer.fit_transfer`), on every target of the model
    that ``table`` labels; the rows not chosen are evaluated before and after.

    Raises :class:`TableError` for a classifier or a table without any of the targets.
    """
    table, X, rest, chosen = split_rows(table, feature_matrix(table), split, where, source)
    labelled = [t for t in model.targets if t in table.columns]
    if model.kind != "regression":
        raise TableError("container transfer needs a regression model (train one with `train`)")
    if not labelled:
        raise TableError(
            f"{source}: no column of the model's targets ({', '.join(model.targets)}); "
            "label the tuning trials with at least one of them"
        )
    result = fit_transfer(model, X, {t: numeric_column(table, t) for t in labelled})
    held_out = None
    if rest is not None:
        before = regression_errors(model, rest, labelled)
        after = regression_errors(result.model, rest, labelled)
        held_out = {
            t: {"n_rows": e["n_rows"], "mae_before": before[t]["mae"], "mae_after": e["mae"]}
            for t, e in after.items()
        }
    return TableTraining(
        model=result.model,
        n_rows=int(X.shape[0]),
        selection=selection_summary(chosen, split, where),
        held_out=held_out,
        n_held_out=0 if rest is None else len(rest),
        transfer=result,
    )
