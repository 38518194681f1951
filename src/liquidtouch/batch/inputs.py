"""What ``predict`` reads: a features CSV, a dataset, a trial directory or a video.

Anything that is not already a (λ, ω) table goes through extraction first, so
this module sits above the pipeline; the model layer never imports it.
"""

from __future__ import annotations

import os
from pathlib import Path

import pandas as pd

from liquidtouch.batch.features import extract_features
from liquidtouch.errors import TableError
from liquidtouch.extraction import extract
from liquidtouch.io.dataset import MANIFEST_NAME, META_NAME
from liquidtouch.io.frames import VIDEO_SUFFIXES
from liquidtouch.io.tables import feature_matrix, read_table


def read_prediction_input(path: str | os.PathLike[str]) -> pd.DataFrame:
    """The table of trials to predict for, with ``decay_rate`` and ``angular_frequency``.

    ``path`` is a features CSV, a dataset directory (``manifest.csv``: its
    features are extracted, cached, into ``DATASET/features.csv``), a trial
    directory (``meta.json``) or a video file (one sensor).
    """
    path = Path(path)
    if path.is_dir() and (path / MANIFEST_NAME).is_file():
        table = extract_features(path)
        failed = table["error"].astype(str) != ""
        if failed.all():
            raise TableError(f"no trial of {path} could be extracted: {table['error'].iloc[0]}")
        table = table[~failed].reset_index(drop=True)
    elif (path.is_dir() and (path / META_NAME).is_file()) or path.suffix.lower() in VIDEO_SUFFIXES:
        table = pd.DataFrame([{"trial": str(path), **extract(path).to_dict()}])
    elif path.is_dir():
        raise TableError(
            f"{path} is neither a dataset ({MANIFEST_NAME}) nor a trial directory ({META_NAME})"
        )
    else:
        table = read_table(path)
    feature_matrix(table)
    return table
