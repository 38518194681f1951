"""Experiment 8 (ours, not in the paper): is every ± the models print calibrated?

A GPR trained on the sugar-water training trials as ``liquidtouch train`` does
(10-fold cross-conformal calibration with the default groups, a local factor on
the GP's std), judged on the sugar-water test trials and on the other
liquids (olive oil, corn oil, mirin): per target, the coverage of the calibrated
±1σ and ±2σ and of the 90 % interval, the RMS of z = error / std (1 when
calibrated), and a reliability diagram — the share of trials inside the central
interval of each level against that level (on the diagonal when calibrated). The
offline fit's λ, ω std are propagated as ``predict`` does.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
import pandas as pd

from liquidtouch.errors import TableError
from liquidtouch.experiments.common import TARGETS, X, pyplot, save_figure, split, usable
from liquidtouch.experiments.report import ExperimentResult, Headline
from liquidtouch.models.conformal import default_groups
from liquidtouch.models.property_model import PropertyModel, feature_std_matrix
from liquidtouch.models.training import can_calibrate, train_regression

#: central-interval levels of the reliability diagram
LEVELS = (0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.95)


def _rows(model, name: str, table: pd.DataFrame, targets: list[str]) -> tuple[list, dict]:
    """Coverage rows of ``table`` and, per target, the observed coverage at :data:`LEVELS`."""
    rows, curves = [], {}
    std_in = feature_std_matrix(table)
    predicted = model.predict(X(table), std_in)
    for target in targets:
        truth = table[target].to_numpy(dtype=float)
        mean, std = predicted[target]
        z = np.abs(mean - truth) / std
        inside90 = np.nan
        cal = model.calibration[target]
        curve = []
        for level in LEVELS:
            try:
                curve.append(float(np.mean(z <= cal.half_width(level))))
            except TableError:  # too few calibration rows for this level
                curve.append(math.nan)
        inside90 = curve[LEVELS.index(0.9)]
        curves[target] = curve
        rows.append(
            {
                "data": name,
                "target": TARGETS.get(target, target),
                "n": len(table),
                "±1σ [%]": 100 * float(np.mean(z <= 1)),
                "±2σ [%]": 100 * float(np.mean(z <= 2)),
                "90 % interval [%]": 100 * inside90,
                "rms z": float(math.sqrt(np.mean(z**2))),
            }
        )
    return rows, curves


def run(
    sugar_table: pd.DataFrame, other_table: pd.DataFrame, out_dir: Path
) -> tuple[ExperimentResult, PropertyModel]:
    """Experiment 8 on the sugar-water (train/test) and other-liquids feature tables; also
    returns its calibrated GPR (experiment 9 streams with it)."""
    start = time.perf_counter()
    train, test = usable(split(sugar_table, "train")), usable(split(sugar_table, "test"))
    targets = [t for t in ("height_mm", "log10_viscosity_cst") if t in train.columns]
    groups = default_groups(train)
    if not len(test) or not can_calibrate("gpr", len(train), 10, groups):
        raise TableError(
            f"too few sugar-water trials to calibrate ({len(train)} for training, "
            f"{len(test)} for testing)"
        )
    model = train_regression(
        X(train),
        {t: train[t].to_numpy(float) for t in targets},
        "gpr",
        calibration_folds=10,
        calibration_groups=groups,
        calibration_std=feature_std_matrix(train),  # the scores see the rows' own fit std
    )
    parts = [("sugar water (test)", test)]
    other = usable(other_table)
    if len(other):
        parts.append(("olive oil, corn oil, mirin", other))
    rows, curves = [], {}
    for name, part in parts:
        part_rows, part_curves = _rows(model, name, part, targets)
        rows += part_rows
        curves[name] = part_curves
    table = pd.DataFrame(rows)
    plt = pyplot()
    fig, axes = plt.subplots(1, len(targets), figsize=(5.2 * len(targets), 4.4), squeeze=False)
    for ax, target in zip(axes[0], targets, strict=True):
        ax.plot([0, 1], [0, 1], color="0.6", lw=1, label="calibrated")
        for name, part_curves in curves.items():
            ax.plot(LEVELS, part_curves[target], marker="o", label=name)
        ax.set(
            xlabel="nominal level of the central interval",
            ylabel="share of trials inside",
            title=TARGETS.get(target, target),
            xlim=(0, 1),
            ylim=(0, 1.02),
        )
        ax.legend(fontsize=7, loc="upper left")
    fig.suptitle(
        "Reliability of the calibrated intervals: sugar-water GPR (10-fold cross-conformal, "
        "default groups)",
        fontsize=10,
    )
    figure = save_figure(fig, out_dir / "calibration.png")
    headlines = [
        Headline(
            "calibration",
            f"{r['data']}: ±1σ coverage {r['target'].split(' ')[0]}",
            r["±1σ [%]"],
            None,
            "%",
            note="nominal 68.3 %",
        )
        for r in rows
    ]
    summary = (
        f"Every ± is calibrated on the training rows: a GPR trained on {len(train)} sugar-water "
        "trials with the cross-conformal calibration of `liquidtouch train` (10 folds, the "
        "default groups, scores normalised by the GP's std and a local factor learnt from "
        "them), judged on trials it never saw. "
        "Nominal: ±1σ 68.3 %, ±2σ 95.4 %, the 90 % interval 90 %, RMS z 1."
    )
    result = ExperimentResult(
        "calibration",
        "8. Calibration of the ± values (ours)",
        summary,
        [("coverage of the truth", table)],
        [figure],
        headlines,
        time.perf_counter() - start,
    )
    return result, model
