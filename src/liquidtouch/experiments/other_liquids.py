"""Experiment 4: olive oil, corn oil and mirin, estimated by the sugar-water models.

Paper (GPR trained on sugar water): h MAE 1.50 / 1.46 / 0.99 mm,
μ MAE 0.12 / 0.12 / 0.35 for olive oil / corn oil / mirin.
"""

from __future__ import annotations

import time
from pathlib import Path

import pandas as pd

from liquidtouch.experiments.common import X, mae, pyplot, save_figure, usable
from liquidtouch.experiments.report import ExperimentResult, Headline

PAPER = {
    "olive-oil": (1.50, 0.12),
    "corn-oil": (1.46, 0.12),
    "mirin": (0.99, 0.35),
}


def run(sugar_model, table: pd.DataFrame, out_dir: Path) -> ExperimentResult:
    """Apply the sugar-trained GPR to the other liquids' trials."""
    start = time.perf_counter()
    table = usable(table)
    rows, headlines = [], []
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    for liquid, part in table.groupby("liquid", sort=False):
        predictions = sugar_model.predict(X(part))
        h, mu = predictions["height_mm"][0], predictions["log10_viscosity_cst"][0]
        paper_h, paper_mu = PAPER.get(liquid, (float("nan"), float("nan")))
        row = {
            "liquid": liquid,
            "n": len(part),
            "h MAE [mm]": mae(h, part["height_mm"]),
            "paper h": paper_h,
            "μ MAE": mae(mu, part["log10_viscosity_cst"]),
            "paper μ": paper_mu,
            "true μ": float(part["log10_viscosity_cst"].mean()),
        }
        rows.append(row)
        headlines += [
            Headline("other liquids", f"{liquid} h MAE", row["h MAE [mm]"], paper_h, "mm"),
            Headline("other liquids", f"{liquid} μ MAE", row["μ MAE"], paper_mu),
        ]
        axes[0].scatter(part["height_mm"], h, s=10, label=liquid)
        axes[1].scatter(part["height_mm"], mu, s=10, label=liquid)
        axes[1].axhline(
            row["true μ"], lw=0.8, ls="--", color=axes[1].collections[-1].get_facecolor()[0]
        )
    axes[0].plot([15, 41], [15, 41], "k--", lw=1)
    axes[0].set_xlabel("true h [mm]")
    axes[0].set_ylabel("predicted h [mm]")
    axes[1].set_xlabel("true h [mm]")
    axes[1].set_ylabel("predicted μ = log10 ν [cSt] (dashed: true)")
    axes[0].legend(fontsize=8)
    fig.suptitle("Other liquids, estimated by the sugar-water GPR")
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
