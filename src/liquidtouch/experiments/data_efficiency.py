"""Experiment 6: how many training points does the GPR need? (c MAE vs training size)."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pandas as pd

from liquidtouch.experiments.common import X, mae, pyplot, save_figure, split, usable
from liquidtouch.experiments.report import ExperimentResult
from liquidtouch.experiments.sugar import train_models

SIZES = (10, 20, 40, 60, 80, 100)
REPEATS = 3


def curve(
    train: pd.DataFrame, test: pd.DataFrame, target: str, kind: str = "gpr", seed: int = 0
) -> list[dict]:
    """MAE of ``target`` on ``test`` for random training subsets of each size in :data:`SIZES`."""
    rng = np.random.default_rng(seed)
    rows = []
    for n in SIZES:
        if n > len(train):
            break
        scores = []
        for _ in range(REPEATS):
            subset = train.iloc[rng.choice(len(train), n, replace=False)]
            model = train_models(subset, kind, targets=(target,))
            scores.append(mae(model.predict(X(test))[target][0], test[target]))
        rows.append({"n train": n, "model": kind, f"MAE {target}": float(np.mean(scores))})
    return rows


def run(tables: dict[str, pd.DataFrame], out_dir: Path) -> ExperimentResult:
    """``tables`` maps container name → that container's sugar-water features."""
    start = time.perf_counter()
    target = "sugar_concentration"
    rows = []
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for container, table in tables.items():
        table = usable(table)
        train, test = split(table, "train"), split(table, "test")
        if len(test) == 0:
            continue
        for kind in ("gpr", "physics-gpr"):
            part = [r | {"container": container} for r in curve(train, test, target, kind)]
            rows += part
            if part:
                ax.plot(
                    [r["n train"] for r in part],
                    [r[f"MAE {target}"] for r in part],
                    "o-" if kind == "gpr" else "s--",
                    label=f"{container} ({kind})",
                )
    ax.set_xlabel("training points")
    ax.set_ylabel("test MAE of c [g / 100 g water]")
    ax.set_title("Data efficiency")
    if rows:  # no container had the 10 training trials of the first point
        ax.legend(fontsize=7)
    table = pd.DataFrame(rows)
    return ExperimentResult(
        "data_efficiency",
        "6. Data efficiency",
        f"Test MAE of the sugar concentration vs the number of training points (random subsets, "
        f"mean of {REPEATS}), per container, for the plain GPR and our physics-informed GPR.",
        [("c MAE vs training points", table)],
        [save_figure(fig, out_dir / "data_efficiency.png")],
        [],
        time.perf_counter() - start,
    )
