"""What ``predict`` reads: a features CSV, a dataset, a trial directory or a video.

Anything that is not already a (λ, ω) table goes through extraction first, so
this module sits above the pipeline; the model layer never imports it.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import pandas as pd

from liquidtouch.batch.features import extract_features, feature_settings, settings_text
from liquidtouch.errors import TableError
from liquidtouch.extraction.fit_settings import FitSettings
from liquidtouch.extraction.pipeline import extract
from liquidtouch.io.dataset import MANIFEST_NAME, META_NAME
from liquidtouch.io.frames import VIDEO_SUFFIXES
from liquidtouch.io.tables import SETTINGS_COLUMN, feature_matrix, read_table
from liquidtouch.models.feature_rows import error_messages, failed_rows
from liquidtouch.signal.lowpass import DEFAULT_LOWPASS_HZ
from liquidtouch.signal.tactile import DEFAULT_N_MARKERS


def read_prediction_input(
    path: str | os.PathLike[str],
    *,
    jobs: int = 1,
    dask_address: str | None = None,
    lowpass_hz: float | None = DEFAULT_LOWPASS_HZ,
    n_markers: int = DEFAULT_N_MARKERS,
    sensors: Sequence[str] | None = None,
    fit_settings: FitSettings | None = None,
) -> pd.DataFrame:
    """The table of trials to predict for, with ``decay_rate`` and ``angular_frequency``.

    ``path`` is a features CSV, a dataset directory (``manifest.csv``: its
    features are extracted through the per-trial cache ``DATASET/.cache/``;
    ``DATASET/features.csv`` is neither written nor read), a trial directory
    (``meta.json``) or a video file (one sensor).

    A dataset's trials run on ``jobs`` worker processes, or on the Dask cluster
    at ``dask_address``. ``lowpass_hz`` [Hz], ``n_markers``, ``sensors`` (names;
    None: all) and ``fit_settings`` are the extraction and fit settings of a
    dataset, trial or video (as ``features`` and ``extract`` take them; checked
    before any work, also for a features CSV, which they do not change).

    Every row is kept, including trials whose extraction failed (a non-empty
    ``error``, empty features: :func:`~liquidtouch.models.feature_rows.failed_rows`);
    the other rows' features are validated. Raises :class:`TableError` if no row
    has features.
    """
    settings = {
        "lowpass_hz": lowpass_hz,
        "n_markers": n_markers,
        "sensors": None if sensors is None else list(sensors),
        "fit_settings": fit_settings,
    }
    chosen = feature_settings("gelsight", **settings)  # bad settings fail before any work
    path = Path(path)
    if path.is_dir() and (path / MANIFEST_NAME).is_file():
        table = extract_features(
            path,
            write=False,
            progress=True,
            jobs=jobs,
            dask_address=dask_address,
            **settings,
        )
        failed = failed_rows(table)
        if failed is not None and failed.all():
            raise TableError(f"no trial of {path} could be extracted: {error_messages(table)[0]}")
    elif (path.is_dir() and (path / META_NAME).is_file()) or path.suffix.lower() in VIDEO_SUFFIXES:
        row = {"trial": str(path), **extract(path, **settings).to_dict()}
        table = pd.DataFrame([{**row, SETTINGS_COLUMN: settings_text(chosen)}])
    elif path.is_dir():
        raise TableError(
            f"{path} is neither a dataset ({MANIFEST_NAME}) nor a trial directory ({META_NAME})"
        )
    else:
        table = read_table(path)
    failed = failed_rows(table)
    if failed is not None and failed.all():
        raise TableError(
            f"{path}: the feature extraction of every row failed (non-empty error column); "
            "nothing to predict"
        )
    feature_matrix(table if failed is None else table[~failed])
    return table
