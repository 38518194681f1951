"""Markerless (plain) gels in the simulator (issue 39): profiles, and the imprint's texture
moving with the gel's displacement field."""

from __future__ import annotations

import numpy as np
import pytest

from liquidtouch.cli.options import GelChoice, TrackingChoice
from liquidtouch.errors import CatalogueError
from liquidtouch.io.frames import iter_frames
from liquidtouch.sim.gelsight import write_sensor_videos
from liquidtouch.sim.sensors import GELS, get_sensor_profile, with_gel
from liquidtouch.sim.trial import simulate_trial
from liquidtouch.tracking.detect import detect_markers
from liquidtouch.tracking.flow import track_flow
from liquidtouch.tracking.gel import TRACKING_CHOICES, gel_tracking


def test_profiles_and_gel_names() -> None:
    digit = get_sensor_profile("digit")
    assert (digit.width_px, digit.height_px, digit.fps, digit.gel) == (320, 240, 60.0, "plain")
    assert with_gel("mini", "plain") == "mini-plain"
    assert with_gel("mini-plain", "markers") == "mini"
    assert with_gel("digit", "markers") == "digit-markers"
    assert with_gel("digit", None) == "digit" and with_gel("default", "markers") == "default"
    assert get_sensor_profile("default-plain").gel == "plain"
    with pytest.raises(CatalogueError, match="unknown gel"):
        with_gel("mini", "velvet")
    # the command line's choices are the library's
    assert [c.value for c in GelChoice] == list(GELS)
    assert [c.value for c in TrackingChoice] == list(TRACKING_CHOICES)


@pytest.mark.slow(seconds=10)
def test_a_plain_gel_shows_no_markers_and_its_texture_moves_with_the_gel(tmp_path) -> None:
    trial = simulate_trial("water", height_mm=25.0, seed=4, duration_s=4.0)
    rec = write_sensor_videos(trial.loads, tmp_path, sensor="mini-plain", seed=4)
    first = next(iter_frames(tmp_path / "left.mp4"))[1]
    found = detect_markers(first)  # a fine texture's grains at most, never dark dots
    assert len(found.positions) < 4 or np.median(found.peak_darkness) < 0.2
    assert gel_tracking(first) == "flow"
    tracks = track_flow(iter_frames(tmp_path / "left.mp4"), "left")
    assert len(tracks.t) == rec.n_frames
    with np.load(tmp_path / "truth_tracks.npz") as truth:
        markers = truth["positions_px"][0]  # where printed markers would be
    motion = markers - markers[0]
    cells = tracks.displacement
    # the cells that move most follow the markers nearest them (the same field)
    order = np.argsort(-np.nanstd(cells, axis=0).sum(axis=1))[:8]
    gains = []
    for cell in order:
        near = np.argmin(np.hypot(*(markers[0] - tracks.reference[cell]).T))
        for axis in range(2):
            if motion[:, near, axis].std() > 0.2:
                x, y = motion[:, near, axis], cells[:, cell, axis]
                assert np.corrcoef(x, y)[0, 1] > 0.9
                gains.append(np.polyfit(x, y, 1)[0])
    # a cell ~half a marker pitch from its marker sees the Gaussian field a little
    # weaker or stronger: the median gain within 15 %
    assert len(gains) >= 4 and np.median(gains) == pytest.approx(1.0, abs=0.15)
