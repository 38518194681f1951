"""Read and write signal CSV files (header ``t,u``: time [s], signal in any unit)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from liquidtouch.errors import TableError
from liquidtouch.io import atomic


def read_signal_csv(path: str | os.PathLike[str]) -> tuple[np.ndarray, np.ndarray]:
    """Read a signal CSV with columns ``t`` [s] and ``u``; other columns are ignored.

    Raises
    ------
    FileNotFoundError
        The file does not exist.
    TableError
        Not a file, no data rows, columns ``t`` or ``u`` missing, a non-numeric
        or empty cell, or NaN/inf values.
    """
    import pandas as pd

    path = Path(path)
    if path.is_dir():
        raise TableError(f"{path} is a directory; give a signal CSV file (header 't,u')")
    if not path.is_file():
        raise FileNotFoundError(2, "No such file", str(path))
    try:
        table = pd.read_csv(path, skipinitialspace=True)
    except (pd.errors.EmptyDataError, pd.errors.ParserError, UnicodeDecodeError) as exc:
        raise TableError(
            f"{path}: not a readable CSV table ({exc}); expected a header 't,u'"
        ) from None
    table.columns = [str(c).strip() for c in table.columns]
    missing = [c for c in ("t", "u") if c not in table.columns]
    if missing:
        raise TableError(
            f"{path}: missing column(s) {', '.join(missing)} (found {', '.join(table.columns)}); "
            "a signal CSV needs the header 't,u'"
        )
    if len(table) == 0:
        raise TableError(f"{path}: the table has a header but no data rows; record a signal")
    columns = []
    for name in ("t", "u"):
        values = pd.to_numeric(table[name], errors="coerce").to_numpy(dtype=float)
        bad = ~np.isfinite(values)
        if bad.any():
            row = int(np.argmax(bad))
            raise TableError(
                f"{path}: column '{name}' has {int(bad.sum())} empty, non-numeric, NaN or inf "
                f"value(s) (first at data row {row + 1}: {table[name].iloc[row]!r})"
            )
        columns.append(values)
    return columns[0], columns[1]


def write_signal_csv(path: str | os.PathLike[str], t: np.ndarray, u: np.ndarray) -> None:
    """Atomically write ``t`` [s] and ``u`` as a signal CSV with header ``t,u``.

    Raises :class:`TableError` unless ``t`` and ``u`` are 1-D arrays of one
    length holding finite real numbers (what :func:`read_signal_csv` reads back).
    """
    try:
        t = np.asarray(t, dtype=float)
        u = np.asarray(u, dtype=float)
    except (TypeError, ValueError):
        raise TableError("t and u must be arrays of real numbers") from None
    if t.shape != u.shape or t.ndim != 1:
        raise TableError(f"t and u must be 1-D of equal length (got {t.shape}, {u.shape})")
    for name, values in (("t", t), ("u", u)):
        bad = ~np.isfinite(values)
        if bad.any():
            raise TableError(
                f"{name} holds {int(bad.sum())} NaN/inf value(s) (first at sample "
                f"{int(np.argmax(bad))}); a signal CSV holds finite numbers only"
            )
    lines = ["t,u", *(f"{a:.9g},{b:.9g}" for a, b in zip(t, u, strict=True))]
    atomic.write_text(path, "\n".join(lines) + "\n")
