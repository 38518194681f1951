"""Experiment 7: transfer grooved cuboid → plain cuboid with a few tuning points.

Keep the sugar-water GPR of the grooved cuboid and fit only
``f_B(λ, ω) = f_A(α1 λ + α2, β1 ω + β2)`` on n cuboid trials, against a GPR
trained from scratch on the same n trials. The paper found
:data:`.paper.TRANSFER_POINTS` tuning points enough.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pandas as pd

from liquidtouch.experiments.common import (
    AXIS_LABELS,
    TARGETS,
    X,
    mae,
    plain_log_axis,
    pyplot,
    save_figure,
    split,
    usable,
)
from liquidtouch.experiments.paper import TRANSFER_POINTS
from liquidtouch.experiments.report import ExperimentResult, Headline
from liquidtouch.experiments.sugar import train_models
from liquidtouch.models.transfer import fit_transfer

SIZES = (5, 10, 15, 20, 40, 60, 100)
REPEATS = 10  # random tuning draws per size: the quick set has few cuboid trials


def run(source_model, cuboid: pd.DataFrame, out_dir: Path, seed: int = 0) -> ExperimentResult:
    """Transfer vs from-scratch test MAE on the cuboid for each tuning size.

    ``seed``: the random draws of tuning trials.
    """

    start = time.perf_counter()
    cuboid = usable(cuboid)
    train, test = split(cuboid, "train"), split(cuboid, "test")
    rng = np.random.default_rng(seed)
    rows = []
    # the sizes of SIZES below the training set's, then all of it (once: every draw is the same)
    sizes = [n for n in SIZES if n < len(train)]
    sizes += [len(train)] if len(train) >= SIZES[0] else []
    for n in sizes:
        for method in ("transfer", "scratch"):
            scores = {t: [] for t in TARGETS}
            for _ in range(REPEATS if n < len(train) else 1):
                tune = train.iloc[rng.choice(len(train), n, replace=False)]
                if method == "transfer":
                    targets = {t: tune[t].to_numpy(float) for t in TARGETS}
                    model = fit_transfer(source_model, X(tune), targets).model
                elif n >= 6:
                    model = train_models(tune, "gpr")
                else:
                    continue
                predictions = model.predict(X(test))
                for t in TARGETS:
                    scores[t].append(mae(predictions[t][0], test[t]))
            if scores["height_mm"]:
                rows.append(
                    {"n tuning": n, "method": method}
                    | {TARGETS[t]: float(np.mean(v)) for t, v in scores.items()}
                )
    no_tuning = source_model.predict(X(test))
    baseline = {TARGETS[t]: mae(no_tuning[t][0], test[t]) for t in TARGETS}
    table = pd.DataFrame(rows)
    plt = pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.4))
    for ax, t in zip(axes, TARGETS, strict=True):
        for method, style in (("transfer", "o-"), ("scratch", "s--")):
            part = table[table["method"] == method] if len(table) else table
            if len(part):
                ax.plot(part["n tuning"], part[TARGETS[t]], style, label=method)
        ax.axhline(baseline[TARGETS[t]], color="grey", lw=0.8, ls=":", label="grooved model as is")
        ax.axvline(
            TRANSFER_POINTS.value, color="k", lw=0.8, ls="-.",
            label=f"paper: {TRANSFER_POINTS.value:g} points suffice",
        )  # fmt: skip
        ax.set_xlabel("cuboid trials used")
        ax.set_ylabel(f"test MAE of {AXIS_LABELS[t]}")
        plain_log_axis(ax, "y")
    # one legend under the panels: inside a panel it covered the curves and the next axis label
    fig.legend(*axes[0].get_legend_handles_labels(), loc="outside lower center", ncol=4, fontsize=8)
    fig.suptitle(
        "Container transfer grooved cuboid → cuboid; dash-dot: "
        f"{TRANSFER_POINTS.label().replace('paper: ', 'the paper, ')}",
        fontsize=10,
    )
    headlines = []
    at15 = table[(table["n tuning"] == 15)].set_index("method") if len(table) else pd.DataFrame()
    for method in ("transfer", "scratch"):
        if method in at15.index:
            headlines.append(
                Headline(
                    "transfer",
                    f"{method}, 15 points: h MAE",
                    float(at15.loc[method, TARGETS["height_mm"]]),
                    None,
                    "mm",
                    note=f"paper: {TRANSFER_POINTS.value:g} tuning points suffice (no MAE given)",
                    source=TRANSFER_POINTS.source,
                )
            )
    return ExperimentResult(
        "transfer",
        "7. Container transfer (grooved cuboid → cuboid)",
        f"Test MAE on {len(test)} cuboid trials after fitting only α1, α2, β1, β2 on n cuboid "
        f"trials (mean of {REPEATS} random draws; the last n is all {len(train)}), against a GPR "
        "trained from scratch on the same n trials. Without any tuning the grooved-cuboid model "
        f"gives h MAE {baseline[TARGETS['height_mm']]:.2f} mm.",
        [("Test MAE vs tuning points", table)],
        [save_figure(fig, out_dir / "transfer.png")],
        headlines,
        time.perf_counter() - start,
    )
