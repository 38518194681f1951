"""What ``predict`` reads: a features CSV, a dataset, a trial directory or a video.

Anything that is not already a (λ, ω) table goes through extraction first, so
this module sits above the pipeline; the model layer never imports it.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pandas as pd

from liquidtouch.batch.features import extract_features
from liquidtouch.errors import TableError
from liquidtouch.extraction import extract
from liquidtouch.io.dataset import MANIFEST_NAME, META_NAME
from liquidtouch.io.frames import VIDEO_SUFFIXES
from liquidtouch.io.tables import feature_matrix, read_table
from liquidtouch.models.feature_rows import error_messages, failed_rows


def read_prediction_input(path: str | os.PathLike[str]) -> pd.DataFrame:
    """The table of trials to predict for, with ``decay_rate`` and ``angular_frequency``.

    ``path`` is a features CSV, a dataset directory (``manifest.csv``: its
    features are extracted through the per-trial cache ``DATASET/.cache/``;
    ``DATASET/features.csv`` is neither written nor read), a trial directory
    (``meta.json``) or a video file (one sensor).

    Every row is kept, including trials whose extraction failed (a non-empty
    ``error``, empty features: :func:`~liquidtouch.models.feature_rows.failed_rows`);
    the other rows' features are validated. Raises :class:`TableError` if no row
    has features.
    """
    path = Path(path)
    if path.is_dir() and (path / MANIFEST_NAME).is_file():
        table = extract_features(path, write=False, progress=sys.stderr.isatty())
        failed = failed_rows(table)
        if failed is not None and failed.all():
            raise TableError(f"no trial of {path} could be extracted: {error_messages(table)[0]}")
    elif (path.is_dir() and (path / META_NAME).is_file()) or path.suffix.lower() in VIDEO_SUFFIXES:
        table = pd.DataFrame([{"trial": str(path), **extract(path).to_dict()}])
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
