"""Shared pieces of the paper's experiments: feature tables, splits, errors, figures."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from liquidtouch.io.figures import save_figure as io_save_figure
from liquidtouch.io.tables import FEATURE_COLUMNS

#: The regression targets of the paper and their short names in tables, with units:
#: c is g sugar per 100 g water (not a mass fraction), μ is log10 of ν in cSt.
TARGETS = {
    "height_mm": "h [mm]",
    "sugar_concentration": "c [g/100 g water]",
    "log10_viscosity_cst": "μ [log10 cSt]",
}
#: Symbols of the targets (metric names in the summary, whose unit column has the unit).
SYMBOLS = {"height_mm": "h", "sugar_concentration": "c", "log10_viscosity_cst": "μ"}
#: Axis labels of the targets.
AXIS_LABELS = {
    "height_mm": "fill height h [mm]",
    "sugar_concentration": "c [g sugar / 100 g water]",
    "log10_viscosity_cst": "μ = log10 ν [log10 cSt]",
}
#: One colour per container (figures of experiments 5 and 6).
CONTAINER_COLOURS = {
    "grooved-cuboid": "tab:blue",
    "cylinder": "tab:orange",
    "cuboid": "tab:green",
    "glass": "tab:red",
}
PAPER_STYLE = {"color": "k", "marker": "*", "s": 90, "zorder": 5}


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

    Figures use constrained layout unless ``layout`` says otherwise.

    No backend is selected (no global ``matplotlib.use``): the figures need no
    display and a notebook's inline backend stays as it is.
    """
    from types import SimpleNamespace

    from matplotlib.figure import Figure

    def figure(figsize=None, dpi=None, layout="constrained"):
        # constrained layout: a panel's y-label never runs into the panel before it
        return Figure(figsize=figsize, dpi=dpi, layout=layout)

    def subplots(*args, figsize=None, dpi=None, layout="constrained", **kwargs):
        fig = figure(figsize=figsize, dpi=dpi, layout=layout)
        return fig, fig.subplots(*args, **kwargs)

    return SimpleNamespace(subplots=subplots, figure=figure)


def plain_log_axis(ax, axis: str = "y") -> None:
    """Log scale whose tick labels are plain numbers (``20``, ``0.5``), never ``2×10¹``.

    Call it after plotting: a range of less than a decade gets evenly spaced
    round ticks (a log axis would label only one or two of them).
    """
    from matplotlib.ticker import LogFormatter, MaxNLocator, NullFormatter

    class PlainLogFormatter(LogFormatter):
        # LogFormatter picks which ticks get a label; this writes them as plain numbers
        def _num_to_string(self, x, vmin, vmax):
            return f"{x:.6g}"

    getattr(ax, f"set_{axis}scale")("log")
    target = ax.yaxis if axis == "y" else ax.xaxis
    target.set_major_formatter(PlainLogFormatter(labelOnlyBase=False))
    target.set_minor_formatter(PlainLogFormatter(labelOnlyBase=False, minor_thresholds=(2, 0.5)))
    lo, hi = ax.get_ylim() if axis == "y" else ax.get_xlim()
    if 0 < lo < hi < 10 * lo:
        ticks = MaxNLocator(nbins=6, steps=[1, 2, 2.5, 5, 10]).tick_values(lo, hi)
        ticks = [t for t in ticks if lo <= t <= hi]
        if len(ticks) >= 3:
            (ax.set_yticks if axis == "y" else ax.set_xticks)(ticks)
            target.set_minor_formatter(NullFormatter())
            (ax.set_ylim if axis == "y" else ax.set_xlim)(lo, hi)


def diagonal(ax, lo: float, hi: float, band: float | None = None, band_label: str = "") -> None:
    """The y = x line from ``lo`` to ``hi``; with ``band``, shade y = x ± band (a paper MAE)."""
    ax.plot([lo, hi], [lo, hi], "k--", lw=1, label="_nolegend_")
    if band is not None:
        ax.fill_between(
            [lo, hi], [lo - band, hi - band], [lo + band, hi + band],
            color="grey", alpha=0.15, lw=0, label=band_label,
        )  # fmt: skip
