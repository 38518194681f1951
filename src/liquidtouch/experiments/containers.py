"""Experiment 5: other containers (cylinder, cuboid, glass), each trained on its own data.

The paper's GPR test MAE per container and target is :data:`.paper.CONTAINERS_TEST_MAE`.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pandas as pd

from liquidtouch.experiments.common import (
    AXIS_LABELS,
    CONTAINER_COLOURS,
    SYMBOLS,
    TARGETS,
    X,
    diagonal,
    pyplot,
    save_figure,
    split,
    usable,
)
from liquidtouch.experiments.paper import CONTAINERS_TEST_MAE, UNITS
from liquidtouch.experiments.report import ExperimentResult, Headline
from liquidtouch.experiments.sugar import errors, train_models


def _figure(predicted: dict[str, tuple[pd.DataFrame, dict]], rows: list[dict], path: Path) -> Path:
    """Top: GPR predicted vs true per target, one colour per container. Bottom: MAE vs paper."""
    plt = pyplot()
    fig, axes = plt.subplots(2, 3, figsize=(13, 7.6), height_ratios=(1.25, 1))
    for k, target in enumerate(TARGETS):
        ax = axes[0, k]
        lo, hi = np.inf, -np.inf
        for container, (test, prediction) in predicted.items():
            mean = prediction[target][0]
            colour = CONTAINER_COLOURS.get(container)
            ax.scatter(test[target], mean, s=12, alpha=0.75, color=colour, label=container)
            lo = min(lo, float(test[target].min()), float(mean.min()))
            hi = max(hi, float(test[target].max()), float(mean.max()))
        if np.isfinite(lo):
            diagonal(ax, lo, hi)
        ax.set_xlabel(f"true {AXIS_LABELS[target]}")
        ax.set_ylabel(f"GPR predicted {AXIS_LABELS[target]}")
        if k == 0 and predicted:
            ax.legend(fontsize=8, title="test trials", title_fontsize=8)
        bars = axes[1, k]
        x = np.arange(len(rows))
        bars.bar(
            x - 0.2, [r[TARGETS[target]] for r in rows], 0.4,
            color=[CONTAINER_COLOURS.get(r["container"], "tab:blue") for r in rows],
            label="ours (simulated)",
        )  # fmt: skip
        bars.bar(
            x + 0.2, [r[f"paper {TARGETS[target]}"] for r in rows], 0.4, color="0.8",
            hatch="//", edgecolor="0.4", label="paper",
        )  # fmt: skip
        bars.set_xticks(x, [r["container"] for r in rows])
        bars.set_ylabel(f"test MAE {SYMBOLS[target]} [{UNITS[target]}]")
        bars.legend(fontsize=7)
    source = CONTAINERS_TEST_MAE["cylinder"]["height_mm"].source.split(" (")[0]
    fig.suptitle(
        "Sugar water in other containers, a GPR per container: predicted vs true (dashed: "
        f"y = x) and test MAE vs the paper's ({source})",
        fontsize=10,
    )
    return save_figure(fig, path)


def run(table: pd.DataFrame, out_dir: Path) -> ExperimentResult:
    """Train and test a GPR per container."""
    start = time.perf_counter()
    table = usable(table)
    rows, headlines = [], []
    predicted: dict[str, tuple[pd.DataFrame, dict]] = {}
    for container, part in table.groupby("container", sort=False):
        train, test = split(part, "train"), split(part, "test")
        if len(train) < 6 or len(test) == 0:
            continue
        model = train_models(train, "gpr")
        err = errors(model, test)
        predicted[str(container)] = (test, model.predict(X(test)))
        paper = CONTAINERS_TEST_MAE.get(container, {})
        rows.append(
            {"container": container, "n train": len(train), "n test": len(test)}
            | {TARGETS[t]: err[t] for t in TARGETS}
            | {f"paper {TARGETS[t]}": paper[t].value if t in paper else np.nan for t in TARGETS}
        )
        headlines += [
            Headline.vs(
                "containers", f"{container} MAE {SYMBOLS[t]}", err[t], paper.get(t), UNITS[t]
            )
            for t in TARGETS
        ]
    return ExperimentResult(
        "containers",
        "5. Other containers",
        "Sugar water in a cylinder on its side, a plain cuboid and a heavy glass container; "
        "a GPR trained and tested on each container's own trials.",
        [("Test MAE per container", pd.DataFrame(rows))],
        [_figure(predicted, rows, out_dir / "containers.png")],
        headlines,
        time.perf_counter() - start,
    )
