"""The stream's ring-downs: where each one's signal starts, which segment an update
comes from, the fits of one ring-down (streaming while it is open, final as offline once
its hold ended) and its final estimate (never replaced)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from liquidtouch.errors import LiquidTouchError
from liquidtouch.extraction.fit_settings import FitSettings
from liquidtouch.live.refresh import EDGE_S, MIN_WINDOW_S, Refreshed, fit_ring_down, shared_signal
from liquidtouch.live.updates import LiveUpdate
from liquidtouch.ring_down import Segment
from liquidtouch.signal.tactile import TactileSignal

__all__ = [
    "RingDown",
    "copy_segment",
    "final_fit",
    "mark_segment",
    "signal_start_s",
    "streaming_fit",
]


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


def final_fit(
    tracks: list,
    seg: Segment,
    window_from: float,
    full: TactileSignal,
    options: Mapping[str, object],
    settings: FitSettings,
    *,
    protocol_events: bool,
) -> Refreshed:
    """The final fit of a ring-down whose hold ended (or the stream's last), as offline.

    The stream's only ring-down, to its end and without protocol events, gets exactly
    ``extract``'s fit of the whole signal ``full``; any other is fitted on its own window
    (from ``window_from`` [s] to the segment's end). ``Refreshed.fit`` is ``None`` when it
    is not a ring-down after all (the message says why).
    """
    if not math.isfinite(window_from) and seg.end_s >= full.t[-1] - 1e-9 and not protocol_events:
        try:
            fit = settings.fit(full.t, full.u)
        except LiquidTouchError as exc:
            return Refreshed(full.t, full.u, "decay", seg.start_s, message=str(exc))
        return Refreshed(full.t, full.u, "decay", float(fit.t0), fit)
    to_s = seg.end_s if seg.closed else math.inf
    try:
        sig = shared_signal(tracks, **options, from_s=window_from, to_s=to_s)
        fit, message, _ = fit_ring_down(sig.t, sig.u, seg.start_s, seg.end_s, settings, final=True)
    except LiquidTouchError as exc:
        sig, fit, message = full, None, str(exc)
    return Refreshed(sig.t, sig.u, "decay", seg.start_s, fit, message)


def streaming_fit(
    tracks: list,
    start_s: float,
    window_from: float,
    options: Mapping[str, object],
    settings: FitSettings,
    warm_start: tuple[float, float] | None,
) -> Refreshed:
    """The streaming estimate of the open ring-down starting at ``start_s`` [s]: its signal
    from ``window_from`` [s] to the trusted edge, fitted from ``warm_start`` (λ, ω)."""
    try:
        sig = shared_signal(tracks, **options, from_s=window_from)
    except LiquidTouchError as exc:
        return Refreshed(np.zeros(0), np.zeros(0), "push", start_s, message=str(exc))
    end = float(sig.t[-1]) - EDGE_S
    if end - start_s < MIN_WINDOW_S:
        return Refreshed(sig.t, sig.u, "push", start_s, message="the push is under way")
    fit, message, no_osc = fit_ring_down(
        sig.t, sig.u, start_s, end, settings, final=False, warm_start=warm_start
    )
    return Refreshed(sig.t, sig.u, "decay", start_s, fit, message, no_osc)
