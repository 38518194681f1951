"""The paper's seven experiments and our two, run on the feature tables of the four datasets.

The experiments form four independent chains (an experiment that reuses another's model
runs after it in its chain), run on worker processes when asked; the results come back in
the report's order (:data:`EXPERIMENT_ORDER`) and do not depend on the number of workers.
An experiment the data cannot support is reported as "not run", with the reason.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pandas as pd

from liquidtouch._core.pool import open_executor, run_each
from liquidtouch.errors import LiquidTouchError
from liquidtouch.experiments import (
    calibration,
    classification,
    containers,
    data_efficiency,
    force_torque,
    other_liquids,
    sugar,
    time_to_answer,
    transfer,
)
from liquidtouch.experiments.report import ExperimentResult

__all__ = ["EXPERIMENT_ORDER", "STREAMED_TRIALS", "STREAMED_TRIALS_QUICK", "run_experiments"]

#: sugar-water test trials experiment 9 streams through the live estimator (~2 CPU-s each
#: on the Mini), and in a quick reproduction
STREAMED_TRIALS, STREAMED_TRIALS_QUICK = 12, 2


def _not_run(key: str, title: str, reason: Exception) -> ExperimentResult:
    return ExperimentResult(key, f"{title} (not run)", f"Not run: {reason}.")


def _attempt(
    key: str, title: str, run: Callable[..., ExperimentResult], *args, **options
) -> ExperimentResult:
    """``run(*args, **options)``, or a "not run" result saying why when the data cannot support it.

    A positional argument ``None`` is the sugar-water model of an experiment 3 that did not run.
    """
    try:
        if any(arg is None for arg in args):
            raise LiquidTouchError("it needs the sugar-water model of experiment 3")
        return run(*args, **options)
    except LiquidTouchError as exc:
        return _not_run(key, title, exc)


#: the report's order of the experiments (their ``ExperimentResult.key``)
EXPERIMENT_ORDER = (
    "classification",
    "force_torque",
    "sugar",
    "other_liquids",
    "containers",
    "data_efficiency",
    "transfer",
    "calibration",
    "time_to_answer",
)


def _classification_chain(
    classes: dict[str, pd.DataFrame], out: Path, root: Path | None
) -> list[ExperimentResult]:
    """Experiments 1 and 2 (the classification dataset)."""
    return [
        _attempt("classification", "1. Liquid classification", classification.run,
                 classes["gelsight"], out),
        _attempt("force_torque", "2. GelSight vs wrist force-torque sensor", force_torque.run,
                 classes["gelsight"], classes["wrench"], out, dataset_root=root,
                 best_effort=classes.get("wrench-best-effort")),
    ]  # fmt: skip


def _sugar_chain(
    sugar_table: pd.DataFrame, other_table: pd.DataFrame, cuboid: pd.DataFrame, out: Path, seed: int
) -> list[ExperimentResult]:
    """Experiment 3 and the two that reuse its sugar-water model (4 and 7)."""
    sugar_gpr = None
    try:
        sugar_result, sugar_gpr = sugar.run(sugar_table, out)
    except LiquidTouchError as exc:
        sugar_result = _not_run("sugar", "3. Sugar water", exc)
    return [
        sugar_result,
        _attempt("other_liquids", "4. Olive oil, corn oil, mirin", other_liquids.run,
                 sugar_gpr, other_table, out),
        _attempt("transfer", "7. Container transfer", transfer.run, sugar_gpr, cuboid, out,
                 seed=seed),
    ]  # fmt: skip


def _container_chain(
    container_table: pd.DataFrame, per_container: dict[str, pd.DataFrame], out: Path, seed: int
) -> list[ExperimentResult]:
    """Experiments 5 and 6 (the containers)."""
    return [
        _attempt("containers", "5. Other containers", containers.run, container_table, out),
        _attempt("data_efficiency", "6. Data efficiency", data_efficiency.run, per_container, out,
                 seed=seed),
    ]  # fmt: skip


def _calibration_chain(
    sugar_table: pd.DataFrame,
    other_table: pd.DataFrame,
    out: Path,
    root: Path | None,
    n_trials: int,
) -> list[ExperimentResult]:
    """Experiment 8 and experiment 9, which streams with 8's calibrated model."""
    calibrated = None
    try:
        calibration_result, calibrated = calibration.run(sugar_table, other_table, out)
    except LiquidTouchError as exc:
        calibration_result = _not_run("calibration", "8. Calibration of the ± values (ours)", exc)
    return [
        calibration_result,
        _attempt("time_to_answer", "9. Time to answer, streamed (ours)", time_to_answer.run,
                 model=calibrated, sugar_table=sugar_table, dataset_root=root, out_dir=out,
                 n_trials=n_trials),
    ]  # fmt: skip


def run_experiments(
    features: dict[str, dict[str, pd.DataFrame]],
    out_dir: str | Path,
    *,
    seed: int = 0,
    dataset_roots: dict[str, Path] | None = None,
    streamed_trials: int = STREAMED_TRIALS,
    jobs: int = 1,
) -> list[ExperimentResult]:
    """The paper's seven experiments and our two on feature tables
    (``features[preset]["gelsight" | "wrench"]``), in the order of :data:`EXPERIMENT_ORDER`.

    ``features`` needs the presets of
    :data:`~liquidtouch.experiments.reproduce.DATASETS`; ``classification`` also
    its ``wrench`` table (and optionally ``wrench-best-effort``). Figures and
    tables go to ``out_dir``. An experiment the data cannot support (too few
    usable trials) is reported as not run, with the reason, and the others still
    run. ``seed`` draws the random training subsets of experiments 6 and 7;
    ``dataset_roots`` (preset → dataset directory) lets experiment 2 plot a trial's raw
    signals and experiment 9 replay ``streamed_trials`` sugar-water test trials through the
    live estimator (without them it is reported as not run). The experiments form four
    independent chains (an experiment that reuses another's model runs after it in its
    chain), run on ``jobs`` worker processes; the results do not depend on ``jobs``.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    roots = dataset_roots or {}
    sugar_table = features["sugar"]["gelsight"]
    other_table = features["other-liquids"]["gelsight"]
    container_table = features["containers"]["gelsight"]
    per_container = {"grooved-cuboid": sugar_table}
    per_container.update(
        {name: part for name, part in container_table.groupby("container", sort=False)}
    )
    cuboid = container_table[container_table["container"] == "cuboid"]
    # the longest chains first, so that the pool's two workers end close together
    chains = {
        "sugar": (_sugar_chain, sugar_table, other_table, cuboid, out, seed),
        "containers": (_container_chain, container_table, per_container, out, seed),
        "calibration": (_calibration_chain, sugar_table, other_table, out, roots.get("sugar"),
                        streamed_trials),
        "classification": (_classification_chain, features["classification"], out,
                           roots.get("classification")),
    }  # fmt: skip
    results: list[ExperimentResult] = []
    with open_executor(jobs, n_tasks=len(chains)) as pool:
        for _, future in run_each(pool, _run_chain, chains):
            results += future.result()
    return sorted(results, key=lambda result: EXPERIMENT_ORDER.index(result.key))


def _run_chain(chain: Callable[..., list[ExperimentResult]], *args) -> list[ExperimentResult]:
    return chain(*args)
