"""The stream's ring-downs: where each one's signal starts, which segment an update
comes from, and the final estimate of a ring-down whose hold ended (never replaced)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from liquidtouch.live.refresh import EDGE_S
from liquidtouch.live.updates import LiveUpdate
from liquidtouch.ring_down import Segment

__all__ = ["RingDown", "copy_segment", "mark_segment", "signal_start_s"]


@dataclass
class RingDown:
    """A ring-down whose hold ended (or the stream's last, at its end): its final estimate."""

    index: int
    start_s: float
    end_s: float
    update: LiveUpdate

    def summary(self, origin_s: float) -> dict[str, object]:
        """JSON-ready: the segment (times since the first frame [s]) and its λ, ω."""
        u = self.update
        return {
            "segment": self.index,
            "start_s": _json(self.start_s - origin_s),
            "end_s": _json(self.end_s - origin_s),
            "decay_rate": _json(u.decay_rate),
            "decay_rate_std": _json(u.decay_rate_std),
            "angular_frequency": _json(u.angular_frequency),
            "angular_frequency_std": _json(u.angular_frequency_std),
            "window_s": _json(u.window_s),
            "message": u.message,
        }


def _json(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None


def signal_start_s(segments: list[Segment], i: int) -> float:
    """Where the signal of ring-down ``segments[i]`` starts [s]: after the stretch before its
    push (the whole stream when its push is the first transient)."""
    before = segments[i - 1] if i >= 1 and segments[i - 1].kind == "push" else None
    j = i - 2 if before is not None else i - 1
    if j < 0 or segments[j].kind == "rest":
        return -math.inf
    return before.start_s if before is not None else segments[i].start_s - EDGE_S


def copy_segment(update: LiveUpdate, other: LiveUpdate) -> None:
    update.segment, update.segment_final = other.segment, other.segment_final
    update.segment_start_s, update.segment_end_s = other.segment_start_s, other.segment_end_s


def mark_segment(update: LiveUpdate, index: int, seg: Segment, *, final: bool) -> None:
    update.segment = index
    update.segment_start_s, update.segment_end_s = seg.start_s, seg.end_s
    update.segment_final = final
