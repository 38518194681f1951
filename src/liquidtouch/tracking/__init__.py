"""Marker tracking: GelSight frames in, :class:`MarkerTracks` out.

``detect`` finds the dark printed markers in a frame (no grid size needed),
``centroid`` refines them to sub-pixel centroids, ``track`` follows each marker
from frame to frame, and ``tracks`` holds the result: positions [px] (T × N × 2)
with a validity mask (lost markers are flagged, never invented). A gel without markers
is tracked by ``flow`` (its own image, pooled over a grid of cells, gives the same
tracks); ``gel`` tells the two apart from the first frame.
"""

from liquidtouch.tracking.detect import detect_markers
from liquidtouch.tracking.flow import TextureError, track_flow
from liquidtouch.tracking.gel import track_gel
from liquidtouch.tracking.tracks import MarkerTracks, track_markers

__all__ = [
    "MarkerTracks",
    "TextureError",
    "detect_markers",
    "track_flow",
    "track_gel",
    "track_markers",
]
