"""Which gel a video shows, and its tracker: printed markers, or the gel's own image (flow).

A marker gel's printed dots are dark: the ink lets through ~a fifth of the light, so a
marker's peak darkness ``1 − I / background`` is ~0.6 on the real GelSight Mini recording
(``docs/real_data.md``) and ~0.7 on the simulator's marker gels.
A markerless gel has no such blobs; the detector still finds the grains of a fine texture
(an embossed label), but their darkness is ~0.1. A first frame with at least
:data:`~liquidtouch.tracking.track.MIN_MARKERS` detections whose median darkness reaches
:data:`MIN_MARKER_DARKNESS` is a marker gel; anything else is tracked by flow
(:mod:`liquidtouch.tracking.flow`). ``tracking="markers"`` or ``"flow"`` forces the choice.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterable

import numpy as np

from liquidtouch.errors import MarkerError
from liquidtouch.tracking.detect import as_grey, detect_markers
from liquidtouch.tracking.flow import FlowTracker, track_flow
from liquidtouch.tracking.track import MIN_MARKERS, MarkerTracker
from liquidtouch.tracking.tracks import MarkerTracks, track_markers

__all__ = [
    "DEFAULT_TRACKING",
    "MIN_MARKER_DARKNESS",
    "TRACKING_CHOICES",
    "check_tracking",
    "gel_tracker",
    "gel_tracking",
    "track_gel",
]

#: ``auto`` finds the gel's kind from the first frame; ``markers`` and ``flow`` force it
TRACKING_CHOICES = ("auto", "markers", "flow")
DEFAULT_TRACKING = "auto"
#: median peak darkness of the first frame's blobs from which they are printed markers:
#: half the real GelSight Mini's (0.6), three times a fine texture's grains (0.1)
MIN_MARKER_DARKNESS = 0.3


def check_tracking(tracking: str) -> str:
    """``tracking`` if it is one of :data:`TRACKING_CHOICES`; :class:`MarkerError` otherwise."""
    if tracking not in TRACKING_CHOICES:
        raise MarkerError(
            f"tracking must be one of {', '.join(TRACKING_CHOICES)}, got {tracking!r}"
        )
    return tracking


def gel_tracking(image: np.ndarray, tracking: str = DEFAULT_TRACKING) -> str:
    """``"markers"`` or ``"flow"``: how to track a video whose first frame is ``image``."""
    if check_tracking(tracking) != "auto":
        return tracking
    found = detect_markers(as_grey(image))
    printed = (
        len(found.positions) >= MIN_MARKERS
        and float(np.median(found.peak_darkness)) >= MIN_MARKER_DARKNESS
    )
    return "markers" if printed else "flow"


def gel_tracker(
    image: np.ndarray, tracking: str = DEFAULT_TRACKING
) -> tuple[MarkerTracker | FlowTracker, np.ndarray]:
    """A tracker started on the first frame ``image``, and the first frame's points (N, 2) [px].

    ``step`` it with the next frames; its ``tracking`` attribute says which kind it is
    (``"markers"`` or ``"flow"``).
    """
    kind = gel_tracking(image, tracking)
    tracker = MarkerTracker() if kind == "markers" else FlowTracker()
    first = tracker.start(image).copy()
    tracker.tracking = kind
    return tracker, first


def track_gel(
    frames: Iterable[tuple[float, np.ndarray]],
    sensor: str = "sensor",
    *,
    tracking: str = DEFAULT_TRACKING,
    on_frame: Callable[[int], None] | None = None,
) -> MarkerTracks:
    """Tracks of one sensor's ``frames``: markers or flow, found from the first frame.

    The result's ``tracking`` says which was used. Errors as :func:`track_markers` and
    :func:`~liquidtouch.tracking.flow.track_flow` (a markerless image with too little
    texture raises :class:`~liquidtouch.tracking.flow.TextureError`).
    """
    check_tracking(tracking)
    frames = iter(frames)
    first = list(itertools.islice(frames, 1))
    kind = tracking
    if tracking == "auto" and first:
        try:
            image = first[0][1]
        except (TypeError, IndexError):
            image = None  # the tracker reports the malformed frame
        kind = "markers" if image is None else gel_tracking(image)
    frames = itertools.chain(first, frames)
    if kind == "flow":
        return track_flow(frames, sensor, on_frame=on_frame)
    return track_markers(frames, sensor, on_frame=on_frame)
