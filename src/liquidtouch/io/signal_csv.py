"""Read and write signal CSV files (header ``t,u``: time [s], signal in any unit).

CSV readers are bounded (:func:`check_csv_bounds`, also used by
:func:`liquidtouch.io.tables.read_table`): before pandas parses a file, its size
(:data:`MAX_CSV_BYTES`), the length of its header line (:data:`MAX_HEADER_BYTES`)
and its number of columns (:data:`MAX_CSV_COLUMNS`) are checked from the first
bytes alone, so a huge or malformed file is refused in milliseconds instead of
taking minutes and gigabytes; error messages stay short (:func:`shorten`).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from liquidtouch._core import atomic
from liquidtouch._core.checks import MAX_ABS_SIGNAL, check_magnitude, check_times
from liquidtouch.errors import TableError

__all__ = [
    "MAX_CSV_BYTES",
    "MAX_CSV_COLUMNS",
    "MAX_HEADER_BYTES",
    "MAX_MESSAGE_CHARS",
    "check_csv_bounds",
    "list_names",
    "read_signal_csv",
    "shorten",
    "write_signal_csv",
]

#: largest CSV file liquidtouch parses (signal CSV, feature tables) [bytes]; a signal CSV
#: at the fit's limit of samples (``fit.oscillation.MAX_SAMPLES``) takes ~25 MiB
MAX_CSV_BYTES = 64 * 2**20
#: most columns a CSV header may have
MAX_CSV_COLUMNS = 1000
#: longest header line [bytes]
MAX_HEADER_BYTES = 64 * 2**10
#: longest error message built from file content [characters]
MAX_MESSAGE_CHARS = 300


def shorten(text: object, limit: int | None = None) -> str:
    """``str(text)`` cut to ``limit`` characters (with an ellipsis) for error messages.

    Paths (default limit 160) keep their end, the file name: ``…`` + the last
    characters; other text (default limit 80) keeps its start.
    """
    if isinstance(text, os.PathLike):
        text, limit = os.fspath(text), limit or 160
        return text if len(text) <= limit else "…" + text[-(limit - 1) :]
    text, limit = str(text), limit or 80
    return text if len(text) <= limit else text[: limit - 1] + "…"


def list_names(names: object, max_chars: int = 100) -> str:
    """Names, comma-separated, as many as fit in ``max_chars``, then ``and N more``."""
    names = [shorten(n, 40) for n in names]
    shown: list[str] = []
    for name in names:
        if shown and sum(len(n) + 2 for n in shown) + len(name) > max_chars:
            break
        shown.append(name)
    rest = len(names) - len(shown)
    return ", ".join(shown) + (f" and {rest} more" if rest else "")


def check_csv_bounds(
    path: str | os.PathLike[str], what: str, *, max_bytes: int = MAX_CSV_BYTES
) -> None:
    """Raise :class:`TableError` if ``path`` is too large or its header too long or too wide.

    Reads at most :data:`MAX_HEADER_BYTES` bytes; leading blank lines are skipped
    as pandas does. ``what`` names the file in the message ("signal CSV").
    """
    path = Path(path)
    size = path.stat().st_size
    if size > max_bytes:
        raise TableError(
            f"{shorten(path)} is {size / 2**20:.1f} MiB, more than the {max_bytes / 2**20:g} MiB "
            f"a {what} may have; split it or resample it to fewer rows"
        )
    head = b""
    with path.open("rb") as handle:  # the first MAX_HEADER_BYTES + 1 after blank lines
        while len(head) <= MAX_HEADER_BYTES:
            chunk = handle.read(MAX_HEADER_BYTES + 1 - len(head))
            if not chunk:
                break
            head = (head + chunk).lstrip(b" \t\r\n")
    end = head.find(b"\n")
    if end < 0 and len(head) > MAX_HEADER_BYTES:
        raise TableError(
            f"{shorten(path)}: the header line is longer than {MAX_HEADER_BYTES // 1024} KiB; "
            f"not a {what} (one header row of column names, then one row per line)"
        )
    header = head if end < 0 else head[:end]
    columns = header.count(b",") + 1
    if columns > MAX_CSV_COLUMNS:
        raise TableError(
            f"{shorten(path)}: the header has {columns} columns, more than the "
            f"{MAX_CSV_COLUMNS} a {what} may have; is it one header row of column names?"
        )


def read_signal_csv(path: str | os.PathLike[str]) -> tuple[np.ndarray, np.ndarray]:
    """Read a signal CSV with columns ``t`` [s] and ``u``; other columns are ignored.

    Raises
    ------
    FileNotFoundError
        The file does not exist.
    TableError
        Not a file, larger than :data:`MAX_CSV_BYTES`, a header longer than
        :data:`MAX_HEADER_BYTES` or wider than :data:`MAX_CSV_COLUMNS`, no data
        rows, columns ``t`` or ``u`` missing, a non-numeric or empty cell,
        NaN/inf values, ``|u|`` over ``MAX_ABS_SIGNAL`` or times beyond
        ``MAX_ABS_TIME_S`` or closer than ``MIN_TIME_STEP_S`` (``_core.checks``).
    """
    import pandas as pd

    path = Path(path)
    if path.is_dir():
        raise TableError(f"{shorten(path)} is a directory; give a signal CSV file (header 't,u')")
    if not path.is_file():
        raise FileNotFoundError(2, "No such file", str(path))
    check_csv_bounds(path, "signal CSV")
    where = shorten(path)
    try:
        table = pd.read_csv(path, skipinitialspace=True)
    except (pd.errors.EmptyDataError, pd.errors.ParserError, UnicodeDecodeError) as exc:
        raise TableError(
            f"{where}: not a readable CSV table ({shorten(exc, 120)}); expected a header 't,u'"
        ) from None
    table.columns = [str(c).strip() for c in table.columns]
    missing = [c for c in ("t", "u") if c not in table.columns]
    if missing:
        raise TableError(
            f"{where}: missing column(s) {', '.join(missing)} (found "
            f"{list_names(table.columns)}); a signal CSV needs the header 't,u'"
        )
    if len(table) == 0:
        raise TableError(f"{where}: the table has a header but no data rows; record a signal")
    columns = []
    for name in ("t", "u"):
        values = pd.to_numeric(table[name], errors="coerce").to_numpy(dtype=float)
        bad = ~np.isfinite(values)
        if bad.any():
            row = int(np.argmax(bad))
            raise TableError(
                f"{where}: column '{name}' has {int(bad.sum())} empty, non-numeric, NaN or inf "
                f"value(s) (first at data row {row + 1}: "
                f"{shorten(repr(table[name].iloc[row]), 40)})"
            )
        columns.append(values)
    t, u = columns
    check_magnitude(u, f"{where}: column 'u'", MAX_ABS_SIGNAL, "(any unit)")
    order = np.sort(t)
    distinct = order[np.r_[True, np.diff(order) != 0]]  # order and duplicates: the fit says
    check_times(distinct, f"{where}: column 't'", TableError, min_count=1)
    return t, u


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
