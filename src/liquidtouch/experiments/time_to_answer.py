"""Experiment 9 (ours, not in the paper): how soon is the streamed answer right, and its ± honest?

Sugar-water test trials are replayed through the live estimator
(:func:`~liquidtouch.live.live_updates`, as ``liquidtouch live trial/ --replay`` streams a
recorded trial, here not in real time) with experiment 8's calibrated GPR. Every update
the live page would show carries a height and a viscosity with their std (the streamed
fit's std propagated through the model, the calibrated model std added). Reported per
trial: the ring-down time from which the height stays within :data:`HEIGHT_TOL_MM` of the
truth, and log10 ν within :data:`VISCOSITY_TOL` (``inf``: the final answer is still off);
per ring-down time bin: the shown estimates' error and the share within ±1σ and ±2σ of the
truth. ``benchmarks/live/time_to_answer.py`` measures the same on every liquid with more trials.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
import pandas as pd

from liquidtouch.errors import LiquidTouchError, TableError
from liquidtouch.experiments.common import TARGETS, pyplot, save_figure, split, usable
from liquidtouch.experiments.report import ExperimentResult, Headline
from liquidtouch.live import live_updates

#: the answer is right when the height is this close to the truth [mm] ...
HEIGHT_TOL_MM = 1.0
#: ... and log10 of the viscosity [cSt] this close
VISCOSITY_TOL = 0.1
TOLERANCES = {"height_mm": HEIGHT_TOL_MM, "log10_viscosity_cst": VISCOSITY_TOL}
#: ring-down time bins [s] of the coverage table
BINS_S = ((0.0, 1.0), (1.0, 2.0), (2.0, 4.0), (4.0, 6.0), (6.0, math.inf))


def pick_trials(test: pd.DataFrame, n: int) -> pd.DataFrame:
    """``n`` rows of ``test`` spread evenly over the fill heights (all when fewer)."""
    ordered = test.sort_values("height_mm", kind="stable")
    if len(ordered) <= n:
        return ordered
    return ordered.iloc[np.unique(np.linspace(0, len(ordered) - 1, n).round().astype(int))]


def streamed(model, trial_dir: Path, targets: list[str]) -> pd.DataFrame:
    """One row per shown update of the replayed trial: ring-down time [s], each target's
    mean and std, and whether it is the final update."""
    rows = []
    for update in live_updates(trial_dir, model=model, realtime=False):
        shown = {t: update.predicted[t] for t in targets if t in update.predicted}
        if not shown or not math.isfinite(update.t_s):
            continue
        row = {"t_s": float(update.t_s), "final": bool(update.final)}
        for target, (mean, std) in shown.items():
            row[target], row[f"{target}_std"] = float(mean), float(std)
        rows.append(row)
    return pd.DataFrame(rows)


def settle_time_s(t_s: np.ndarray, right: np.ndarray) -> float:
    """The first time [s] from which every estimate is right (``inf``: the last is not)."""
    if not len(right) or not right[-1]:
        return math.inf
    wrong = np.flatnonzero(~right)
    return float(t_s[0] if not len(wrong) else t_s[wrong[-1] + 1])


def _symbol(target: str) -> str:
    """The target's short name in the tables (``h`` of ``h [mm]``)."""
    return TARGETS[target].split(" ")[0]


def _settle_column(target: str) -> str:
    return f"{_symbol(target)} right from [s]"


def run(
    model, sugar_table: pd.DataFrame, dataset_root: Path | None, out_dir: Path, n_trials: int
) -> ExperimentResult:
    """Experiment 9: ``n_trials`` sugar-water test trials of ``dataset_root`` streamed with
    ``model`` (experiment 8's GPR)."""
    start = time.perf_counter()
    if model is None or dataset_root is None:
        raise TableError("needs experiment 8's model and the sugar-water trials' recordings")
    targets = [t for t in TOLERANCES if t in model.targets]
    chosen = pick_trials(usable(split(sugar_table, "test")), n_trials)
    trials, streams = [], []
    for _, row in chosen.iterrows():
        try:
            stream = streamed(model, Path(dataset_root) / str(row["trial"]), targets)
        except LiquidTouchError as exc:  # a recording the live path refuses: say so
            trials.append({"trial": row["trial"], "what happened": str(exc)})
            continue
        if stream.empty:
            trials.append({"trial": row["trial"], "what happened": "no estimate shown"})
            continue
        entry = {"trial": row["trial"], "h [mm]": float(row["height_mm"])}
        for target in targets:
            stream[f"{target}_error"] = stream[target] - float(row[target])
            shown = stream[stream[target].notna()]
            err = shown[f"{target}_error"].abs().to_numpy()
            entry[_settle_column(target)] = settle_time_s(
                shown["t_s"].to_numpy(), err <= TOLERANCES[target]
            )
            entry[f"{_symbol(target)} final error"] = float(err[-1]) if len(err) else math.nan
        entry["what happened"] = ""
        trials.append(entry)
        streams.append(stream)
    if not streams:
        raise TableError(f"no trial gave a streamed estimate ({len(chosen)} tried)")
    per_trial = pd.DataFrame(trials)
    coverage = _coverage(pd.concat(streams, ignore_index=True), targets)
    figure = _figure(streams, coverage, targets, Path(out_dir) / "time_to_answer.png")
    settle = per_trial.get(_settle_column("height_mm"), pd.Series(dtype=float)).dropna()
    median_s = float(np.median(settle)) if len(settle) else math.nan
    summary = (
        f"{len(streams)} sugar-water test trials replayed through the live estimator "
        "(`liquidtouch live trial/ --replay`, not in real time) with experiment 8's "
        "calibrated GPR. Every update the live page shows is judged against the truth: the "
        f"ring-down time from which the height stays within {HEIGHT_TOL_MM:g} mm "
        f"(log10 ν within {VISCOSITY_TOL:g}), and per time bin the share of the shown "
        "estimates within ±1σ / ±2σ (nominal 68.3 / 95.4 %). `inf`: the final answer is "
        "still outside."
    )
    headlines = [
        Headline(
            "time_to_answer",
            f"median ring-down time to a height within {HEIGHT_TOL_MM:g} mm for good",
            median_s,
            None,
            "s",
            note=f"{len(streams)} streamed trials",
        )
    ]
    return ExperimentResult(
        "time_to_answer",
        "9. Time to answer, streamed (ours)",
        summary,
        [("per trial", per_trial), ("coverage by ring-down time", coverage)],
        [figure],
        headlines,
        time.perf_counter() - start,
    )


def _coverage(stream: pd.DataFrame, targets: list[str]) -> pd.DataFrame:
    """Per target and ring-down time bin: n, median |error|, ±1σ and ±2σ coverage [%]."""
    rows = []
    for target in targets:
        rows_t = stream[stream[target].notna()]
        err = rows_t[f"{target}_error"].abs()
        z = err / rows_t[f"{target}_std"]
        for lo, hi in BINS_S:
            inside = ((rows_t["t_s"] >= lo) & (rows_t["t_s"] < hi)).to_numpy()
            label = f"{lo:g}-{hi:g} s" if math.isfinite(hi) else f"≥ {lo:g} s"
            n = int(inside.sum())
            rows.append(
                {
                    "target": TARGETS[target],
                    "ring-down": label,
                    "n": n,
                    "median abs. error": float(np.median(err[inside])) if n else math.nan,
                    "±1σ [%]": 100 * float(np.mean(z[inside] <= 1)) if n else math.nan,
                    "±2σ [%]": 100 * float(np.mean(z[inside] <= 2)) if n else math.nan,
                }
            )
    return pd.DataFrame(rows)


def _figure(streams: list[pd.DataFrame], coverage: pd.DataFrame, targets, path: Path) -> Path:
    """Each trial's error against ring-down time, per target; the ±1σ coverage per bin."""
    plt = pyplot()
    fig, axes = plt.subplots(1, len(targets) + 1, figsize=(5.0 * (len(targets) + 1), 4.2))
    for ax, target in zip(axes, targets, strict=False):
        for stream in streams:
            shown = stream[stream[target].notna()]
            ax.plot(shown["t_s"], shown[f"{target}_error"], lw=1, alpha=0.7)
        tol, unit = TOLERANCES[target], TARGETS[target].split("[")[-1].rstrip("]")
        ax.axhspan(-tol, tol, color="0.85", zorder=0, label=f"±{tol:g} {unit}")
        ax.set(xlabel="ring-down time [s]", ylabel=f"streamed − true {TARGETS[target]}")
        ax.legend(fontsize=7, loc="upper right")
    ax = axes[-1]
    width = 0.8 / len(targets)
    for k, target in enumerate(targets):
        part = coverage[coverage["target"] == TARGETS[target]]
        x = np.arange(len(part)) + (k - (len(targets) - 1) / 2) * width
        ax.bar(x, part["±1σ [%]"], width, label=TARGETS[target])
    ax.axhline(68.3, color="0.3", lw=1, ls="--", label="nominal 68.3 %")
    ax.set_xticks(np.arange(len(BINS_S)), list(part["ring-down"]), fontsize=7)
    ax.set(xlabel="ring-down time", ylabel="shown estimates within ±1σ [%]", ylim=(0, 105))
    ax.legend(fontsize=7, loc="lower right")
    fig.suptitle("The streamed answer: error and ±1σ coverage against ring-down time")
    return save_figure(fig, path)
