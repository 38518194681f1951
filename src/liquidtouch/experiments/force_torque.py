"""Experiment 2: the same classification from the wrist force-torque sensor.

The paper's accuracies are :data:`.paper.FORCE_TORQUE_ACCURACY`. Both feature
tables come from the same simulated trials (``classification`` dataset): the
GelSight videos and the trial's ``wrench.csv``. A trial whose wrist signal
shows no oscillation above its noise gives no features; it counts as
misclassified (the robot got no answer), which is why the accuracy can be 0 %
with three classes: the note of the headline says so, and the figure shows
a trial's GelSight signal next to its wrist signal. The paper fitted the wrist
signal anyway and classified the result (34.3 %, chance level); the
``wrench-best-effort`` table does the same, so that row compares like for like.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pandas as pd

from liquidtouch.experiments.classification import classify, correct_note
from liquidtouch.experiments.common import pyplot, save_figure, split, usable
from liquidtouch.experiments.paper import FORCE_TORQUE_ACCURACY
from liquidtouch.experiments.report import ExperimentResult, Headline
from liquidtouch.extraction.pipeline import extract_signal
from liquidtouch.extraction.wrench import wrench_signal
from liquidtouch.io.dataset import WRENCH_NAME, read_wrench_csv

SENSORS = ("GelSight", "wrist F/T", "wrist F/T, best-effort fit")


def _first_error(table: pd.DataFrame) -> str:
    """The most common extraction error of ``table`` (shortened), or ""."""
    if "error" not in table.columns:
        return ""
    errors = table["error"].fillna("").astype(str)
    errors = errors[errors != ""]
    if errors.empty:
        return ""
    first = str(errors.value_counts().index[0]).split(" (")[0].split(";")[0].strip()
    return first if len(first) <= 90 else first[:89] + "…"


def _outcome(name: str, table: pd.DataFrame) -> dict[str, object]:
    """Accuracy of one sensor's table and what happened (the row of the result table)."""
    test, train = split(table, "test"), split(table, "train")
    n_train = len(usable(train))
    n_classes = max(1, table["liquid"].nunique()) if "liquid" in table.columns else 3
    chance = f"chance is {100 / n_classes:.0f} %"
    if n_train < 6:
        # too few trials with features to train on: the robot gets no answer on any
        # test trial, so none counts as correct
        accuracy, n_failed = 0.0, len(test)
        error = _first_error(table)
        note = (
            f"no answer: {len(test) - len(usable(test))}/{len(test)} test and "
            f"{len(train) - n_train}/{len(train)} training trials gave no features"
            + (f" (“{error}”)" if error else "")
            + f", so no classifier could be trained; {chance}"
        )
    else:
        _, _, accuracy, n_failed = classify(table)
        note = f"{correct_note(accuracy, len(test), n_failed)}; {chance}"
    return {
        "sensor": name,
        "test accuracy [%]": 100 * accuracy,
        "paper [%]": FORCE_TORQUE_ACCURACY[name].value,
        "test trials without features": n_failed,
        "usable training trials": n_train,
        "what happened": note,
    }


def _example_trial(gelsight: pd.DataFrame, wrench: pd.DataFrame) -> str | None:
    """A test trial (water first: it rings longest) with GelSight features, present in both."""
    if "trial" not in gelsight.columns or "trial" not in wrench.columns:
        return None
    ok = usable(split(gelsight, "test"))
    ok = ok[ok["trial"].isin(set(wrench["trial"]))]
    if ok.empty:
        return None
    water = ok[ok.get("liquid", pd.Series("", index=ok.index)) == "water"]
    return str((water if len(water) else ok)["trial"].iloc[0])


def _signals_panels(axes, trial_dir: Path, fit_row: pd.Series | None) -> None:
    """GelSight u(t) and the wrist forces of one trial, on a shared time axis."""

    signal = extract_signal(trial_dir)
    axes[0].plot(signal.t, signal.u, color="tab:blue", lw=1.2, label="GelSight u(t)")
    axes[0].set_ylabel("GelSight marker motion u [px]")
    title = f"GelSight, trial {trial_dir.name}"
    if fit_row is not None and np.isfinite(fit_row.get("decay_rate", np.nan)):
        title += f": λ = {fit_row['decay_rate']:.2f} 1/s, ω = {fit_row['angular_frequency']:.1f}"
        title += " rad/s"
    axes[0].set_title(title, fontsize=9)
    t_s, force_n = read_wrench_csv(trial_dir / WRENCH_NAME)
    raw = force_n - np.median(force_n, axis=0)
    for j, name in enumerate(("Fx", "Fy", "Fz")):
        axes[1].plot(t_s, raw[:, j], lw=0.4, alpha=0.45, label=f"{name} (raw)")
    t, u, _ = wrench_signal(t_s, force_n)
    axes[1].plot(t, u, color="k", lw=1.2, label="3 Hz low-pass, 1st component")
    axes[1].set_ylabel("wrist force [N]")
    axes[1].set_xlabel("time [s]")
    axes[1].set_title("wrist F/T, same trial: the slosh force is below the noise", fontsize=9)
    lo, hi = axes[1].get_ylim()
    axes[1].set_ylim(lo, hi + 0.35 * (hi - lo))  # room for the legend above the noise
    axes[1].legend(fontsize=7, ncol=4, loc="upper right")
    axes[0].sharex(axes[1])


def _accuracy_panel(ax, rows: list[dict[str, object]]) -> None:
    """Test accuracy per sensor, ours next to the paper's, with the chance level."""
    x = np.arange(len(rows))
    ours = [float(r["test accuracy [%]"]) for r in rows]
    paper = [float(r["paper [%]"]) for r in rows]
    ax.bar(x - 0.2, ours, 0.4, color="tab:blue", label="ours (simulated)")
    ax.bar(x + 0.2, paper, 0.4, color="0.75", hatch="//", edgecolor="0.4", label="paper")
    for xi, value, row in zip(x, ours, rows, strict=True):
        text = f"{value:.0f} %"
        if value == 0 and str(row["what happened"]).startswith("no answer"):
            text = "0 %\nno answer"
        ax.text(xi - 0.2, value + 2, text, ha="center", va="bottom", fontsize=8)
    for xi, value in zip(x, paper, strict=True):
        ax.text(xi + 0.2, value + 2, f"{value:g} %", ha="center", va="bottom", fontsize=8)
    ax.axhline(100 / 3, color="tab:red", ls=":", lw=1, label="chance (1 in 3)")
    ax.set_xticks(x, [str(r["sensor"]).replace(", ", ",\n") for r in rows])
    ax.set_ylim(0, 118)
    ax.set_ylabel("test accuracy [%]")
    ax.set_title(f"paper: {FORCE_TORQUE_ACCURACY['wrist F/T'].source}", fontsize=8)
    ax.legend(fontsize=7, loc="upper right")


def figure(
    rows: list[dict[str, object]],
    path: Path,
    gelsight: pd.DataFrame,
    wrench: pd.DataFrame,
    dataset_root: Path | None,
) -> Path:
    """Accuracy bars (ours vs paper) and, with the dataset at hand, one trial's two signals."""
    plt = pyplot()
    trial = _example_trial(gelsight, wrench) if dataset_root is not None else None
    if trial is None or not (Path(dataset_root) / trial).is_dir():
        fig, ax = plt.subplots(figsize=(5.5, 4.0))
        _accuracy_panel(ax, rows)
        fig.suptitle("GelSight vs wrist F/T: test accuracy")
        return save_figure(fig, path)
    fig = plt.figure(figsize=(12, 5.2))
    grid = fig.add_gridspec(2, 2, width_ratios=(2.2, 1))
    axes = [fig.add_subplot(grid[0, 0]), fig.add_subplot(grid[1, 0])]
    row = usable(gelsight)
    row = row[row["trial"] == trial]
    _signals_panels(axes, Path(dataset_root) / trial, row.iloc[0] if len(row) else None)
    _accuracy_panel(fig.add_subplot(grid[:, 1]), rows)
    fig.suptitle("GelSight vs wrist F/T: one test trial's signals, and the test accuracy")
    return save_figure(fig, path)


def run(
    gelsight: pd.DataFrame,
    wrench: pd.DataFrame,
    out_dir: Path,
    dataset_root: Path | None = None,
    best_effort: pd.DataFrame | None = None,
) -> ExperimentResult:
    """Compare test accuracy from the GelSight and the wrist F/T features.

    ``dataset_root``: the classification dataset (trial directories), for the
    figure's example signals; without it the figure shows the accuracies only.
    ``best_effort``: the wrist features fitted even without an oscillation above
    the noise (feature source ``wrench-best-effort``), the paper's comparison.
    """
    start = time.perf_counter()
    tables = (gelsight, wrench) if best_effort is None else (gelsight, wrench, best_effort)
    rows = [_outcome(name, table) for name, table in zip(SENSORS, tables, strict=False)]
    result = pd.DataFrame(rows)
    ft = rows[1]
    forced = (
        f" With the best-effort fit (as the paper): {rows[2]['test accuracy [%]']:.1f} % — "
        f"{rows[2]['what happened']}."
        if len(rows) > 2
        else ""
    )
    path = figure(rows, Path(out_dir) / "force_torque.png", gelsight, wrench, dataset_root)
    return ExperimentResult(
        key="force_torque",
        title="2. GelSight vs wrist force-torque sensor",
        summary=(
            "The same trials, classified from the GelSight markers and from the wrist F/T signal "
            "(its noise is far above the slosh force). A trial whose signal shows no oscillation "
            f"above the noise counts as misclassified. Wrist F/T: {ft['test accuracy [%]']:.1f} % "
            f"— {ft['what happened']}.{forced}"
        ),
        tables=[("Test accuracy by sensor", result)],
        figures=[path],
        headlines=[
            Headline.vs(
                "force-torque",
                f"{r['sensor']} accuracy",
                float(r["test accuracy [%]"]),
                FORCE_TORQUE_ACCURACY[str(r["sensor"])],
                note=str(r["what happened"]),
            )
            for r in rows
        ],
        seconds=time.perf_counter() - start,
    )
