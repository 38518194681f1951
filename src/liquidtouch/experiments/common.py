"""Shared pieces of the paper's experiments: feature tables, splits, errors, figures."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from liquidtouch.io.figures import save_figure as io_save_figure
from liquidtouch.io.tables import FEATURE_COLUMNS

#: The regression targets of the paper and their short names in tables.
TARGETS = {"height_mm": "h [mm]", "sugar_concentration": "c [wt%]", "log10_viscosity_cst": "μ"}


def usable(table: pd.DataFrame) -> pd.DataFrame:
    """Rows whose feature extraction succeeded (finite λ and ω, no error)."""
    ok = np.isfinite(table[list(FEATURE_COLUMNS)].to_numpy(dtype=float)).all(axis=1)
    if "error" in table.columns:
        ok &= table["error"].fillna("").astype(str).eq("").to_numpy()
    return table[ok].reset_index(drop=True)


def split(table: pd.DataFrame, name: str) -> pd.DataFrame:
    """The ``train`` or ``test`` rows of ``table`` (all rows when it has no ``split``)."""
    if "split" not in table.columns:
        return table
    return table[table["split"] == name].reset_index(drop=True)


def X(table: pd.DataFrame) -> np.ndarray:
    """The (n, 2) feature matrix (λ [1/s], ω [rad/s])."""
    return table[list(FEATURE_COLUMNS)].to_numpy(dtype=float)


def mae(predicted: np.ndarray, truth: np.ndarray) -> float:
    """Mean absolute error (NaN when there is nothing to compare)."""
    predicted, truth = np.asarray(predicted, float), np.asarray(truth, float)
    return float(np.mean(np.abs(predicted - truth))) if len(truth) else float("nan")


def save_figure(fig, path: Path) -> Path:
    """Save an experiment's figure atomically as PNG, margins trimmed."""
    return io_save_figure(fig, path, tight=True)


def pyplot():
    """A stand-in for ``matplotlib.pyplot`` whose ``subplots`` builds a bare ``Figure``.

    No backend is selected (no global ``matplotlib.use``): the figures need no
    display and a notebook's inline backend stays as it is.
    """
    from types import SimpleNamespace

    from matplotlib.figure import Figure

    def subplots(*args, figsize=None, dpi=None, layout=None, **kwargs):
        fig = Figure(figsize=figsize, dpi=dpi, layout=layout)
        return fig, fig.subplots(*args, **kwargs)

    return SimpleNamespace(subplots=subplots)
