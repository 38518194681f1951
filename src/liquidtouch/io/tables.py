"""Reading and validating feature tables (CSV with ``decay_rate``, ``angular_frequency``, labels).

A feature table has one row per trial: the slow sloshing mode's decay rate
λ [1/s] and angular frequency ω [rad/s], plus label columns such as
``height_mm``, ``sugar_concentration``, ``log10_viscosity_cst`` or ``liquid``
(``docs/formats.md``). Every problem raises :class:`TableError` with the file,
the column and the rows at fault.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd

from liquidtouch.errors import TableError
from liquidtouch.io.signal_csv import check_csv_bounds, shorten

FEATURE_COLUMNS: tuple[str, str] = ("decay_rate", "angular_frequency")
#: The column of the settings a row's features were extracted with (compact JSON).
SETTINGS_COLUMN = "extraction_settings"


def read_table(path: str | os.PathLike[str]) -> pd.DataFrame:
    """Read a CSV file into a DataFrame; raise :class:`TableError` if it is not a table.

    Bounded like every CSV reader (``io.signal_csv.check_csv_bounds``): at most
    ``MAX_CSV_BYTES`` (64 MiB) and ``MAX_CSV_COLUMNS`` (1000) columns, checked
    before parsing.
    """

    path = Path(path)
    if not path.is_file():
        raise TableError(
            f"{shorten(path)}: no such file (give a features CSV, e.g. from `liquidtouch features`)"
        )
    check_csv_bounds(path, "feature table")
    try:
        table = pd.read_csv(path)
    except pd.errors.EmptyDataError:
        raise TableError(
            f"{shorten(path)}: the file is empty; expected a CSV with a header row"
        ) from None
    except (pd.errors.ParserError, UnicodeDecodeError) as exc:
        raise TableError(
            f"{shorten(path)}: not a readable CSV table ({shorten(exc, 120)})"
        ) from None
    if table.empty:
        raise TableError(f"{shorten(path)}: the table has a header but no rows")
    table.attrs["source"] = str(path)
    return table


def _where(table: pd.DataFrame) -> str:
    return table.attrs.get("source", "table")


def _rows(mask: np.ndarray) -> str:
    # 1-based data-row numbers, as a spreadsheet user would count them
    rows = np.flatnonzero(mask) + 1
    shown = ", ".join(str(r) for r in rows[:5])
    return shown + (f" and {rows.size - 5} more" if rows.size > 5 else "")


def require_columns(table: pd.DataFrame, columns: tuple[str, ...] | list[str]) -> None:
    """Raise :class:`TableError` naming every column of ``columns`` that ``table`` lacks."""
    missing = [c for c in columns if c not in table.columns]
    if missing:
        present = ", ".join(map(str, table.columns)) or "none"
        raise TableError(
            f"{_where(table)}: missing column(s) {', '.join(missing)} (columns present: {present})"
        )


def numeric_column(table: pd.DataFrame, name: str) -> np.ndarray:
    """Column ``name`` as floats; :class:`TableError` if missing, non-numeric or NaN."""
    require_columns(table, [name])
    raw = table[name]
    values = pd.to_numeric(raw, errors="coerce").to_numpy(dtype=float)
    bad_text = np.isnan(values) & raw.notna().to_numpy()
    if bad_text.any():
        first = raw.to_numpy()[np.flatnonzero(bad_text)[0]]
        raise TableError(
            f"{_where(table)}: column {name} must be numeric but row(s) {_rows(bad_text)} "
            f"hold text such as {first!r}"
        )
    if not np.isfinite(values).all():
        raise TableError(
            f"{_where(table)}: column {name} has empty, NaN or infinite values in row(s) "
            f"{_rows(~np.isfinite(values))}; drop or fix those rows"
        )
    return values


def label_column(table: pd.DataFrame, name: str) -> np.ndarray:
    """Column ``name`` as an array of class-name strings; raise if missing or empty cells."""
    require_columns(table, [name])
    raw = table[name]
    empty = raw.isna().to_numpy() | (raw.astype(str).str.strip() == "").to_numpy()
    if empty.any():
        raise TableError(
            f"{_where(table)}: column {name} has empty values in row(s) {_rows(empty)}; "
            "every training row needs a label"
        )
    return raw.astype(str).str.strip().to_numpy()


def feature_matrix(table: pd.DataFrame) -> np.ndarray:
    """The (n, 2) array of (decay_rate [1/s], angular_frequency [rad/s]) of ``table``, validated.

    Both columns must be numeric and finite; the decay rate must be >= 0 and the
    angular frequency > 0 (anything else is a failed oscillation fit, not a liquid).
    """
    require_columns(table, FEATURE_COLUMNS)
    decay_rate = numeric_column(table, "decay_rate")
    angular_frequency = numeric_column(table, "angular_frequency")
    if (decay_rate < 0).any():
        raise TableError(
            f"{_where(table)}: decay_rate must be >= 0 but is negative in row(s) "
            f"{_rows(decay_rate < 0)}; check the oscillation fits of those trials"
        )
    if (angular_frequency <= 0).any():
        raise TableError(
            f"{_where(table)}: angular_frequency must be > 0 but is not in row(s) "
            f"{_rows(angular_frequency <= 0)}; check the oscillation fits of those trials"
        )
    return np.column_stack([decay_rate, angular_frequency])


def read_feature_table(path: str | os.PathLike[str]) -> tuple[pd.DataFrame, np.ndarray]:
    """Read a features CSV; return the table and its validated (n, 2) feature matrix."""
    table = read_table(path)
    return table, feature_matrix(table)
