"""Tactile signal: resampling, low-pass, marker selection, PCA, sign convention, errors."""

from __future__ import annotations

import numpy as np
import pytest

from liquidtouch.errors import MarkerError, SignalError
from liquidtouch.fit.oscillation import fit_oscillation
from liquidtouch.signal import lowpass, tactile_signal, uniform_clock
from liquidtouch.tracking.tracks import MarkerTracks

LAM, OMEGA = 0.6, 2 * np.pi * 1.3


def make_tracks(t, n=30, seed=0, sensor="left", noise=0.01):
    rng = np.random.default_rng(seed)
    reference = rng.uniform(50, 400, (n, 2))
    gain = np.exp(-np.hypot(*(reference - 225).T) / 80)  # markers near the contact move most
    osc = np.exp(-LAM * t) * np.cos(OMEGA * t)
    disp = np.stack([2.0 * gain * osc[:, None], -0.5 * gain * osc[:, None]], axis=2)
    positions = reference[None] + disp + rng.normal(0, noise, disp.shape)
    return MarkerTracks(t, positions, np.ones((len(t), n), bool), reference, sensor=sensor)


def test_signal_recovers_damped_oscillation_from_jittery_clock():
    rng = np.random.default_rng(1)
    t = np.arange(240) / 30 + rng.uniform(-0.004, 0.004, 240)
    t[0] = 0.0
    tracks = [make_tracks(t, sensor="left"), make_tracks(t, seed=2, sensor="right")]
    sig = tactile_signal(tracks)
    assert sig.n_markers == 16 and sig.weights.shape == (16, 2)
    assert sig.fps == pytest.approx(30, rel=0.01)
    assert np.allclose(np.diff(sig.t), 1 / sig.fps)
    assert sig.explained_variance > 0.99
    assert {name for name, _ in sig.markers} == {"left", "right"}
    fit = fit_oscillation(sig.t, sig.u, model="single-mode")
    assert fit.angular_frequency == pytest.approx(OMEGA, rel=0.01)
    assert fit.decay_rate == pytest.approx(LAM, rel=0.05)
    # Sign convention: the largest-magnitude weight is positive.
    flat = sig.weights.ravel()
    assert flat[np.argmax(np.abs(flat))] > 0
    # The chosen markers are the ones that move most (nearest the contact).
    left = tracks[0]
    chosen_left = [i for name, i in sig.markers if name == "left"]
    dist = np.hypot(*(left.reference - 225).T)
    assert dist[chosen_left].max() <= np.sort(dist)[len(chosen_left) + 4]


def test_short_gaps_interpolated_long_gaps_excluded():
    t = np.arange(200) / 30
    tracks = make_tracks(t)
    best = int(np.argmax(-np.hypot(*(tracks.reference - 225).T)))
    tracks.valid[50:53, best] = False
    tracks.positions[50:53, best] = np.nan
    sig = tactile_signal([tracks])
    assert ("left", best) in sig.markers and np.isfinite(sig.u).all()
    tracks.valid[60:100, best] = False
    tracks.positions[60:100, best] = np.nan
    assert ("left", best) not in tactile_signal([tracks]).markers


def test_errors():
    t = np.arange(200) / 30
    tracks = make_tracks(t, n=3)
    tracks.valid[:, :2] = False
    with pytest.raises(MarkerError, match="only 1 markers"):
        tactile_signal([tracks])
    with pytest.raises(SignalError, match="Nyquist"):
        lowpass(np.zeros((100, 2)), fps=5.0, cutoff_hz=3.0)
    with pytest.raises(SignalError, match="frames"):
        lowpass(np.zeros((10, 2)), fps=30.0)
    with pytest.raises(SignalError, match="increasing"):
        uniform_clock(np.array([0.0, 0.1, 0.1]))
    still = make_tracks(t, noise=0.0)
    still.positions[:] = still.reference
    with pytest.raises(SignalError, match="do not move"):
        tactile_signal([still])


def test_free_decay_starts_at_the_push_not_at_the_end_of_a_slip_drift():
    from liquidtouch.segment import free_decay, free_decay_start

    t = np.arange(0, 13, 1 / 30)
    ring = np.where(t >= 1.2, np.exp(-3.5 * (t - 1.2)) * np.cos(15.0 * (t - 1.2)), 0.0)
    drift = 0.12 * np.clip(t - 1.2, 0, None)  # slip: ends 1.4 above rest, the push went 1.0
    u = ring + drift
    start = free_decay_start(t, u)
    assert abs(t[start] - 1.2) < 1.5 / 30
    t_free, u_free = free_decay(t, u)
    assert t_free[0] == t[start] and len(u_free) == len(t) - start
    # without drift the filter does not move the peak either
    assert free_decay_start(t, ring) == start
