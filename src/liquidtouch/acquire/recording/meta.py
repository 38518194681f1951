"""A recording's meta.json: assembled from the summary, labels and extra fields, validated.

Used by :class:`liquidtouch.acquire.recording.Recorder` (see its module docstring).
"""

from __future__ import annotations

from dataclasses import asdict

from pydantic import ValidationError

from liquidtouch.acquire.recording.summary import RecordingSummary
from liquidtouch.errors import DatasetError, DeviceError
from liquidtouch.io.dataset import TrialMeta
from liquidtouch.io.frame_times import TIMESTAMPS_NAME, VIDEO_TIMESTAMPS_SUFFIX

__all__ = ["RESERVED_META", "build_meta", "check_meta_fields", "validate_meta"]

RESERVED_META = ("format_version", "fps", "sensors", "tracks", "sensor_start_s", "recording")
"""meta.json fields the recorder writes itself (labels and extra_meta cannot set them)."""


def check_meta_fields(fields: dict[str, object], what: str) -> None:
    """:class:`DatasetError` if ``fields`` (labels, extra meta.json fields) set a
    :data:`RESERVED_META` field."""
    clash = [k for k in fields if k in RESERVED_META]
    if clash:
        raise DatasetError(
            f"{what} cannot set {', '.join(clash)}: the recorder writes these meta.json fields"
        )


def validate_meta(meta: dict[str, object]) -> None:
    """:class:`DatasetError` naming the first bad field unless ``meta`` is a valid meta.json."""
    try:
        TrialMeta.model_validate(meta)
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(p) for p in first["loc"]) or "(root)"
        raise DatasetError(f"meta.json field {where}: {first['msg']}") from None


def build_meta(
    summary: RecordingSummary,
    labels: dict[str, object],
    extra_meta: dict[str, object] | None,
    *,
    fmt: str,
    grey: bool,
    profile: str,
) -> dict[str, object]:
    """The validated meta.json of a stopped recording (``extra_meta`` cannot set
    :data:`RESERVED_META`)."""
    extra = dict(extra_meta or {})
    check_meta_fields(extra, "extra_meta")
    sensors = summary.sensors
    meta = {
        "format_version": 1,
        "fps": summary.fps,
        "sensors": [s.file for s in sensors.values()],
        **labels,
        "sensor_start_s": {n: s.start_t_s for n, s in sensors.items()},
        "recording": {
            "clock": "time.monotonic",
            "start_t_s": summary.start_t_s,
            "duration_s": summary.duration_s,
            "format": fmt,
            "grey": grey,
            "profile": profile,
            "timestamps": {
                n: (f"{n}{VIDEO_TIMESTAMPS_SUFFIX}" if fmt == "ffv1" else f"{n}/{TIMESTAMPS_NAME}")
                for n in sensors
            },
            "sensors": {
                n: {k: v for k, v in asdict(s).items() if k not in ("name", "file")}
                for n, s in sensors.items()
            },
        },
        **extra,
    }
    if meta["fps"] is None:
        raise DeviceError("the recording has no measurable frame rate")
    validate_meta(meta)
    return meta
