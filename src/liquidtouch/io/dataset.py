"""Trial and dataset formats: every trial-directory file name and schema in one place.

A *trial directory* holds ``meta.json`` and one video (or image folder) per
sensor; simulated trials add ``force.csv``, ``wrench.csv`` and
``truth_tracks.npz``. A *dataset directory* holds ``manifest.csv`` and the trial
directories, and ``features.csv`` once features are extracted. The formats are
documented in ``docs/formats.md``.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable
from pathlib import Path

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, StrictInt, ValidationError

from liquidtouch._core import atomic
from liquidtouch.errors import DatasetError

__all__ = [
    "FEATURES_NAME",
    "FORCE_CHANNELS",
    "FORCE_COLUMNS",
    "FORCE_NAME",
    "LABEL_COLUMNS",
    "MANIFEST_NAME",
    "META_NAME",
    "NUMERIC_LABELS",
    "TRIAL_FORMAT_VERSION",
    "TRUTH_COLUMNS",
    "TRUTH_TRACKS_NAME",
    "WRENCH_COLUMNS",
    "WRENCH_NAME",
    "TrialMeta",
    "read_manifest",
    "read_trial_meta",
    "read_wrench_csv",
    "trial_path",
    "trial_sensor_starts",
    "write_manifest",
    "write_trial_meta",
]

META_NAME = "meta.json"
MANIFEST_NAME = "manifest.csv"
FEATURES_NAME = "features.csv"
FORCE_NAME = "force.csv"
WRENCH_NAME = "wrench.csv"
TRUTH_TRACKS_NAME = "truth_tracks.npz"
TRIAL_FORMAT_VERSION = 1

# force.csv: time [s], per-finger shear force [N] and twist moment [N·mm]
FORCE_COLUMNS = (
    "t_s",
    "left_fx_n",
    "left_fy_n",
    "left_mz_nmm",
    "right_fx_n",
    "right_fy_n",
    "right_mz_nmm",
)
# wrench.csv: time [s], then the wrist force [N] and torque [N·m] channels
WRENCH_COLUMNS = ("fx_n", "fy_n", "fz_n", "tx_nm", "ty_nm", "tz_nm")
FORCE_CHANNELS = WRENCH_COLUMNS[:3]

LABEL_COLUMNS = (
    "liquid",
    "container",
    "height_mm",
    "sugar_concentration",
    "viscosity_cst",
    "log10_viscosity_cst",
    "temperature_c",
)
TRUTH_COLUMNS = ("true_decay_rate", "true_angular_frequency")


class TrialMeta(BaseModel):
    """Contents of a trial's ``meta.json``.

    Labels are ``None`` when unknown (a real recording). Simulated trials add
    the ground truth ``true_decay_rate`` [1/s] and ``true_angular_frequency``
    [rad/s] (small-amplitude slow mode) and may carry extra simulator fields.
    """

    model_config = ConfigDict(extra="allow")

    format_version: StrictInt = TRIAL_FORMAT_VERSION
    fps: float = Field(gt=0, allow_inf_nan=False)
    sensors: list[str] = []
    liquid: str | None = None
    container: str | None = None
    height_mm: float | None = None
    sugar_concentration: float | None = None
    viscosity_cst: float | None = None
    log10_viscosity_cst: float | None = None
    temperature_c: float | None = None
    true_decay_rate: float | None = None
    true_angular_frequency: float | None = None
    tracks: str | None = None  # imported marker tracks (tracks.npz), used instead of videos
    # a recording's {sensor: time [s] of its first frame on the clock all sensors share}
    sensor_start_s: dict[str, float | None] | None = None

    def labels(self) -> dict[str, object]:
        """The label and ground-truth columns of this trial (``None`` when unknown)."""
        return {name: getattr(self, name) for name in (*LABEL_COLUMNS, *TRUTH_COLUMNS)}


def read_trial_meta(trial_dir: str | Path) -> TrialMeta:
    """Read and validate ``trial_dir/meta.json``; raise :class:`DatasetError` if unusable."""
    path = Path(trial_dir) / META_NAME
    if not path.is_file():
        raise DatasetError(f"{trial_dir} is not a trial directory: {META_NAME} is missing")
    try:
        meta = TrialMeta.model_validate(json.loads(path.read_text(encoding="utf-8")))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise DatasetError(f"{path} is not valid JSON: {exc}") from None
    except RecursionError:
        raise DatasetError(f"{path} is nested too deeply to be a trial's meta.json") from None
    except OSError as exc:
        raise DatasetError(f"cannot read {path}: {exc.strerror or exc}") from None
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(p) for p in first["loc"]) or "(root)"
        raise DatasetError(f"{path}: field {where}: {first['msg']}") from None
    if meta.format_version > TRIAL_FORMAT_VERSION:
        raise DatasetError(
            f"{path} has format version {meta.format_version}; this liquidtouch reads "
            f"up to {TRIAL_FORMAT_VERSION} (upgrade liquidtouch)"
        )
    root = Path(trial_dir).resolve()
    for name in [*meta.sensors, *([meta.tracks] if meta.tracks else [])]:
        resolved = (root / name).resolve()  # a symlink must not lead outside the trial either
        if Path(name).is_absolute() or ".." in Path(name).parts or root not in resolved.parents:
            raise DatasetError(
                f"{path}: sensor video {name!r} must stay inside the trial directory"
            )
    return meta


def trial_sensor_starts(
    paths: str | os.PathLike[str] | Iterable[str | os.PathLike[str]],
) -> dict[str, float]:
    """``sensor_start_s`` of the trial when ``paths`` is one trial directory, else ``{}``.

    The recorder stamps every sensor on one clock and stores when each sensor's
    first frame came; the tactile signal aligns the sensors with it
    (:attr:`~liquidtouch.tracking.tracks.MarkerTracks.start_s`).
    """
    items = [paths] if isinstance(paths, str | os.PathLike) else list(paths)
    if len(items) != 1 or not isinstance(items[0], str | os.PathLike):
        return {}
    trial = Path(items[0])
    if not (trial.is_dir() and (trial / META_NAME).is_file()):
        return {}
    starts = read_trial_meta(trial).sensor_start_s or {}
    return {name: float(t) for name, t in starts.items() if t is not None}


def write_trial_meta(trial_dir: str | Path, meta: TrialMeta) -> Path:
    """Atomically write ``meta`` to ``trial_dir/meta.json``; return the path."""
    path = Path(trial_dir) / META_NAME
    atomic.write_json(path, meta.model_dump(mode="json"))
    return path


def read_wrench_csv(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Read ``wrench.csv``: time ``t_s`` [s] and the force channels [N] as an (n, 3) array."""
    import pandas as pd

    path = Path(path)
    if not path.is_file():
        raise DatasetError(f"{path} not found: the trial has no wrist force-torque recording")
    try:
        table = pd.read_csv(path)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise DatasetError(f"{path} is not a readable CSV: {exc}") from None
    missing = [c for c in ("t_s", *FORCE_CHANNELS) if c not in table.columns]
    if missing:
        raise DatasetError(f"{path} lacks column(s) {', '.join(missing)}")
    values = table[["t_s", *FORCE_CHANNELS]].apply(pd.to_numeric, errors="coerce").to_numpy(float)
    if not np.isfinite(values).all():
        raise DatasetError(f"{path} holds text, NaN or infinite values")
    return values[:, 0], values[:, 1:]


NUMERIC_LABELS = (
    "height_mm",
    "sugar_concentration",
    "viscosity_cst",
    "log10_viscosity_cst",
    "temperature_c",
    *TRUTH_COLUMNS,
)


def trial_path(root: str | Path, relative: str) -> Path:
    """Resolve a manifest's ``trial`` entry under ``root``; refuse paths that leave it."""
    root = Path(root).resolve()
    rel = Path(str(relative))
    if not str(relative).strip() or rel.is_absolute() or ".." in rel.parts:
        raise DatasetError(f"trial path {relative!r} must be a relative path inside {root}")
    path = (root / rel).resolve()
    if root not in path.parents and path != root:
        raise DatasetError(f"trial path {relative!r} leaves the dataset root {root}")
    return path


def write_manifest(root: str | Path, rows: list[dict[str, object]]) -> Path:
    """Atomically write ``root/manifest.csv``: one row per trial, ``trial`` first.

    Each row holds ``trial`` (path relative to ``root``) and any label columns.
    """
    import pandas as pd

    if not rows:
        raise DatasetError("a dataset needs at least one trial")
    table = pd.DataFrame(rows)
    if "trial" not in table.columns:
        raise DatasetError("every manifest row needs a 'trial' entry")
    for rel in table["trial"]:
        trial_path(root, rel)
    table = table[["trial", *[c for c in table.columns if c != "trial"]]]
    path = Path(root) / MANIFEST_NAME
    atomic.write_text(path, table.to_csv(index=False))
    return path


def read_manifest(root: str | Path):
    """Read and validate ``root/manifest.csv``; return it as a pandas DataFrame.

    Checks: the file exists and parses, a ``trial`` column, unique trial paths
    that stay inside ``root``, numeric label columns that are numeric.
    """
    import pandas as pd

    root = Path(root)
    path = root / MANIFEST_NAME
    if not path.is_file():
        raise DatasetError(f"{root} is not a dataset directory: {MANIFEST_NAME} is missing")
    try:
        table = pd.read_csv(path)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise DatasetError(f"{path} is not a readable CSV: {exc}") from None
    if "trial" not in table.columns:
        raise DatasetError(f"{path} has no 'trial' column (columns: {', '.join(table.columns)})")
    if table.empty:
        raise DatasetError(f"{path} lists no trials")
    table["trial"] = table["trial"].astype(str)
    duplicated = table["trial"][table["trial"].duplicated()]
    if len(duplicated):
        raise DatasetError(f"{path} lists trial {duplicated.iloc[0]!r} twice")
    for rel in table["trial"]:
        trial_path(root, rel)
    for column in NUMERIC_LABELS:
        if column in table.columns:
            values = pd.to_numeric(table[column], errors="coerce")
            bad = values.isna() & table[column].notna()
            if bad.any():
                row = int(bad.idxmax())
                raise DatasetError(
                    f"{path}: column {column} must be numeric; row {row + 2} has "
                    f"{table[column][row]!r}"
                )
            table[column] = values
    return table
