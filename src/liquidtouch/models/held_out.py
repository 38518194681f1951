"""Training on chosen rows of a feature table and scoring the model on the rest.

``train``, ``classify`` and ``transfer`` fit on the rows chosen by ``--split NAME``
(the ``split`` column) and ``--where COLUMN=VALUE`` (all must hold; all rows by
default): :func:`split_rows`. The labelled rows not chosen are then scored:
:func:`regression_errors` (mean absolute error per target, in the target's unit)
and :func:`classification_accuracy` (fraction of rows classified right, 0-1).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd

from liquidtouch.errors import TableError
from liquidtouch.io.tables import feature_matrix

MAX_LISTED_VALUES = 10  # values of a column quoted in an error message


def _listed(values: Any) -> str:
    shown = [str(v) for v in list(values)[:MAX_LISTED_VALUES]]
    more = len(values) - len(shown)
    return ", ".join(shown) + (f" and {more} more" if more > 0 else "")


def column_equals(
    table: pd.DataFrame, column: str, value: str, flag: str, path: str | os.PathLike[str]
) -> np.ndarray:
    """Boolean mask of ``table[column] == value``: numeric for a numeric column, else text.

    ``flag`` (the parameter and its value, e.g. ```split` train``) and ``path`` name the
    selection and the table in the :class:`TableError`
    raised for a missing column, a non-number for a numeric column, or no match.
    """
    if column not in table.columns:
        raise TableError(
            f"{flag}: {path} has no column {column!r} (columns: {_listed(table.columns)})"
        )
    cells = table[column]
    if pd.api.types.is_numeric_dtype(cells) and not pd.api.types.is_bool_dtype(cells):
        try:
            number = float(value)
        except ValueError:
            raise TableError(
                f"{flag}: column {column} of {path} is numeric, but {value!r} is not a number"
            ) from None
        values = cells.to_numpy(dtype=float)
        mask = np.isclose(values, number, rtol=1e-9, atol=0.0) | (values == number)
        shown = np.unique(values[np.isfinite(values)])
        shown = [f"{v:g}" for v in shown]
    else:
        text = cells.astype(str).str.strip()
        mask = (text == value.strip()).to_numpy() & cells.notna().to_numpy()
        shown = sorted(set(text[cells.notna()]))
    if not mask.any():
        raise TableError(
            f"{flag}: no row of {path} has {column} = {value} ({column} values: {_listed(shown)})"
        )
    return mask


def select_rows(
    table: pd.DataFrame,
    split: str | None,
    where: Sequence[str] | None,
    path: str | os.PathLike[str],
) -> np.ndarray | None:
    """The rows chosen by ``split``/``where`` (boolean mask; None without either)."""
    if split is None and not where:
        return None
    mask = np.ones(len(table), dtype=bool)
    if split is not None:
        mask &= column_equals(table, "split", split, f"`split` {split}", path)
    for condition in where or []:
        column, sep, value = condition.partition("=")
        if not sep or not column.strip():
            raise TableError(f"`where` takes COLUMN=VALUE (e.g. split=train), got {condition!r}")
        mask &= column_equals(table, column.strip(), value, f"`where` {condition}", path)
    if not mask.any():
        chosen = " ".join(
            ([f"`split` {split}"] if split is not None else [])
            + [f"`where` {w}" for w in where or []]
        )
        raise TableError(f"no row of {path} matches {chosen} (each alone matches some rows)")
    return mask


def split_rows(
    table: pd.DataFrame,
    X: np.ndarray,
    split: str | None,
    where: Sequence[str] | None,
    path: str | os.PathLike[str],
) -> tuple[pd.DataFrame, np.ndarray, pd.DataFrame | None, np.ndarray | None]:
    """``(chosen rows, their (n, 2) features, the other rows, the mask)`` of ``table``.

    Without ``split`` and ``where`` every row is chosen; the other rows and the
    mask are then None (:func:`select_rows`).
    """
    chosen = select_rows(table, split, where, path)
    if chosen is None:
        return table, X, None, None
    return table[chosen], X[chosen], table[~chosen], chosen


def selection_summary(
    mask: np.ndarray | None, split: str | None, where: Sequence[str] | None
) -> dict[str, object] | None:
    """JSON-ready ``split``, ``where`` and the counts of chosen rows (None: no selection)."""
    if mask is None:
        return None
    return {
        "split": split,
        "where": list(where or []),
        "n_selected": int(mask.sum()),
        "n_not_selected": int((~mask).sum()),
    }


def labelled_rows(table: pd.DataFrame, column: str) -> np.ndarray:
    """Mask of rows with a usable label in ``column`` (finite number, or non-empty text)."""
    if column not in table.columns:
        return np.zeros(len(table), dtype=bool)
    cells = table[column]
    if pd.api.types.is_numeric_dtype(cells):
        return np.isfinite(cells.to_numpy(dtype=float))
    return (cells.notna() & (cells.astype(str).str.strip() != "")).to_numpy()


def regression_errors(
    fitted: Any, rest: pd.DataFrame, targets: Sequence[str]
) -> dict[str, dict[str, float | int]]:
    """Per target with labelled rows in ``rest``: ``{"n_rows", "mae"}`` of ``fitted``.

    ``fitted`` is a regression :class:`~liquidtouch.models.property_model.PropertyModel`;
    the MAE is in the target's unit (e.g. mm for ``height_mm``).
    """
    out: dict[str, dict[str, float | int]] = {}
    for target in targets:
        rows = rest[labelled_rows(rest, target)]
        if rows.empty:
            continue
        truth = pd.to_numeric(rows[target], errors="coerce").to_numpy(dtype=float)
        mean, _ = fitted.predict(feature_matrix(rows))[target]
        out[target] = {"n_rows": len(rows), "mae": float(np.mean(np.abs(mean - truth)))}
    return out


def classification_accuracy(
    fitted: Any, rest: pd.DataFrame, label: str
) -> dict[str, float | int | None]:
    """``{"n_rows", "accuracy"}`` (0-1; None without labelled rows) of ``fitted`` on ``rest``."""
    rows = rest[labelled_rows(rest, label)]
    result: dict[str, float | int | None] = {"n_rows": len(rows), "accuracy": None}
    if len(rows):
        predicted, _ = fitted.predict_proba(feature_matrix(rows))
        truth = rows[label].astype(str).str.strip().to_numpy()
        result["accuracy"] = float(np.mean(predicted == truth))
    return result
