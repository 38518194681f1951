"""What a recording produced: per-sensor and whole-recording summaries."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["RecordingSummary", "SensorSummary", "summarise"]


@dataclass
class SensorSummary:
    """One sensor's recording: frames, measured rate [Hz], drops, duplicates, times [s]."""

    name: str
    source: str
    frames: int
    measured_fps: float | None
    nominal_fps: float | None
    drops: int
    duplicates: int
    backlog_drops: int
    start_t_s: float | None
    end_t_s: float | None
    file: str | None = None
    reanchored: int = 0
    """Frames whose camera clock stepped back or stood still, timed on arrival instead."""

    @property
    def lost(self) -> int:
        """Frames missing from the recording: camera drops plus encoder backlog drops."""
        return self.drops + self.backlog_drops


@dataclass
class RecordingSummary:
    """What :meth:`Recorder.stop` recorded; ``trial_dir`` is set by :meth:`Recorder.finish`.

    ``start_t_s`` is when capturing started [s, :func:`time.monotonic`], ``duration_s``
    how long it ran [s].
    """

    sensors: dict[str, SensorSummary]
    start_t_s: float
    duration_s: float
    fmt: str
    profile: str
    grey: bool
    trial_dir: Path | None = None
    errors: dict[str, str] = field(default_factory=dict)

    @property
    def warnings(self) -> list[str]:
        """One line per sensor whose camera clock had to be re-anchored (not an error: the
        frames are in order and readable, but their times there are arrival times)."""
        return [
            f"sensor {s.name}: the camera's clock stepped back or stood still; {s.reanchored} "
            "frame(s) timed on arrival instead"
            for s in self.sensors.values()
            if s.reanchored
        ]

    @property
    def fps(self) -> float | None:
        """The measured frame rate over all sensors [Hz] (their mean), for meta.json."""
        rates = [s.measured_fps for s in self.sensors.values() if s.measured_fps]
        return float(np.mean(rates)) if rates else None

    def to_dict(self) -> dict[str, object]:
        out = asdict(self)
        out["trial_dir"] = str(self.trial_dir) if self.trial_dir else None
        out["fps"] = self.fps
        out["warnings"] = self.warnings
        return out


def summarise(
    session: Any,
    pool: Any,
    sensors: Iterable[tuple[str, str, Any]],
    *,
    stopped_at: float,
    fmt: str,
    profile: str,
    grey: bool,
) -> RecordingSummary:
    """The summary of a stopped recording from its capture session and writer pool.

    ``sensors``: ``(name, source, camera)`` per sensor; ``stopped_at``: when capture
    stopped [s, ``time.monotonic``].
    """
    stats = session.stats
    summaries = {}
    for name, source, camera in sensors:
        s = stats[name]
        writer = pool.writers[name]
        summaries[name] = SensorSummary(
            name=name,
            source=source,
            frames=len(writer.times),
            measured_fps=s.measured_fps,
            nominal_fps=camera.nominal_fps,
            drops=s.drops,
            duplicates=s.duplicates,
            backlog_drops=pool.backlog_drops[name],
            start_t_s=s.first_t_s,
            end_t_s=s.last_t_s,
            file=writer.entry,
            reanchored=int(getattr(camera, "reanchors", 0)),
        )
    errors = {name: str(error) for name, error in session.errors.items()}
    for name, error in pool.errors.items():
        errors.setdefault(name, str(error))
    start = session.start_t_s or stopped_at
    return RecordingSummary(
        sensors=summaries,
        start_t_s=start,
        duration_s=stopped_at - start,
        fmt=fmt,
        profile=profile,
        grey=grey,
        errors=errors,
    )
