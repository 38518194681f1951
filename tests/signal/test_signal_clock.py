"""The signal's clock: the fitted frame period, and sensors aligned on the trial's shared clock."""

from __future__ import annotations

import numpy as np
import pytest

from liquidtouch.errors import SignalError
from liquidtouch.signal.tactile import tactile_signal
from liquidtouch.tracking.clock import frame_period, uniform_clock
from liquidtouch.tracking.tracks import MarkerTracks, load_tracks, save_tracks

PERIOD_S = 1 / 29.55  # a real camera's rate, not the nominal 30 fps
LAM, OMEGA = 0.6, 2 * np.pi * 1.3
PUSH_S = 100.4  # the motion's origin on the shared (monotonic) clock


def camera_times(n, rng, *, jitter_s=0.002, drop_fraction=0.05, round_s=None, start_s=0.0):
    """Capture times [s] of a camera: jittered, some frames dropped, optionally rounded."""
    t = start_s + np.arange(n) * PERIOD_S + rng.normal(0, jitter_s, n)
    keep = rng.random(n) >= drop_fraction
    keep[0] = keep[-1] = True
    t = t[keep]
    return np.round(t / round_s) * round_s if round_s else t


def test_fitted_period_is_the_camera_rate_where_the_median_interval_is_not():
    rng = np.random.default_rng(3)
    t = camera_times(400, rng, round_s=1e-3, start_s=1234.5)  # Matroska keeps 1 ms
    assert np.any(np.diff(t) > 1.5 * PERIOD_S)  # frames were dropped
    median_error = np.median(np.diff(t)) / PERIOD_S - 1
    assert abs(median_error) > 0.003  # 33 or 34 ms, not 33.84 ms: 15× the tolerance below
    assert frame_period(t) == pytest.approx(PERIOD_S, rel=2e-4)
    clock, fps = uniform_clock(t)
    assert fps == pytest.approx(1 / PERIOD_S, rel=2e-4)
    assert clock[0] == 0 and clock[-1] <= t[-1] - t[0] < clock[-1] + 1 / fps
    np.testing.assert_allclose(np.diff(clock), 1 / fps)


def test_fitted_period_is_exact_on_exact_times_and_refuses_bad_ones():
    assert frame_period(np.arange(50) * 0.04 + 7.0) == pytest.approx(0.04, rel=1e-12)
    with pytest.raises(SignalError, match="increase strictly"):
        frame_period(np.array([0.0, 0.1, 0.1]))


def _tracks(t_common, sensor, seed, *, origin_s=0.0, start_s=0.0, n=20):
    """Tracks of markers moving with the same motion, sampled at shared-clock times
    ``t_common``; stored relative to ``origin_s`` (a video's own time axis)."""
    rng = np.random.default_rng(seed)
    reference = rng.uniform(50, 400, (n, 2))
    gain = np.exp(-np.hypot(*(reference - 225).T) / 120)
    tau = t_common - PUSH_S
    osc = np.exp(-LAM * tau) * np.cos(OMEGA * tau)
    disp = np.stack([2.0 * gain * osc[:, None], -0.5 * gain * osc[:, None]], axis=2)
    positions = reference[None] + disp + rng.normal(0, 1e-4, disp.shape)
    t = t_common - t_common[0] + origin_s
    valid = np.ones(positions.shape[:2], bool)
    return MarkerTracks(t, positions, valid, reference, sensor=sensor, start_s=start_s)


def test_sensors_with_different_starts_and_drops_are_aligned_on_the_shared_clock(tmp_path):
    rng = np.random.default_rng(5)
    left_t = camera_times(330, rng, jitter_s=0.0, start_s=100.0)
    right_t = camera_times(330, rng, jitter_s=0.0, start_s=100.2173)  # opened later
    tracks = [
        _tracks(left_t, "left", 1, start_s=left_t[0]),
        _tracks(right_t, "right", 2, origin_s=3.0, start_s=right_t[0]),
    ]
    sig = tactile_signal(tracks, n_markers=20)
    assert {name for name, _ in sig.markers} == {"left", "right"}
    # the truth: both sensors sampled without drops on the clock the signal chose
    truth_t = right_t[0] + np.arange(len(sig.t) + 1) * PERIOD_S
    truth_tracks = [_tracks(truth_t, name, seed) for name, seed in (("left", 1), ("right", 2))]
    truth = tactile_signal(truth_tracks, n_markers=20)
    assert sig.fps == pytest.approx(1 / PERIOD_S, rel=1e-9)
    k = min(len(sig.u), len(truth.u))
    assert abs(len(sig.u) - len(truth.u)) <= 1
    scale = np.abs(truth.u).max()
    assert np.abs(sig.u[:k] - truth.u[:k]).max() < 0.02 * scale
    # aligned on their first frames instead (start_s unknown), the sensors disagree
    for tr in tracks:
        tr.start_s = 0.0
    unaligned = tactile_signal(tracks, n_markers=20)
    assert np.abs(unaligned.u[:k] - truth.u[:k]).max() > 0.2 * scale
    # the start survives the tracks file; files without it read as 0
    tracks[1].start_s = right_t[0]
    save_tracks(tmp_path / "t.npz", tracks)
    assert [tr.start_s for tr in load_tracks(tmp_path / "t.npz")] == [0.0, right_t[0]]


def test_sensors_that_never_overlap_are_refused():
    t = np.arange(100) * PERIOD_S + 100.0
    tracks = [_tracks(t, "left", 1, start_s=100.0), _tracks(t + 10, "right", 2, start_s=110.0)]
    with pytest.raises(SignalError, match="do not overlap"):
        tactile_signal(tracks)
