"""Experiment 1: classify water / olive oil / detergent with the SVM on (λ, ω).

The paper's accuracy is :data:`.paper.CLASSIFICATION_ACCURACY`; its figure
shows the decision regions in (λ, ω). Experiment 2 (:mod:`.force_torque`)
reuses :func:`classify` on the wrist signal.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pandas as pd

from liquidtouch.experiments.common import X, pyplot, save_figure, split, usable
from liquidtouch.experiments.paper import CLASSIFICATION_ACCURACY, PaperValue
from liquidtouch.experiments.report import ExperimentResult, Headline
from liquidtouch.models.training import train_classifier


def classify(table: pd.DataFrame) -> tuple[object, pd.DataFrame, float, int]:
    """Train on the train split, predict the test split.

    Returns the model, the test rows with ``predicted_liquid``, the test
    accuracy (a test trial whose features could not be extracted counts as
    wrong: the robot got no answer) and the number of such failed trials.
    """

    train = usable(split(table, "train"))
    test_all = split(table, "test")
    test = usable(test_all)
    model = train_classifier(X(train), train["liquid"].to_numpy(), label="liquid")
    predicted = model.predict_table(test)
    n_failed = len(test_all) - len(test)
    correct = int((predicted["predicted_liquid"] == predicted["liquid"]).sum())
    accuracy = correct / len(test_all) if len(test_all) else float("nan")
    return model, predicted, accuracy, n_failed


def correct_note(accuracy: float, n_test: int, n_failed: int) -> str:
    """``"29/30 test trials right; 1 without features (counted wrong)"``."""
    note = f"{round(accuracy * n_test)}/{n_test} test trials right"
    return note + (f"; {n_failed} without features (counted wrong)" if n_failed else "")


def decision_figure(
    model,
    train: pd.DataFrame,
    test: pd.DataFrame,
    path: Path,
    title: str,
    accuracy: float | None = None,
    paper: PaperValue | None = None,
) -> Path:
    """Decision regions of ``model`` in (λ, ω) with the train and test trials.

    ``accuracy`` (a fraction) and ``paper`` are written in a box in the corner.
    """
    plt = pyplot()
    points = np.vstack([X(train), X(test)])
    lo, hi = points.min(axis=0), points.max(axis=0)
    pad = 0.08 * (hi - lo)
    lam, om = np.meshgrid(
        np.linspace(lo[0] - pad[0], hi[0] + pad[0], 200),
        np.linspace(lo[1] - pad[1], hi[1] + pad[1], 200),
    )
    classes = list(model.classifier.classes_)
    _, proba = model.predict_proba(np.column_stack([lam.ravel(), om.ravel()]))
    index = np.argmax(proba, axis=1).reshape(lam.shape)  # columns follow classes_
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    colours = ["tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple"]
    ax.contourf(
        lam,
        om,
        index,
        levels=np.arange(len(classes) + 1) - 0.5,
        colors=colours[: len(classes)],
        alpha=0.18,
    )
    for k, name in enumerate(classes):
        tr, te = train[train["liquid"] == name], test[test["liquid"] == name]
        ax.scatter(
            tr["decay_rate"],
            tr["angular_frequency"],
            c=colours[k],
            marker="o",
            edgecolor="k",
            label=f"{name} (train)",
        )
        ax.scatter(
            te["decay_rate"],
            te["angular_frequency"],
            c=colours[k],
            marker="x",
            s=18,
            label=f"{name} (test)",
        )
    ax.set_xlabel("decay rate λ [1/s]")
    ax.set_ylabel("angular frequency ω [rad/s]")
    ax.set_title(title)
    ax.legend(fontsize=7, ncol=2, loc="upper right")
    if accuracy is not None:
        text = f"test accuracy: ours {100 * accuracy:.1f} %"
        if paper is not None:
            text += f"\n{paper.label()}"
        ax.text(
            0.02, 0.02, text, transform=ax.transAxes, fontsize=8, va="bottom",
            bbox={"facecolor": "white", "alpha": 0.85, "edgecolor": "0.7"},
        )  # fmt: skip
    return save_figure(fig, path)


def run(table: pd.DataFrame, out_dir: Path) -> ExperimentResult:
    """Experiment 1 on the ``classification`` dataset's GelSight features."""
    start = time.perf_counter()
    model, predicted, accuracy, n_failed = classify(table)
    train = usable(split(table, "train"))
    confusion = pd.crosstab(predicted["liquid"], predicted["predicted_liquid"]).reset_index()
    confusion.columns = ["true \\ predicted", *confusion.columns[1:]]
    figure = decision_figure(
        model,
        train,
        predicted,
        out_dir / "classification.png",
        "SVM decision regions (GelSight)",
        accuracy,
        CLASSIFICATION_ACCURACY,
    )
    return ExperimentResult(
        key="classification",
        title="1. Liquid classification (water / olive oil / detergent)",
        summary=(
            f"RBF-SVM on (λ, ω) from GelSight videos; trained on {len(train)} trials, tested on "
            f"{len(split(table, 'test'))}. Test accuracy {100 * accuracy:.1f} % "
            f"(paper: {CLASSIFICATION_ACCURACY.value:g} %); {n_failed} test trial(s) gave no "
            "features."
        ),
        tables=[("Confusion matrix (test)", confusion)],
        figures=[figure],
        headlines=[
            Headline.vs(
                "classification",
                "test accuracy",
                100 * accuracy,
                CLASSIFICATION_ACCURACY,
                note=correct_note(accuracy, len(split(table, "test")), n_failed),
            )
        ],
        seconds=time.perf_counter() - start,
    )
