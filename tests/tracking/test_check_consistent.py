"""check_consistent: the videos of one trial are one recording (rate and time span, not counts)."""

from __future__ import annotations

import numpy as np
import pytest

from liquidtouch.errors import VideoError
from liquidtouch.tracking.clock import check_consistent
from liquidtouch.tracking.tracks import MarkerTracks


def _tracks(t, sensor, start_s=0.0):
    n = 4
    positions = np.zeros((len(t), n, 2))
    return MarkerTracks(
        np.asarray(t),
        positions,
        np.ones((len(t), n), bool),
        np.zeros((n, 2)),
        sensor,
        start_s=start_s,
    )


def _drop(t, every):
    keep = np.ones(len(t), bool)
    keep[every::every] = False
    keep[-1] = True
    return t[keep]


def test_independent_drops_are_accepted():
    t = np.arange(390) / 29.55
    left, right = _tracks(_drop(t, 17), "left"), _tracks(_drop(t, 29), "right")
    assert len(right.t) - len(left.t) > 5  # far more than the ±1 frames once required
    check_consistent([left, right])
    # one recording on one clock: the right camera opened a frame later
    check_consistent([_tracks(t, "left", 50.0), _tracks(t[:-1], "right", 50.0 + t[1])])


@pytest.mark.parametrize(
    ("right", "match"),
    [
        (_tracks(np.arange(390) / 25.0, "right"), "differ in frame rate"),  # another camera
        (_tracks(np.arange(300) / 29.55, "right"), "differ in length"),  # 10.1 s of 13.2 s
        (_tracks(np.arange(390) / 29.55, "right", 3.0), "differ in length"),  # 3 s later
    ],
)
def test_different_recordings_are_refused(right, match):
    left = _tracks(np.arange(390) / 29.55, "left")
    with pytest.raises(VideoError, match=match):
        check_consistent([left, right])
