"""Experiment 4: olive oil, corn oil and mirin, estimated by the sugar-water models.

The paper's MAE (GPR trained on sugar water) per liquid is
:data:`.paper.OTHER_LIQUIDS_MAE`.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pandas as pd

from liquidtouch.experiments.common import (
    AXIS_LABELS,
    X,
    diagonal,
    mae,
    pyplot,
    save_figure,
    usable,
)
from liquidtouch.experiments.paper import OTHER_LIQUIDS_MAE, UNITS
from liquidtouch.experiments.report import ExperimentResult, Headline

_H, _MU = "height_mm", "log10_viscosity_cst"


def _mae_bars(ax, rows: list[dict], ours: str, paper: str, unit: str, title: str) -> None:
    """MAE per liquid: ours next to the paper's."""
    x = np.arange(len(rows))
    ax.bar(x - 0.2, [r[ours] for r in rows], 0.4, color="tab:blue", label="ours (simulated)")
    ax.bar(
        x + 0.2, [r[paper] for r in rows], 0.4, color="0.75", hatch="//", edgecolor="0.4",
        label="paper",
    )  # fmt: skip
    ax.set_xticks(x, [r["liquid"] for r in rows])
    ax.set_ylabel(f"MAE [{unit}]")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7)


def run(sugar_model, table: pd.DataFrame, out_dir: Path) -> ExperimentResult:
    """Apply the sugar-trained GPR to the other liquids' trials."""
    start = time.perf_counter()
    table = usable(table)
    rows, headlines = [], []
    plt = pyplot()
    fig, axes = plt.subplots(2, 2, figsize=(11, 7.6))
    for liquid, part in table.groupby("liquid", sort=False):
        predictions = sugar_model.predict(X(part))
        h, mu = predictions[_H][0], predictions[_MU][0]
        paper = OTHER_LIQUIDS_MAE.get(liquid, {})
        row = {
            "liquid": liquid,
            "n": len(part),
            "h MAE [mm]": mae(h, part[_H]),
            "paper h MAE [mm]": paper[_H].value if _H in paper else np.nan,
            "μ MAE [log10 cSt]": mae(mu, part[_MU]),
            "paper μ MAE [log10 cSt]": paper[_MU].value if _MU in paper else np.nan,
            "true μ [log10 cSt]": float(part[_MU].mean()),
        }
        rows.append(row)
        headlines += [
            Headline.vs("other liquids", f"{liquid} h MAE", row["h MAE [mm]"], paper.get(_H), "mm"),
            Headline.vs(
                "other liquids", f"{liquid} μ MAE", row["μ MAE [log10 cSt]"], paper.get(_MU),
                UNITS[_MU],
            ),
        ]  # fmt: skip
        axes[0, 0].scatter(part[_H], h, s=12, label=liquid)
        colour = axes[0, 0].collections[-1].get_facecolor()[0]
        axes[0, 1].scatter(part[_H], mu, s=12, color=colour, label=liquid)
        axes[0, 1].axhline(row["true μ [log10 cSt]"], lw=0.9, ls="--", color=colour)
    if len(table):
        lo, hi = float(table[_H].min()) - 1, float(table[_H].max()) + 1
        diagonal(axes[0, 0], lo, hi)
    axes[0, 0].set_xlabel(f"true {AXIS_LABELS[_H]}")
    axes[0, 0].set_ylabel(f"predicted {AXIS_LABELS[_H]}")
    axes[0, 0].set_title("fill height (dashed: y = x)", fontsize=9)
    axes[0, 1].set_xlabel(f"true {AXIS_LABELS[_H]}")
    axes[0, 1].set_ylabel(f"predicted {AXIS_LABELS[_MU]}")
    axes[0, 1].set_title("viscosity (dashed: each liquid's true μ)", fontsize=9)
    if rows:
        axes[0, 0].legend(fontsize=8)
        source = next(iter(OTHER_LIQUIDS_MAE.values()))[_H].source.split(" (")[0]
        _mae_bars(axes[1, 0], rows, "h MAE [mm]", "paper h MAE [mm]", "mm", "h MAE per liquid")
        _mae_bars(
            axes[1, 1], rows, "μ MAE [log10 cSt]", "paper μ MAE [log10 cSt]", "log10 cSt",
            "μ MAE per liquid",
        )  # fmt: skip
        fig.suptitle(
            f"Other liquids, estimated by the sugar-water GPR (paper: {source})", fontsize=10
        )
    return ExperimentResult(
        "other_liquids",
        "4. Olive oil, corn oil, mirin with the sugar-water models",
        "The GPR trained on sugar water (experiment 3) predicts fill height and viscosity of "
        "liquids it never saw.",
        [("MAE per liquid", pd.DataFrame(rows))],
        [save_figure(fig, out_dir / "other_liquids.png")],
        headlines,
        time.perf_counter() - start,
    )
