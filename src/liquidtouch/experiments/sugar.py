"""Experiment 3: sugar water — fill height, sugar concentration and viscosity.

GPR and the 6-parameter quadratic model from (λ, ω); MAE on train and test,
against the paper's test MAE (:data:`.paper.SUGAR_TEST_MAE`).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pandas as pd

from liquidtouch.experiments.common import (
    AXIS_LABELS,
    SYMBOLS,
    TARGETS,
    X,
    diagonal,
    mae,
    pyplot,
    save_figure,
    split,
    usable,
)
from liquidtouch.experiments.paper import SUGAR_TEST_MAE, UNITS
from liquidtouch.experiments.report import ExperimentResult, Headline
from liquidtouch.models.property_model import MODEL_KINDS, PropertyModel
from liquidtouch.models.training import train_regression


def train_models(train: pd.DataFrame, kind: str, targets=tuple(TARGETS)):
    """One model of ``kind`` (gpr, quadratic, physics-gpr) for ``targets`` on ``train``."""

    return train_regression(X(train), {t: train[t].to_numpy(float) for t in targets}, model=kind)


def errors(model, table: pd.DataFrame) -> dict[str, float]:
    """MAE of each of the model's targets on ``table``."""
    predictions = model.predict(X(table))
    return {t: mae(mean, table[t]) for t, (mean, _) in predictions.items()}


def run(
    table: pd.DataFrame, out_dir: Path, kinds: tuple[str, ...] | None = None
) -> tuple[ExperimentResult, PropertyModel]:
    """Experiment 3; also returns the sugar-trained GPR (experiments 4 and 7 reuse it).

    ``kinds``: the regressor kinds to compare (default: all of ``MODEL_KINDS``).
    """

    kinds = MODEL_KINDS if kinds is None else kinds
    start = time.perf_counter()
    train, test = usable(split(table, "train")), usable(split(table, "test"))
    rows, models = [], {}
    for kind in kinds:
        models[kind] = train_models(train, kind)
        for name, part in (("train", train), ("test", test)):
            err = errors(models[kind], part)
            paper = SUGAR_TEST_MAE.get(kind, {}) if name == "test" else {}
            rows.append(
                {"model": kind, "split": name, "n": len(part)}
                | {TARGETS[t]: err[t] for t in TARGETS}
                | {f"paper {TARGETS[t]}": paper[t].value if t in paper else np.nan for t in TARGETS}
            )
    result = pd.DataFrame(rows)
    plt = pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.4))
    predictions = models["gpr"].predict(X(test))
    for ax, target in zip(axes, TARGETS, strict=True):
        mean, std = predictions[target]
        ours = mae(mean, test[target])
        ax.errorbar(
            test[target], mean, yerr=std, fmt="o", ms=3, alpha=0.6, elinewidth=0.6,
            label=f"ours: MAE {ours:.3g} {UNITS[target]}",
        )  # fmt: skip
        lo = min(test[target].min(), mean.min())
        hi = max(test[target].max(), mean.max())
        paper = SUGAR_TEST_MAE["gpr"][target]
        diagonal(ax, lo, hi, paper.value, f"± paper MAE {paper.value:g} {paper.unit}")
        ax.set_xlabel(f"true {AXIS_LABELS[target]}")
        ax.set_ylabel(f"GPR predicted {AXIS_LABELS[target]}")
        ax.legend(fontsize=7, loc="upper left")
    fig.suptitle(
        "Sugar water, test trials: GPR prediction ± std; grey band: y = x ± the paper's GPR "
        f"test MAE ({SUGAR_TEST_MAE['gpr']['height_mm'].source})",
        fontsize=10,
    )
    figure = save_figure(fig, out_dir / "sugar.png")
    test_rows = result[result["split"] == "test"].set_index("model")
    headlines = [
        Headline.vs(
            "sugar",
            f"{kind} test MAE {SYMBOLS[t]}",
            float(test_rows.loc[kind, TARGETS[t]]),
            SUGAR_TEST_MAE.get(kind, {}).get(t),
            UNITS[t],
            note="" if kind in SUGAR_TEST_MAE else "ours (physics-informed GPR), not in the paper",
        )
        for kind in (*SUGAR_TEST_MAE, "physics-gpr")
        if kind in test_rows.index
        for t in TARGETS
    ]
    summary = (
        f"Sugar water in the grooved cuboid: {len(train)} training and {len(test)} test trials "
        "through the whole pipeline (videos → markers → signal → fit → models). "
        "`physics-gpr` is our physics-informed GPR (not in the paper)."
    )
    return (
        ExperimentResult(
            "sugar",
            "3. Sugar water: height, concentration, viscosity",
            summary,
            [("MAE on train and test", result)],
            [figure],
            headlines,
            time.perf_counter() - start,
        ),
        models["gpr"],
    )
