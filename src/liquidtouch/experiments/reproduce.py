"""Run every experiment of the paper on simulated trials, end to end, and write the report.

Each dataset is simulated once (videos and all) into ``OUT/data/<quick|full>/<preset>``,
its features extracted through the whole pipeline (videos → markers → signal
→ fit; cached per trial), then the seven experiments run on the feature
tables. Re-running reuses what is there.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from liquidtouch.errors import LiquidTouchError
from liquidtouch.experiments import (
    classification,
    containers,
    data_efficiency,
    force_torque,
    other_liquids,
    sugar,
    transfer,
)
from liquidtouch.experiments.report import ExperimentResult, summary_table, write_report
from liquidtouch.io.dataset import MANIFEST_NAME

DATASETS = ("classification", "sugar", "other-liquids", "containers")


@dataclass
class Reproduction:
    """Where the report went, its headline numbers and how long each part took [s]."""

    report_md: Path
    report_html: Path
    summary: pd.DataFrame
    seconds: dict[str, float]


def prepare_dataset(
    preset: str, root: Path, *, quick: bool, jobs: int, dask_address: str | None, progress: bool
) -> dict[str, pd.DataFrame]:
    """Simulate ``preset`` into ``root`` unless it is there; return its feature tables."""
    from liquidtouch.batch.features import extract_features
    from liquidtouch.sim.presets import simulate_dataset

    if not (root / MANIFEST_NAME).is_file():
        # the quick run uses the GelSight Mini profile (320 x 240 at 25 fps): 3x cheaper
        sensor = "mini" if quick else "default"
        simulate_dataset(preset, root, jobs=jobs, quick=quick, progress=progress, sensor=sensor)
    tables = {
        "gelsight": extract_features(root, jobs=jobs, dask_address=dask_address, progress=progress)
    }
    if preset == "classification":
        tables["wrench"] = extract_features(
            root,
            out=root / "features_wrench.csv",
            jobs=jobs,
            dask_address=dask_address,
            source="wrench",
            progress=progress,
        )
    return tables


def failure_note(features: dict[str, dict[str, pd.DataFrame]]) -> str:
    """One sentence: trials per dataset and how many gave no GelSight features (one reason)."""
    parts = []
    for preset, tables in features.items():
        table = tables["gelsight"]
        errors = table["error"].fillna("").astype(str) if "error" in table else pd.Series([], str)
        failed = errors[errors != ""]
        text = f"{preset} {len(table)} trials"
        if len(failed):
            text += f" ({len(failed)} without features, e.g. “{failed.iloc[0][:100]}”)"
        parts.append(text)
    return "Trials: " + "; ".join(parts) + "."


def _not_run(key: str, title: str, reason: Exception) -> ExperimentResult:
    return ExperimentResult(key, f"{title} (not run)", f"Not run: {reason}.")


def _attempt(key: str, title: str, run: Callable[..., ExperimentResult], *args) -> ExperimentResult:
    """``run(*args)``, or a "not run" result saying why when the data cannot support it.

    An argument ``None`` is the sugar-water model of an experiment 3 that did not run.
    """
    try:
        if any(arg is None for arg in args):
            raise LiquidTouchError("it needs the sugar-water model of experiment 3")
        return run(*args)
    except LiquidTouchError as exc:
        return _not_run(key, title, exc)


def run_experiments(
    features: dict[str, dict[str, pd.DataFrame]], out_dir: str | Path
) -> list[ExperimentResult]:
    """The seven experiments on feature tables (``features[preset]["gelsight" | "wrench"]``).

    ``features`` needs the presets of :data:`DATASETS`; ``classification`` also
    its ``wrench`` table. Figures and tables go to ``out_dir``. An experiment
    the data cannot support (too few usable trials) is reported as not run,
    with the reason, and the others still run.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    sugar_table = features["sugar"]["gelsight"]
    container_table = features["containers"]["gelsight"]
    classes = features["classification"]
    per_container = {"grooved-cuboid": sugar_table}
    per_container.update(
        {name: part for name, part in container_table.groupby("container", sort=False)}
    )
    cuboid = container_table[container_table["container"] == "cuboid"]

    results = [
        _attempt("classification", "1. Liquid classification", classification.run,
                 classes["gelsight"], out),
        _attempt("force_torque", "2. GelSight vs wrist force-torque sensor", force_torque.run,
                 classes["gelsight"], classes["wrench"], out),
    ]  # fmt: skip
    sugar_gpr = None  # experiments 4 and 7 reuse experiment 3's model
    try:
        sugar_result, sugar_gpr = sugar.run(sugar_table, out)
    except LiquidTouchError as exc:
        sugar_result = _not_run("sugar", "3. Sugar water", exc)
    results += [
        sugar_result,
        _attempt("other_liquids", "4. Olive oil, corn oil, mirin", other_liquids.run,
                 sugar_gpr, features["other-liquids"]["gelsight"], out),
        _attempt("containers", "5. Other containers", containers.run, container_table, out),
        _attempt("data_efficiency", "6. Data efficiency", data_efficiency.run, per_container, out),
        _attempt("transfer", "7. Container transfer", transfer.run, sugar_gpr, cuboid, out),
    ]  # fmt: skip
    return results


def reproduce(
    out_dir: str | Path,
    *,
    quick: bool = False,
    jobs: int = 1,
    dask_address: str | None = None,
    progress: bool = True,
) -> Reproduction:
    """Simulate, extract, run the seven experiments and write ``report.md`` / ``report.html``."""
    out = Path(out_dir)
    data_root = out / "data" / ("quick" if quick else "full")
    seconds: dict[str, float] = {}
    features: dict[str, dict[str, pd.DataFrame]] = {}
    reused: list[str] = []
    for preset in DATASETS:
        if (data_root / preset / MANIFEST_NAME).is_file():
            reused.append(preset)
        start = time.perf_counter()
        features[preset] = prepare_dataset(
            preset,
            data_root / preset,
            quick=quick,
            jobs=jobs,
            dask_address=dask_address,
            progress=progress,
        )
        seconds[f"data: {preset}"] = time.perf_counter() - start

    start = time.perf_counter()
    results = run_experiments(features, out)
    seconds["experiments"] = time.perf_counter() - start

    timing = ", ".join(f"{k} {v:.0f} s" for k, v in seconds.items())
    if reused:  # their simulation (and cached features) came from an earlier run
        timing += f" (simulated in an earlier run, not timed here: {', '.join(reused)})"
    preamble = (
        f"{'Quick' if quick else 'Full'} reproduction of Huang, Guo, Yuan (RSS 2022) on "
        f"simulated trials, each through the whole pipeline (rendered GelSight videos of the "
        f"{'GelSight Mini (320×240, 25 fps)' if quick else 'default (640×480, 30 fps)'} profile "
        f"→ marker tracking → tactile signal → oscillation fit → models). {failure_note(features)} "
        f"Time: {timing}; total {sum(seconds.values()):.0f} s with {jobs} worker(s)."
    )
    md, html = write_report(
        results, out, title="liquidtouch: reproduction of the paper", preamble=preamble
    )
    return Reproduction(md, html, summary_table(results), seconds)
