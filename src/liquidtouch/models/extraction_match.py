"""What a model's features were extracted with, and which other features match it.

A features table keeps, per row, the settings its λ and ω were extracted and fitted
with (the ``extraction_settings`` column, :data:`~liquidtouch.io.tables.SETTINGS_COLUMN`:
one JSON object of the source, the low-pass cut-off, the marker count, the sensors and
the fit's options). A model trained on such rows keeps that object (model file
``extraction_settings``, format version 8). Features extracted otherwise, e.g. u(t)
from all markers against a model trained on 16, scatter and bias differently: the
model's calibrated std was measured on the first kind and may not hold for them.
:func:`settings_differences` names what differs, so that ``predict``, ``live`` and
``run-trial`` can say so.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import Any

import numpy as np
import pandas as pd

from liquidtouch.errors import TableError
from liquidtouch.io.tables import SETTINGS_COLUMN

__all__ = ["parse_settings", "row_differences", "settings_differences", "table_settings"]


def parse_settings(text: object, where: str) -> dict[str, Any] | None:
    """The settings object of one cell (``None`` for an empty cell).

    Raises :class:`TableError` for a cell that is not a JSON object.
    """
    if _empty(text):
        return None
    try:
        settings = json.loads(str(text))
    except json.JSONDecodeError:
        settings = None
    if not isinstance(settings, dict):
        raise TableError(f"{where}: `{SETTINGS_COLUMN}` is not a JSON object: {str(text)[:80]!r}")
    return settings


def _empty(text: object) -> bool:
    return text is None or (isinstance(text, float) and np.isnan(text)) or text == ""


def _cells(table: pd.DataFrame) -> tuple[list[str | None], dict[str, dict[str, Any]]]:
    """Each row's cell (``None``: empty, or no such column) and every distinct cell's
    settings, each parsed once (a table's rows mostly share one)."""
    if SETTINGS_COLUMN not in table.columns:
        return [None] * len(table), {}
    cells = [None if _empty(v) else str(v) for v in table[SETTINGS_COLUMN]]
    parsed: dict[str, dict[str, Any]] = {}
    for i, cell in enumerate(cells):
        if cell is not None and cell not in parsed:
            parsed[cell] = parse_settings(cell, f"row {i + 1}")
    return cells, parsed


def row_differences(trained: Mapping[str, Any], table: pd.DataFrame) -> list[list[str]]:
    """Per row of ``table``, how its settings differ from ``trained``
    (:func:`settings_differences`; empty where they match or the row has none)."""
    cells, parsed = _cells(table)
    differ = {cell: settings_differences(trained, used) for cell, used in parsed.items()}
    return [[] if cell is None else differ[cell] for cell in cells]


def table_settings(table: pd.DataFrame) -> dict[str, Any] | None:
    """The one settings object of the rows of ``table`` (a training table's); ``None``
    when no row has one.

    Raises :class:`TableError` when rows were extracted with different settings: a model
    of such rows would hold no one way to extract the features it is given.
    """
    found = list(_cells(table)[1].values())
    if not found:
        return None
    first = found[0]
    for other in found[1:]:
        differ = settings_differences(first, other)
        if differ:
            raise TableError(
                f"the training rows were extracted with different settings ({differ[0]}); "
                "extract them all with one set of options (`liquidtouch features`)"
            )
    return first


def settings_differences(
    trained: Mapping[str, Any], used: Mapping[str, Any], prefix: str = ""
) -> list[str]:
    """``"name: trained -> used"`` for each setting both hold with different values.

    Nested objects (the fit's options) are compared setting by setting (``fit.model``).
    A setting only one side holds is not compared: a newer liquidtouch may add one, at
    its default, to the features it writes.
    """
    differ = []
    for name in sorted(set(trained) & set(used)):
        a, b = trained[name], used[name]
        if isinstance(a, Mapping) and isinstance(b, Mapping):
            differ += settings_differences(a, b, f"{prefix}{name}.")
        elif not _same(a, b):
            differ.append(f"{prefix}{name}: {_show(a)} -> {_show(b)}")
    return differ


def _same(a: object, b: object) -> bool:
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return float(a) == float(b)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    return a == b


def _show(value: object) -> str:
    return json.dumps(value, separators=(",", ":"))
