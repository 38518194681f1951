"""Feature extraction over a whole dataset: one row of (λ, ω, fit quality, labels) per trial.

Trials run in parallel through any :class:`concurrent.futures.Executor`
(serial, process pool, Dask). Each finished trial is cached under
``DATASET/.cache/features/`` keyed by a fingerprint of its inputs and of every
extraction and fit setting, so a trial whose inputs and settings did not change
is not redone and an interrupted run resumes where it stopped. A bad trial is
recorded with its error and the run goes on. Every row records the liquidtouch
version that computed it and the settings (:data:`PROVENANCE_COLUMNS`).
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
from collections.abc import Callable
from pathlib import Path

import pandas as pd

from liquidtouch import __version__
from liquidtouch._core import atomic
from liquidtouch._core.pool import open_executor, run_each
from liquidtouch._core.progress import progress_bar
from liquidtouch.errors import LiquidTouchError
from liquidtouch.extraction.fit_settings import FitSettings
from liquidtouch.extraction.pipeline import extract_trial
from liquidtouch.extraction.wrench import wrench_features
from liquidtouch.io.dataset import (
    FEATURES_NAME,
    META_NAME,
    WRENCH_NAME,
    read_manifest,
    read_trial_meta,
    trial_path,
)
from liquidtouch.io.tables import FEATURE_COLUMNS, SETTINGS_COLUMN
from liquidtouch.signal.lowpass import DEFAULT_LOWPASS_HZ
from liquidtouch.signal.tactile import DEFAULT_N_MARKERS, check_signal_options
from liquidtouch.tracking.gel import DEFAULT_TRACKING, check_tracking

__all__ = [
    "CACHE_DIR",
    "FEATURES_VERSION",
    "FEATURE_ROW_COLUMNS",
    "PROVENANCE_COLUMNS",
    "SOURCES",
    "cache_trial_features",
    "extract_features",
    "feature_settings",
    "settings_text",
    "trial_features",
]

logger = logging.getLogger(__name__)

#: Bump when extraction or fitting changes in a way that changes features.
FEATURES_VERSION = 6
#: ``wrench-best-effort``: the wrist fit even where it shows no oscillation (the paper's baseline)
SOURCES = ("gelsight", "wrench", "wrench-best-effort")
#: The measured columns of a feature row (after the manifest's): the two model
#: features (:data:`liquidtouch.io.tables.FEATURE_COLUMNS`) first, then fit diagnostics.
FEATURE_ROW_COLUMNS = (
    *FEATURE_COLUMNS,
    "fast_decay_rate",
    "fast_angular_frequency",
    "decay_rate_std",
    "angular_frequency_std",
    "damping_gain",
    "damping_gain_std",
    "r2",
    "explained_variance",
    "n_markers",
    "frames",
    "fps",
    "model",
    "delta_bic_single_mode",
    "delta_bic_two_mode",
    "delta_bic_amplitude",
    "delta_bic_amplitude_two_mode",
    "gap_share",
    "signal_gap_share",
)
#: Columns after ``error``: the liquidtouch version that computed the row and the
#: settings of the run (compact JSON, :func:`feature_settings`).
PROVENANCE_COLUMNS = ("liquidtouch_version", SETTINGS_COLUMN)
CACHE_DIR = Path(".cache") / "features"


def feature_settings(
    source: str = "gelsight",
    *,
    lowpass_hz: float | None = DEFAULT_LOWPASS_HZ,
    n_markers: int = DEFAULT_N_MARKERS,
    sensors: list[str] | tuple[str, ...] | None = None,
    fit_settings: FitSettings | None = None,
    tracking: str = DEFAULT_TRACKING,
) -> dict[str, object]:
    """Every setting the features of ``source`` depend on, JSON-ready (validated).

    ``tracking`` (gelsight; :mod:`liquidtouch.tracking.gel`) is kept only when forced, so
    the default's settings, and the trials cached under them, stay what they were.

    ``gelsight``: ``lowpass_hz``, ``n_markers``, ``sensors`` (None: all) and ``fit``
    (:meth:`~liquidtouch.extraction.fit_settings.FitSettings.to_dict`); ``wrench``: ``lowpass_hz``
    (a number: the wrist forces are always low-passed) and ``fit``; ``wrench-best-effort``:
    the same, fitted even where the wrist signal shows no oscillation.
    """

    if source not in SOURCES:
        raise LiquidTouchError(
            f"unknown feature source {source!r}; choose one of {', '.join(SOURCES)}"
        )
    check_signal_options(lowpass_hz, n_markers)
    fit = FitSettings() if fit_settings is None else fit_settings
    if not isinstance(fit, FitSettings):
        raise LiquidTouchError(f"fit_settings must be a FitSettings, got {type(fit).__name__}")
    if source != "gelsight":
        if lowpass_hz is None:
            raise LiquidTouchError("the wrench source needs a low-pass cut-off (lowpass_hz)")
        return {"source": source, "lowpass_hz": float(lowpass_hz), "fit": fit.to_dict()}
    if isinstance(sensors, str):
        sensors = [sensors]
    return {
        "source": source,
        "lowpass_hz": None if lowpass_hz is None else float(lowpass_hz),
        "n_markers": int(n_markers),
        "sensors": None if sensors is None else sorted(set(sensors)),
        "fit": fit.to_dict(),
        **({} if check_tracking(tracking) == DEFAULT_TRACKING else {"tracking": tracking}),
    }


def settings_text(settings: dict[str, object]) -> str:
    """``settings`` (:func:`feature_settings`'s) as a table's ``extraction_settings`` cell:
    compact JSON, keys sorted."""
    return json.dumps(settings, sort_keys=True, separators=(",", ":"))


def _fit_settings(settings: dict[str, object]):

    fit = dict(settings["fit"])
    return FitSettings(**{**fit, "band_hz": tuple(fit["band_hz"])})


def trial_features(
    trial_dir: str | Path, source: str = "gelsight", **settings: object
) -> dict[str, float]:
    """Features of one trial directory: the oscillation fit of its tactile (or wrist) signal.

    ``settings``: the keyword arguments of :func:`feature_settings` (defaults: the
    paper's extraction and fit).
    """

    chosen = feature_settings(source, **settings)
    fit = _fit_settings(chosen)
    if source != "gelsight":
        return wrench_features(
            trial_dir,
            lowpass_hz=chosen["lowpass_hz"],
            fit_settings=fit,
            best_effort=source == "wrench-best-effort",
        )
    return extract_trial(
        trial_dir,
        lowpass_hz=chosen["lowpass_hz"],
        n_markers=chosen["n_markers"],
        sensors=chosen["sensors"],
        fit_settings=fit,
        tracking=chosen.get("tracking", DEFAULT_TRACKING),
    )


def _fingerprint(trial_dir: Path, source: str, settings: dict[str, object] | None = None) -> str:
    """Hash of everything the trial's features depend on (file sizes and mtimes, settings)."""
    meta = read_trial_meta(trial_dir)
    recorded = [*meta.sensors, *([meta.tracks] if meta.tracks else [])]
    inputs = [META_NAME, *(recorded if source == "gelsight" else [WRENCH_NAME])]
    chosen = feature_settings(source) if settings is None else settings
    digest = hashlib.sha256(
        f"v{FEATURES_VERSION}:{source}:fps={meta.fps!r}:"
        f"{json.dumps(chosen, sort_keys=True)}".encode()
    )
    for name in inputs:
        path = trial_dir / name
        stat = path.stat() if path.exists() else None
        digest.update(
            f"|{name}:{stat.st_size if stat else -1}:{stat.st_mtime_ns if stat else -1}".encode()
        )
        if stat is not None and path.is_dir():  # an image folder: every file in it counts
            for entry in sorted(path.iterdir()):
                st = entry.stat() if entry.exists() else entry.lstat()  # a dangling link
                digest.update(f"|{name}/{entry.name}:{st.st_size}:{st.st_mtime_ns}".encode())
    return digest.hexdigest()


def _safe_run(
    trial_dir: str, source: str, settings: dict[str, object] | None = None
) -> dict[str, object]:
    """Worker: features of one trial, or the error that stopped it (never raises).

    Only the settings that differ from the defaults are passed on to
    :func:`trial_features`.
    """
    chosen = feature_settings(source) if settings is None else settings
    defaults = feature_settings(source)
    changed = {k for k, v in chosen.items() if v != defaults[k]}
    kwargs: dict[str, object] = {k: chosen[k] for k in changed - {"fit"}}
    done = {"liquidtouch_version": __version__}
    try:
        if "fit" in changed:
            kwargs["fit_settings"] = _fit_settings(chosen)
        features = trial_features(trial_dir, source, **kwargs)
        return {"features": features, "error": None, "cacheable": True, **done}
    except LiquidTouchError as exc:
        return {"features": {}, "error": str(exc), "cacheable": True, **done}
    except Exception as exc:  # a batch survives any one bad trial
        error = f"{type(exc).__name__}: {exc}"
        return {"features": {}, "error": error, "cacheable": False, **done}


def _cache_file(root: Path, trial: str, source: str) -> Path:
    safe = trial.replace("/", "__")
    return root / CACHE_DIR / source / f"{safe}.json"


def _read_cache(path: Path, fingerprint: str) -> dict[str, object] | None:
    """The cache entry at ``path`` if it is one for ``fingerprint``; ``None`` (the trial is
    computed again) when it is missing, stale, or not what :func:`_safe_run` writes: the
    cache is read like any input."""
    try:
        entry = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError):  # unreadable or damaged: recompute
        return None
    if not isinstance(entry, dict) or entry.get("fingerprint") != fingerprint:
        return None
    if not _valid_entry(entry):
        logger.warning("cache entry %s is damaged; the trial is computed again", path)
        return None
    return entry


def _valid_entry(entry: dict[str, object]) -> bool:
    """Whether a cache entry holds what :func:`_safe_run` writes: ``features`` a dict of
    names to scalars, the table's numeric columns numbers (a good trial's
    :data:`FEATURE_COLUMNS` among them), ``error`` and the version text."""
    features, error = entry.get("features"), entry.get("error")
    if not isinstance(features, dict) or not (error is None or isinstance(error, str)):
        return False
    if not isinstance(entry.get("liquidtouch_version", ""), str):
        return False
    for name, value in features.items():
        if not isinstance(name, str) or not isinstance(value, str | float | int | None):
            return False
        numeric = name in FEATURE_ROW_COLUMNS and name != "model"
        if numeric and not (value is None or _is_number(value)):
            return False
    return error is not None or all(_is_number(features.get(n)) for n in FEATURE_COLUMNS)


def _is_number(value: object) -> bool:
    """A real number (NaN included: a feature the fit did not give), not a bool."""
    return isinstance(value, float | int) and not isinstance(value, bool)


def cache_trial_features(
    dataset: str | Path, trial: str, sources: tuple[str, ...] = ("gelsight",)
) -> None:
    """Compute one trial's features (default settings) into the dataset's cache; never raises.

    The very entries :func:`extract_features` would compute for ``trial`` (same
    fingerprint, same cache file), so that it reads them afterwards instead: a
    simulation worker extracts each trial right after writing it
    (``simulate_dataset(after_trial=...)``), while its videos are in the page
    cache and with no separate extraction pass to wait for.
    """
    root = Path(dataset)
    tdir = trial_path(root, trial)
    for source in sources:
        settings = feature_settings(source)
        try:
            fingerprint = _fingerprint(tdir, source, settings)
        except LiquidTouchError:  # extract_features reports it
            return
        result = _safe_run(str(tdir), source, settings)
        if result.pop("cacheable"):
            atomic.write_json(
                _cache_file(root, trial, source), {"fingerprint": fingerprint, **result}
            )


def extract_features(
    dataset: str | Path,
    *,
    out: str | Path | None = None,
    write: bool = True,
    jobs: int = 1,
    dask_address: str | None = None,
    source: str = "gelsight",
    progress: bool = True,
    on_trial: Callable[[str, dict[str, object]], None] | None = None,
    lowpass_hz: float | None = DEFAULT_LOWPASS_HZ,
    n_markers: int = DEFAULT_N_MARKERS,
    sensors: list[str] | tuple[str, ...] | None = None,
    fit_settings: FitSettings | None = None,
    tracking: str = DEFAULT_TRACKING,
) -> pd.DataFrame:
    """Extract features of every trial of ``dataset``; write ``out`` (default ``features.csv``).

    Returns the table: the manifest's columns, then :data:`FEATURE_ROW_COLUMNS`,
    then ``error`` (empty for good trials), then :data:`PROVENANCE_COLUMNS`; its
    ``attrs`` hold ``n_computed`` and ``n_cached`` (trials computed now, read from
    the cache) and ``settings`` (:func:`feature_settings`). With
    ``write=False`` no table is written (the per-trial cache is still read and
    filled). ``on_trial(trial, result)`` is called as each trial is computed (not
    for trials read from the cache; used by tests and progress reports).
    ``lowpass_hz``, ``n_markers``, ``sensors``, ``tracking`` and ``fit_settings``
    (:class:`~liquidtouch.extraction.fit_settings.FitSettings`) are the extraction and fit
    settings (:func:`feature_settings`); they are checked before any work, and a
    trial cached under other settings is recomputed.
    """
    settings = feature_settings(
        source,
        lowpass_hz=lowpass_hz,
        n_markers=n_markers,
        sensors=sensors,
        fit_settings=fit_settings,
        tracking=tracking,
    )
    settings_json = settings_text(settings)
    root = Path(dataset)
    manifest = read_manifest(root)
    results: dict[str, dict[str, object]] = {}
    todo: dict[str, tuple[Path, str]] = {}
    for trial in manifest["trial"]:
        tdir = trial_path(root, trial)
        try:
            fingerprint = _fingerprint(tdir, source, settings)
        except LiquidTouchError as exc:
            logger.info("trial %s: %s", trial, exc)  # in the table's error column
            results[trial] = {"features": {}, "error": str(exc)}
            continue
        cached = _read_cache(_cache_file(root, trial, source), fingerprint)
        if cached is not None:
            logger.debug("trial %s: cached", trial)
            results[trial] = cached
        else:
            todo[trial] = (tdir, fingerprint)

    if todo:
        with (
            open_executor(jobs, dask_address, n_tasks=len(todo)) as pool,
            progress_bar(f"features ({source})", len(todo), enabled=progress) as advance,
        ):
            tasks = {trial: (str(tdir), source, settings) for trial, (tdir, _) in todo.items()}
            for trial, future in run_each(pool, _safe_run, tasks):
                result = future.result()
                if result.pop("cacheable"):
                    entry = {"fingerprint": todo[trial][1], **result}
                    atomic.write_json(_cache_file(root, trial, source), entry)
                results[trial] = result
                if result["error"]:
                    # info: the error column carries it, and the caller reports it (once)
                    logger.info("trial %s failed: %s", trial, result["error"])
                else:
                    logger.info("trial %s extracted", trial)
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
        row["liquidtouch_version"] = result.get("liquidtouch_version") or __version__
        row[SETTINGS_COLUMN] = settings_json
        rows.append(row)
    table = pd.DataFrame(rows)
    table.attrs.update(
        n_computed=len(todo),
        n_cached=sum(trial not in todo and "fingerprint" in results[trial] for trial in results),
        settings=settings,
    )
    if write:
        out_path = Path(out) if out is not None else root / FEATURES_NAME
        atomic.write_text(out_path, table.to_csv(index=False))
        logger.info("wrote %s (%d trials, %d computed)", out_path, len(table), len(todo))
    return table
