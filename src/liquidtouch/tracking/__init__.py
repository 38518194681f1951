"""Marker tracking: GelSight frames in, :class:`MarkerTracks` out.

``detect`` finds the dark printed markers in a frame (no grid size needed),
``centroid`` refines them to sub-pixel centroids, ``track`` follows each marker
from frame to frame, and ``tracks`` holds the result: positions [px] (T × N × 2)
with a validity mask (lost markers are flagged, never invented).
"""

from liquidtouch.tracking.detect import detect_markers
from liquidtouch.tracking.tracks import MarkerTracks, track_markers

__all__ = ["MarkerTracks", "detect_markers", "track_markers"]
