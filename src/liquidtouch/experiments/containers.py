"""Experiment 5: other containers (cylinder, cuboid, glass), each trained on its own data.

Paper (GPR test MAE): h 0.84 / 1.96 / 0.91 mm; c 13.5 / 20.4 / 12.9 wt%;
μ 0.15 / 0.23 / 0.14 for cylinder / cuboid / glass.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pandas as pd

from liquidtouch.experiments.common import TARGETS, pyplot, save_figure, split, usable
from liquidtouch.experiments.report import ExperimentResult, Headline
from liquidtouch.experiments.sugar import errors, train_models

PAPER = {
    "cylinder": {"height_mm": 0.84, "sugar_concentration": 13.5, "log10_viscosity_cst": 0.15},
    "cuboid": {"height_mm": 1.96, "sugar_concentration": 20.4, "log10_viscosity_cst": 0.23},
    "glass": {"height_mm": 0.91, "sugar_concentration": 12.9, "log10_viscosity_cst": 0.14},
}


def run(table: pd.DataFrame, out_dir: Path) -> ExperimentResult:
    """Train and test a GPR per container."""
    start = time.perf_counter()
    table = usable(table)
    rows, headlines = [], []
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for container, part in table.groupby("container", sort=False):
        train, test = split(part, "train"), split(part, "test")
        if len(train) < 6 or len(test) == 0:
            continue
        err = errors(train_models(train, "gpr"), test)
        paper = PAPER.get(container, {})
        rows.append(
            {"container": container, "n train": len(train), "n test": len(test)}
            | {TARGETS[t]: err[t] for t in TARGETS}
            | {f"paper {TARGETS[t]}": paper.get(t, np.nan) for t in TARGETS}
        )
        headlines += [
            Headline("containers", f"{container} MAE {TARGETS[t]}", err[t], paper.get(t))
            for t in TARGETS
        ]
        ax.scatter(part["decay_rate"], part["angular_frequency"], s=8, label=container)
    ax.set_xlabel("decay rate λ [1/s]")
    ax.set_ylabel("angular frequency ω [rad/s]")
    ax.set_title("Sugar water in other containers: features")
    ax.legend()
    return ExperimentResult(
        "containers",
        "5. Other containers",
        "Sugar water in a cylinder on its side, a plain cuboid and a heavy glass container; "
        "a GPR trained and tested on each container's own trials.",
        [("Test MAE per container", pd.DataFrame(rows))],
        [save_figure(fig, out_dir / "containers.png")],
        headlines,
        time.perf_counter() - start,
    )
