"""Trial and dataset formats (DESIGN.md, "Formats").

A *trial directory* holds ``meta.json`` and one video per sensor. This module
reads and validates ``meta.json``; dataset manifests come with the experiments.
"""

from __future__ import annotations

import json
from pathlib import Path

from pydantic import BaseModel, ConfigDict, ValidationError

from liquidtouch import atomic
from liquidtouch.errors import DatasetError

META_NAME = "meta.json"
TRIAL_FORMAT_VERSION = 1

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

    format_version: int = TRIAL_FORMAT_VERSION
    fps: float
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
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(p) for p in first["loc"]) or "(root)"
        raise DatasetError(f"{path}: field {where}: {first['msg']}") from None
    if meta.format_version > TRIAL_FORMAT_VERSION:
        raise DatasetError(
            f"{path} has format version {meta.format_version}; this liquidtouch reads "
            f"up to {TRIAL_FORMAT_VERSION} (upgrade liquidtouch)"
        )
    for name in meta.sensors:
        if Path(name).is_absolute() or ".." in Path(name).parts:
            raise DatasetError(
                f"{path}: sensor video {name!r} must stay inside the trial directory"
            )
    return meta


def write_trial_meta(trial_dir: str | Path, meta: TrialMeta) -> Path:
    """Atomically write ``meta`` to ``trial_dir/meta.json``; return the path."""
    path = Path(trial_dir) / META_NAME
    atomic.write_json(path, meta.model_dump(mode="json"))
    return path
