"""Experiment 6: how many training points does the GPR need? (c MAE vs training size).

The figure marks, per container, the paper's test MAE of c with all training
data (:func:`.paper.full_data_c_mae`).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pandas as pd

from liquidtouch.experiments.common import (
    AXIS_LABELS,
    CONTAINER_COLOURS,
    TARGETS,
    X,
    mae,
    pyplot,
    save_figure,
    split,
    usable,
)
from liquidtouch.experiments.paper import full_data_c_mae
from liquidtouch.experiments.report import ExperimentResult
from liquidtouch.experiments.sugar import train_models

SIZES = (6, 10, 15, 20, 40, 60, 80, 100)
REPEATS = 3
MODELS = {"gpr": "-", "physics-gpr": "--"}  # model kind → line style (colour = container)
MARKERS = {"gpr": "o", "physics-gpr": "s"}


def sizes_for(n_train: int) -> list[int]:
    """The training sizes of :data:`SIZES` up to ``n_train``, plus ``n_train`` itself.

    A small training set (the quick run's) still gets a curve of several points
    ending at all its trials.
    """
    sizes = [n for n in SIZES if n < n_train]
    return [*sizes, n_train] if n_train >= SIZES[0] else sizes


def curve(
    train: pd.DataFrame, test: pd.DataFrame, target: str, kind: str = "gpr", seed: int = 0
) -> list[dict]:
    """MAE of ``target`` on ``test`` for random training subsets of each size of :func:`sizes_for`.

    The full training set is used once (all draws would be the same); smaller
    sizes average :data:`REPEATS` random draws.
    """
    rng = np.random.default_rng(seed)
    rows = []
    for n in sizes_for(len(train)):
        scores = []
        for _ in range(REPEATS if n < len(train) else 1):
            subset = train.iloc[rng.choice(len(train), n, replace=False)]
            model = train_models(subset, kind, targets=(target,))
            scores.append(mae(model.predict(X(test))[target][0], test[target]))
        rows.append({"n train": n, "model": kind, f"MAE {TARGETS[target]}": float(np.mean(scores))})
    return rows


def _label_references(ax, references: list[tuple[float, str | None]]) -> None:
    """Write "paper <value>" right of the axes at each reference line, labels kept apart."""
    if not references:
        return
    lo, hi = ax.get_ylim()
    span = (hi - lo) or 1.0
    placed: list[float] = []
    for value, colour in sorted(references):
        y = (value - lo) / span  # axes fraction
        if placed and y - placed[-1] < 0.04:
            y = placed[-1] + 0.04
        placed.append(y)
        ax.annotate(
            f"paper {value:g}", (1.0, y), xycoords="axes fraction", xytext=(3, 0),
            textcoords="offset points", va="center", fontsize=7, color=colour,
        )  # fmt: skip


def run(tables: dict[str, pd.DataFrame], out_dir: Path, seed: int = 0) -> ExperimentResult:
    """``tables`` maps container name → that container's sugar-water features.

    ``seed``: the random training subsets.
    """
    start = time.perf_counter()
    target = "sugar_concentration"
    rows = []
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(8.4, 5.4))
    references: list[tuple[float, str | None]] = []
    for container, table in tables.items():
        table = usable(table)
        train, test = split(table, "train"), split(table, "test")
        if len(test) == 0:
            continue
        colour = CONTAINER_COLOURS.get(container)
        for kind, style in MODELS.items():
            part = [r | {"container": container} for r in curve(train, test, target, kind, seed)]
            rows += part
            if part:
                ax.plot(
                    [r["n train"] for r in part],
                    [r[f"MAE {TARGETS[target]}"] for r in part],
                    ls=style,
                    marker=MARKERS[kind],
                    ms=5,
                    color=colour,
                    label=f"{container}, {kind}",
                )
        paper = full_data_c_mae(container)
        if paper is not None and len(train):
            ax.axhline(paper.value, color=colour, ls=":", lw=1.2)
            references.append((paper.value, colour))
    _label_references(ax, references)
    drawn_paper = bool(references)
    ax.set_xlabel("training points")
    ax.set_ylabel(f"test MAE of {AXIS_LABELS[target]}")
    ax.set_title(
        "Data efficiency: colour = container, line style = model"
        + (
            "\ndotted: the paper's GPR test MAE of c with all its training data"
            " (sugar-water and other-containers experiments)"
            if drawn_paper
            else ""
        ),
        fontsize=9,
    )
    if rows:  # no container had the training trials of the first point
        handles, labels = ax.get_legend_handles_labels()
        fig.legend(handles, labels, fontsize=7, ncol=4, loc="outside lower center")
    table = pd.DataFrame(rows)
    return ExperimentResult(
        "data_efficiency",
        "6. Data efficiency",
        f"Test MAE of the sugar concentration c [g/100 g water] vs the number of training points "
        f"(random subsets, mean of {REPEATS} draws; the last point of each curve is the whole "
        "training set), per container, for the plain GPR and our physics-informed GPR. Dotted "
        "lines: the paper's GPR test MAE of c with all its training data.",
        [("c MAE vs training points", table)],
        [save_figure(fig, out_dir / "data_efficiency.png")],
        [],
        time.perf_counter() - start,
    )
