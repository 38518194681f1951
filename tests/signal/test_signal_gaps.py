"""Gaps are gaps (issue 23): stalls and dropped frames do not move λ, and a gap that
swallows the ring-down is reported. Against the simulator's truth and the gap-free fit."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from liquidtouch.cli.format import gap_warning
from liquidtouch.errors import SwallowedRingDownError
from liquidtouch.extraction.fit_settings import FitSettings, ring_down_swallowed
from liquidtouch.signal.lowpass import lowpass, lowpass_frames, observed_samples
from liquidtouch.signal.tactile import tactile_signal
from liquidtouch.sim.gelsight import sensor_scene
from liquidtouch.sim.sensors import get_sensor_profile
from liquidtouch.sim.trial import simulate_trial
from liquidtouch.testing.scene_tracks import keep_frames, noisy_true_tracks
from liquidtouch.tracking.tracks import MarkerTracks

FPS = 25.0
LAM, OMEGA = 0.8, 13.0  # a mirin-like ring-down [1/s, rad/s]


def ring_down(t: np.ndarray) -> np.ndarray:
    return np.exp(-LAM * t) * np.cos(OMEGA * t)


def test_the_low_pass_of_the_frames_that_came_reads_through_dropped_frames():
    """Three dropped frames at 25 fps are a quarter of a 2 Hz period: a straight line
    across them, then the low-pass, is a quarter of the amplitude off; the smoother of
    the frames that came, ~0.3 %."""
    t_clock = np.arange(250) / FPS
    keep = np.ones(250, bool)
    keep[[11, 12, 13, 40, 41, 70]] = False  # frame 12: near a peak (ω t ≈ 2π)
    x = ring_down(t_clock)[:, None]
    everything = lowpass_frames(t_clock, x, t_clock, FPS)[:, 0]
    came = lowpass_frames(t_clock[keep], x[keep], t_clock, FPS)[:, 0]
    line = lowpass(np.interp(t_clock, t_clock[keep], x[keep, 0])[:, None], FPS)[:, 0]
    assert np.abs(line - lowpass(x, FPS)[:, 0]).max() > 0.2
    assert np.abs(came - everything).max() < 0.005


def test_the_smoother_is_the_butterworth_where_no_frame_is_missing():
    """Same passband and stopband as the zero-phase Butterworth it stands in for, and
    closer to the clean signal at the recording's ends (odd-reflection padding)."""
    t = np.arange(2000) / FPS
    for f_hz in (1.0, 2.0, 2.5, 3.0, 4.0):
        wave = np.sin(2 * np.pi * f_hz * t)[:, None]
        smooth = lowpass_frames(t, wave, t, FPS)[500:-500, 0].std()
        butter = lowpass(wave, FPS)[500:-500, 0].std()
        assert smooth == pytest.approx(butter, abs=0.005)
    wave = np.sin(2 * np.pi * 6.0 * t)[:, None]
    assert lowpass_frames(t, wave, t, FPS)[500:-500].std() / wave.std() < 0.03
    t = t[:250]
    clean = ring_down(t)
    noisy = clean + np.random.default_rng(0).normal(0, 0.01, t.size)
    smooth = lowpass_frames(t, noisy[:, None], t, FPS)[:, 0]
    butter = lowpass(noisy[:, None], FPS)[:, 0]
    inner = slice(25, -25)
    assert np.abs(smooth - clean)[inner].max() < 1.1 * np.abs(butter - clean)[inner].max()
    assert np.abs(smooth - clean)[:10].max() < 0.5 * np.abs(butter - clean)[:10].max()


def test_the_low_pass_next_to_a_stall_matches_the_gap_free_low_pass():
    """No frame for 0.6 s: at the samples on each side the low-pass is within 1 % of the
    ring-down's amplitude of the low-pass without the stall."""
    t = np.arange(250) / FPS
    x = ring_down(t)[:, None]
    came = (t < 2.0) | (t > 2.6)
    gapped = lowpass_frames(t[came], x[came], t, FPS)
    assert np.abs(gapped - lowpass_frames(t, x, t, FPS))[came].max() < 0.01


def test_a_lone_frame_at_either_end_is_not_observed():
    """Dropped frames just before the last frame leave nothing beyond it to bridge to:
    the clock ends at the last two frames one period apart (the smoother read a water
    ring-down's last 0.16 s at up to 5x the push)."""
    t_frames = np.delete(np.arange(30) / FPS, [1, 2, 25, 26, 27, 28])
    clock = np.arange(30) / FPS
    observed = observed_samples(t_frames, clock, 0.17)
    assert not observed[:3].any() and observed[3:25].all() and not observed[25:].any()


def truth_tracks(liquid: str, seed: int, height_mm: float) -> tuple[list[MarkerTracks], object]:
    """Both sensors' true marker positions (mini profile, 25 fps) and 0.01 px of noise,
    as ``benchmarks/signal/gaps.py``."""
    rng = np.random.default_rng(seed)
    trial = simulate_trial(liquid, height_mm=height_mm, seed=seed)
    scene = sensor_scene(trial.loads, get_sensor_profile("mini"), rng, jitter=False)
    return noisy_true_tracks(scene, rng, 0.01), trial


def fit(tracks: list[MarkerTracks]):
    sig = tactile_signal(tracks)
    return FitSettings().fit(sig.t, sig.u)


@pytest.mark.parametrize(
    ("liquid", "seed", "height_mm", "stall_after_s", "stall_s"),
    [("water", 0, 25.0, 1.0, 0.6), ("mirin", 2, 22.0, 0.4, 1.0), ("corn-oil", 3, 28.0, 0.3, 0.3)],
)
def test_a_stall_in_the_ring_down_does_not_move_lambda(
    liquid, seed, height_mm, stall_after_s, stall_s
):
    tracks, trial = truth_tracks(liquid, seed, height_mm)
    ref = fit(tracks)
    assert ref.decay_rate == pytest.approx(trial.true_decay_rate, rel=0.08)
    t = tracks[0].t
    begin = ref.t0 + stall_after_s
    kept = ~((t > begin) & (t < begin + stall_s))
    gapped = fit(keep_frames(tracks, [kept, kept]))
    assert gapped.gap_share > 0
    assert not ring_down_swallowed(gapped)
    assert gapped.decay_rate == pytest.approx(ref.decay_rate, rel=0.05)
    assert gapped.angular_frequency == pytest.approx(ref.angular_frequency, rel=0.005)
    assert gapped.decay_rate == pytest.approx(trial.true_decay_rate, rel=0.08)


def test_irregular_drops_at_16_fps_do_not_move_lambda():
    """Each sensor keeps each 25 fps frame with probability 16/25, independently."""
    tracks, trial = truth_tracks("water", 5, 24.0)
    ref = fit(tracks)
    rng = np.random.default_rng(7)
    keep = [rng.random(tr.t.size) < 16 / 25 for tr in tracks]
    for k in keep:
        k[[0, -1]] = True
    gapped = fit(keep_frames(tracks, keep))
    assert gapped.decay_rate == pytest.approx(ref.decay_rate, rel=0.05)
    assert gapped.angular_frequency == pytest.approx(ref.angular_frequency, rel=0.005)
    assert gapped.decay_rate == pytest.approx(trial.true_decay_rate, rel=0.08)


def test_a_stall_that_swallows_a_detergent_ring_down_is_reported():
    """Detergent (λ ≈ 4 1/s) is above the noise for ~0.7 s: a 1 s stall from its start
    leaves its tail only. The fit either refuses, naming the gap, or warns."""
    tracks, _ = truth_tracks("detergent", 4, 25.0)
    ref = fit(tracks)
    assert ref.ring_down_gap_share == 0 and not ring_down_swallowed(ref)
    t = tracks[0].t
    begin = ref.t0 + 0.1
    kept = ~((t > begin) & (t < begin + 1.0))
    try:
        gapped = fit(keep_frames(tracks, [kept, kept]))
    except SwallowedRingDownError as exc:
        assert "stall" in str(exc) and "without samples" in str(exc)
        return
    assert ring_down_swallowed(gapped)
    assert "swallowed the ring-down" in gap_warning(gapped)


def test_the_swallowed_warning_names_the_gap_share():
    result = SimpleNamespace(ring_down_gap_share=0.8, t0=1.25, gap_before_start_s=0.0)
    assert ring_down_swallowed(result)
    assert "80% of the ring-down" in gap_warning(result)
    quiet = SimpleNamespace(ring_down_gap_share=0.1, t0=1.25, gap_before_start_s=0.0)
    assert not ring_down_swallowed(quiet) and gap_warning(quiet) is None
    assert math.isclose(FitSettings().fit(*example_signal()).ring_down_gap_share, 0.0)


def example_signal() -> tuple[np.ndarray, np.ndarray]:
    t = np.arange(300) / 30
    return t, ring_down(t) + 0.01 * np.random.default_rng(0).normal(size=t.size)
