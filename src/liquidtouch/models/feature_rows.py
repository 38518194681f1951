"""Rows of a feature table whose extraction failed, for the commands that read such tables.

``liquidtouch features`` keeps a failed trial as a row with empty features and its
message in the ``error`` column. ``train``, ``classify`` and ``transfer`` skip those
rows (with a warning), ``predict`` keeps them with empty predictions. In a table
without an ``error`` column an empty feature is bad input, refused as before by
:func:`liquidtouch.io.tables.feature_matrix`.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from liquidtouch.errors import TableError
from liquidtouch.io.tables import FEATURE_COLUMNS

ERROR_COLUMN = "error"


def row_list(mask: np.ndarray, limit: int = 10) -> str:
    """1-based data-row numbers of ``mask`` (as a spreadsheet counts), the first ``limit``."""
    rows = np.flatnonzero(mask) + 1
    shown = ", ".join(str(r) for r in rows[:limit])
    return shown + (f" and {rows.size - limit} more" if rows.size > limit else "")


def error_messages(table: pd.DataFrame) -> pd.Series:
    """The ``error`` column as stripped strings (empty for good rows and missing cells)."""
    return table[ERROR_COLUMN].astype(object).fillna("").astype(str).str.strip()


def failed_rows(table: pd.DataFrame) -> np.ndarray | None:
    """Boolean (n,): the rows whose feature extraction failed; ``None`` without ``error`` column.

    A row failed if its ``error`` is non-empty or a feature cell (``decay_rate``,
    ``angular_frequency``) is empty. Text in a feature cell is not a failure but bad
    input (left to :func:`~liquidtouch.io.tables.feature_matrix` to report).
    """
    if ERROR_COLUMN not in table.columns:
        return None
    failed = (error_messages(table) != "").to_numpy(dtype=bool, copy=True)
    for column in FEATURE_COLUMNS:
        if column in table.columns:
            failed |= table[column].isna().to_numpy(dtype=bool)
    return failed


def drop_failed(table: pd.DataFrame) -> tuple[pd.DataFrame, int]:
    """``table`` without its failed rows, and how many were dropped.

    Raises :class:`TableError` if every row failed. Later messages count rows of
    the reduced table; its ``attrs["source"]`` says so.
    """
    failed = failed_rows(table)
    if failed is None or not failed.any():
        return table, 0
    where = table.attrs.get("source", "table")
    if failed.all():
        first = error_messages(table).iloc[0] or "empty decay_rate or angular_frequency"
        raise TableError(
            f"{where}: the feature extraction of every row failed (first: {first}); nothing to use"
        )
    kept = table[~failed].reset_index(drop=True)
    kept.attrs = {**table.attrs, "source": f"{where} (rows counted without the failed ones)"}
    return kept, int(failed.sum())
