"""Experiment 2: the same classification from the wrist force-torque sensor.

Paper: GelSight 100 % vs wrist F/T 34.3 %. Both feature tables come from the
same simulated trials (``classification`` dataset): the GelSight videos and the
trial's ``wrench.csv``.
"""

from __future__ import annotations

import time
from pathlib import Path

import pandas as pd

from liquidtouch.experiments.classification import classify, decision_figure
from liquidtouch.experiments.common import split, usable
from liquidtouch.experiments.report import ExperimentResult, Headline

PAPER = {"GelSight": 100.0, "wrist F/T": 34.3}


def run(gelsight: pd.DataFrame, wrench: pd.DataFrame, out_dir: Path) -> ExperimentResult:
    """Compare test accuracy from the GelSight and the wrist F/T features."""
    start = time.perf_counter()
    rows, figures = [], []
    for name, table in (("GelSight", gelsight), ("wrist F/T", wrench)):
        n_train = len(usable(split(table, "train")))
        if n_train < 6:
            # too few trials with features to train on: the robot gets no answer on any
            # test trial, so none counts as correct (chance would be one in three)
            accuracy, n_failed, model = 0.0, len(split(table, "test")), None
        else:
            model, predicted, accuracy, n_failed = classify(table)
        rows.append(
            {
                "sensor": name,
                "test accuracy [%]": 100 * accuracy,
                "paper [%]": PAPER[name],
                "trials without features": n_failed,
                "usable training trials": n_train,
            }
        )
        if name == "wrist F/T" and model is not None:
            train = usable(split(table, "train"))
            figures.append(
                decision_figure(
                    model,
                    train,
                    predicted,
                    out_dir / "force_torque.png",
                    "SVM decision regions (wrist F/T)",
                )
            )
    result = pd.DataFrame(rows)
    ft = result.iloc[1]
    return ExperimentResult(
        key="force_torque",
        title="2. GelSight vs wrist force-torque sensor",
        summary=(
            "The same trials, classified from the GelSight markers and from the wrist F/T signal "
            "(its noise is far above the slosh force). A trial whose signal shows no oscillation "
            f"above the noise counts as misclassified. Wrist F/T: {ft['test accuracy [%]']:.1f} % "
            f"({ft['trials without features']} test trials without features)."
        ),
        tables=[("Test accuracy by sensor", result)],
        figures=figures,
        headlines=[
            Headline(
                "force-torque",
                f"{r['sensor']} accuracy",
                r["test accuracy [%]"],
                r["paper [%]"],
                "%",
            )
            for r in rows
        ],
        seconds=time.perf_counter() - start,
    )
