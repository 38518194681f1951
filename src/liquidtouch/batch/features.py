"""Feature extraction over a whole dataset: one row of (λ, ω, fit quality, labels) per trial.

Trials run in parallel through any :class:`concurrent.futures.Executor`
(serial, process pool, Dask). Each finished trial is cached under
``DATASET/.cache/features/`` keyed by a fingerprint of its inputs, so a trial
whose inputs did not change is not redone and an interrupted run resumes
where it stopped. A bad trial is recorded with its error and the run goes on.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Callable
from pathlib import Path

import pandas as pd

from liquidtouch.batch.executors import open_executor, run_each
from liquidtouch.errors import LiquidTouchError
from liquidtouch.io import atomic
from liquidtouch.io.dataset import (
    FEATURES_NAME,
    META_NAME,
    WRENCH_NAME,
    read_manifest,
    read_trial_meta,
    trial_path,
)
from liquidtouch.io.tables import FEATURE_COLUMNS
from liquidtouch.progress import progress_bar

#: Bump when extraction or fitting changes in a way that changes features.
FEATURES_VERSION = 2
SOURCES = ("gelsight", "wrench")
#: The measured columns of a feature row (after the manifest's): the two model
#: features (:data:`liquidtouch.io.tables.FEATURE_COLUMNS`) first, then fit diagnostics.
FEATURE_ROW_COLUMNS = (
    *FEATURE_COLUMNS,
    "fast_decay_rate",
    "fast_angular_frequency",
    "decay_rate_std",
    "angular_frequency_std",
    "r2",
    "explained_variance",
    "n_markers",
    "frames",
    "fps",
)
CACHE_DIR = Path(".cache") / "features"


def trial_features(trial_dir: str | Path, source: str = "gelsight") -> dict[str, float]:
    """Features of one trial directory: the oscillation fit of its tactile (or wrist) signal."""
    from liquidtouch.extraction import extract_trial
    from liquidtouch.wrench import wrench_features

    if source == "wrench":
        return wrench_features(trial_dir)
    return extract_trial(trial_dir)


def _fingerprint(trial_dir: Path, source: str) -> str:
    """Hash of everything the trial's features depend on (file sizes and mtimes, settings)."""
    meta = read_trial_meta(trial_dir)
    inputs = [META_NAME, *(meta.sensors if source == "gelsight" else [WRENCH_NAME])]
    digest = hashlib.sha256(f"v{FEATURES_VERSION}:{source}".encode())
    for name in inputs:
        path = trial_dir / name
        stat = path.stat() if path.exists() else None
        digest.update(
            f"|{name}:{stat.st_size if stat else -1}:{stat.st_mtime_ns if stat else -1}".encode()
        )
    return digest.hexdigest()


def _safe_run(trial_dir: str, source: str) -> dict[str, object]:
    """Worker: features of one trial, or the error that stopped it (never raises)."""
    try:
        return {"features": trial_features(trial_dir, source), "error": None, "cacheable": True}
    except LiquidTouchError as exc:
        return {"features": {}, "error": str(exc), "cacheable": True}
    except Exception as exc:  # a batch survives any one bad trial
        return {"features": {}, "error": f"{type(exc).__name__}: {exc}", "cacheable": False}


def _cache_file(root: Path, trial: str, source: str) -> Path:
    safe = trial.replace("/", "__")
    return root / CACHE_DIR / source / f"{safe}.json"


def _read_cache(path: Path, fingerprint: str) -> dict[str, object] | None:
    try:
        entry = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError):  # unreadable or damaged: recompute
        return None
    if not isinstance(entry, dict) or entry.get("fingerprint") != fingerprint:
        return None
    return entry


def extract_features(
    dataset: str | Path,
    *,
    out: str | Path | None = None,
    jobs: int = 1,
    dask_address: str | None = None,
    source: str = "gelsight",
    progress: bool = True,
    on_trial: Callable[[str, dict[str, object]], None] | None = None,
) -> pd.DataFrame:
    """Extract features of every trial of ``dataset``; write ``out`` (default ``features.csv``).

    Returns the table: the manifest's columns, then :data:`FEATURE_ROW_COLUMNS`,
    then ``error`` (empty for good trials). ``on_trial(trial, result)`` is
    called as each trial finishes (used by tests and progress reports).
    """
    if source not in SOURCES:
        raise LiquidTouchError(
            f"unknown feature source {source!r}; choose one of {', '.join(SOURCES)}"
        )
    root = Path(dataset)
    manifest = read_manifest(root)
    results: dict[str, dict[str, object]] = {}
    todo: dict[str, tuple[Path, str]] = {}
    for trial in manifest["trial"]:
        tdir = trial_path(root, trial)
        try:
            fingerprint = _fingerprint(tdir, source)
        except LiquidTouchError as exc:
            results[trial] = {"features": {}, "error": str(exc)}
            continue
        cached = _read_cache(_cache_file(root, trial, source), fingerprint)
        if cached is not None:
            results[trial] = cached
        else:
            todo[trial] = (tdir, fingerprint)

    if todo:
        with (
            open_executor(jobs, dask_address, n_tasks=len(todo)) as pool,
            progress_bar(f"features ({source})", len(todo), enabled=progress) as advance,
        ):
            tasks = {trial: (str(tdir), source) for trial, (tdir, _) in todo.items()}
            for trial, future in run_each(pool, _safe_run, tasks):
                result = future.result()
                if result.pop("cacheable"):
                    entry = {"fingerprint": todo[trial][1], **result}
                    atomic.write_json(_cache_file(root, trial, source), entry)
                results[trial] = result
                if on_trial is not None:
                    on_trial(trial, result)
                advance()

    rows = []
    for record in manifest.to_dict("records"):
        result = results[record["trial"]]
        features = result.get("features") or {}
        row = dict(record)
        row.update({name: features.get(name, math.nan) for name in FEATURE_ROW_COLUMNS})
        row["error"] = result.get("error") or ""
        rows.append(row)
    table = pd.DataFrame(rows)
    out_path = Path(out) if out is not None else root / FEATURES_NAME
    atomic.write_text(out_path, table.to_csv(index=False))
    return table
