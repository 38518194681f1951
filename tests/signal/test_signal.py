"""Tactile signal: resampling, low-pass, marker selection, PCA, sign convention, errors."""

from __future__ import annotations

import numpy as np
import pytest

from liquidtouch.errors import MarkerError, SignalError
from liquidtouch.fit.oscillation import fit_oscillation
from liquidtouch.signal.lowpass import lowpass
from liquidtouch.signal.tactile import tactile_signal
from liquidtouch.tracking.clock import uniform_clock
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
    with pytest.raises(SignalError, match="increase strictly"):
        uniform_clock(np.array([0.0, 0.1, 0.1]))
    still = make_tracks(t, noise=0.0)
    still.positions[:] = still.reference
    with pytest.raises(SignalError, match="do not move"):
        tactile_signal([still])


def test_free_decay_starts_at_the_push_not_at_the_end_of_a_slip_drift():
    from liquidtouch.ring_down.segments import free_decay
    from liquidtouch.ring_down.start import free_decay_start

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


def test_tactile_signal_does_not_depend_on_the_clock_origin():
    t = np.arange(200) / 30
    base = tactile_signal([make_tracks(t), make_tracks(t, seed=2, sensor="right")])
    late_tracks = [make_tracks(t), make_tracks(t, seed=2, sensor="right")]
    for tracks in late_tracks:
        tracks.t = tracks.t + 5.0  # e.g. a camera clock that does not start at 0
    late = tactile_signal(late_tracks)
    assert late.t.size == base.t.size
    np.testing.assert_allclose(late.u, base.u, atol=1e-9)


def _signal_args(**change):
    t = np.arange(200) / 30
    args = {"tracks": [make_tracks(t)]}
    args.update(change)
    return args


def _tracks_with(**arrays):
    tracks = make_tracks(np.arange(200) / 30)
    for name, value in arrays.items():
        setattr(tracks, name, value)
    return tracks


@pytest.mark.parametrize(
    ("change", "exc", "match"),
    [
        ({"n_markers": 0}, SignalError, r"n_markers must be a whole number >= 1 .*got 0"),
        ({"n_markers": -3}, SignalError, "n_markers must be a whole number >= 1"),
        ({"n_markers": 2.5}, SignalError, "n_markers must be a whole number"),
        ({"n_markers": True}, SignalError, "n_markers must be a whole number"),
        ({"lowpass_hz": 0.0}, SignalError, "lowpass_hz must be a cut-off frequency > 0"),
        ({"lowpass_hz": -3.0}, SignalError, "lowpass_hz must be"),
        ({"lowpass_hz": float("nan")}, SignalError, "lowpass_hz must be"),
        ({"lowpass_hz": 20.0}, SignalError, "Nyquist"),
        ({"max_lost_fraction": 1.5}, SignalError, r"max_lost_fraction must be .* \[0, 1\]"),
        ({"max_lost_fraction": -0.1}, SignalError, "max_lost_fraction"),
        ({"max_gap_s": -1.0}, SignalError, "max_gap_s must be a duration >= 0"),
        ({"max_gap_s": float("nan")}, SignalError, "max_gap_s"),
        ({"tracks": []}, MarkerError, "no marker tracks"),
        ({"tracks": make_tracks(np.arange(200) / 30)}, MarkerError, r"pass \[tracks\]"),
        ({"tracks": 5}, MarkerError, "must be a list of MarkerTracks"),
        ({"tracks": [np.zeros((200, 30, 2))]}, MarkerError, "expected MarkerTracks"),
        (
            {"tracks": [make_tracks(np.arange(200) / 30), make_tracks(np.arange(200) / 30)]},
            MarkerError,
            "both named 'left'",
        ),
        (
            {"tracks": [_tracks_with(valid=np.ones((200, 29), bool))]},
            MarkerError,
            r"inconsistent tracks: .* expected \(T,\), \(T, N, 2\)",
        ),
        (
            {"tracks": [_tracks_with(reference=np.zeros(30))]},
            MarkerError,
            "inconsistent tracks",
        ),
        (
            {"tracks": [_tracks_with(t=np.r_[np.arange(199) / 30, 0.0])]},
            SignalError,
            "left: frame timestamps must increase strictly",
        ),
        (
            {"tracks": [_tracks_with(t=np.r_[np.arange(199) / 30, np.nan])]},
            SignalError,
            "left: frame timestamps holds 1 NaN/inf",
        ),
    ],
)
def test_tactile_signal_checks_its_arguments(change, exc, match):
    with pytest.raises(exc, match=match):
        tactile_signal(**_signal_args(**change))


def test_signal_helpers_check_their_arguments():
    from liquidtouch.signal.tactile import first_component

    with pytest.raises(SignalError, match="end_s must be a finite time after"):
        uniform_clock(np.arange(10.0), end_s=-1.0)
    with pytest.raises(SignalError, match="at least 2 strictly increasing"):
        uniform_clock(np.array([0.0]))
    with pytest.raises(SignalError, match="NaN/inf"):
        lowpass(np.full((100, 2), np.nan), fps=30.0)
    with pytest.raises(SignalError, match="fps must be a frame rate > 0"):
        lowpass(np.zeros((100, 2)), fps=0.0)
    with pytest.raises(SignalError, match="filter order must be a whole number"):
        lowpass(np.zeros((100, 2)), fps=30.0, order=0)
    with pytest.raises(SignalError, match="PCA must be a non-empty 2-D array"):
        first_component(np.zeros(10))
    with pytest.raises(SignalError, match=r"PCA needs \(samples >= 2"):
        first_component(np.zeros((1, 4)))


@pytest.mark.parametrize(
    ("args", "kwargs", "match"),
    [
        ((np.arange(100) / 30, np.zeros(99)), {}, "equal length"),
        ((np.zeros(0), np.zeros(0)), {}, "non-empty"),
        ((np.arange(100) / 30, np.full(100, np.nan)), {}, "u holds NaN/inf"),
        ((np.arange(100)[::-1] / 30, np.zeros(100)), {}, "increase strictly"),
        ((np.arange(100) / 30, np.zeros(100)), {"baseline_s": -1.0}, "baseline_s must be"),
        ((np.arange(100) / 30, np.zeros(100)), {"drift_cutoff_hz": 0.0}, "drift_cutoff_hz"),
    ],
)
def test_free_decay_checks_its_arguments(args, kwargs, match):
    from liquidtouch.ring_down.segments import free_decay
    from liquidtouch.ring_down.start import free_decay_start

    with pytest.raises(SignalError, match=match):
        free_decay_start(*args, **kwargs)
    if not kwargs:
        with pytest.raises(SignalError, match=match):
            free_decay(*args)


def test_plot_extraction_draws_into_given_axes_without_touching_the_backend(tmp_path, monkeypatch):
    import matplotlib
    from matplotlib.figure import Figure

    from liquidtouch.errors import LiquidTouchError
    from liquidtouch.extraction.pipeline import Extraction
    from liquidtouch.extraction.plot import plot_extraction

    def no_backend_switch(*args, **kwargs):
        raise AssertionError("a library must not call matplotlib.use")

    backend = matplotlib.get_backend()
    monkeypatch.setattr(matplotlib, "use", no_backend_switch)
    t = np.arange(300) / 30
    tracks = [make_tracks(t), make_tracks(t, seed=2, sensor="right")]
    sig = tactile_signal(tracks)
    extraction = Extraction(tracks, sig, fit_oscillation(sig.t, sig.u, model="single-mode"))
    fig = Figure()
    grid = fig.subplots(2, 2)
    assert plot_extraction(extraction, axes=grid) is fig
    assert all(ax.has_data() for ax in grid.ravel())
    assert grid[1, 1].get_title().startswith("λ = ")
    single = Figure().subplots()
    assert plot_extraction(extraction, axes=single) is single.figure
    assert [line.get_label() for line in single.lines] == ["u(t)", "fit"]
    new = plot_extraction(extraction, tmp_path / "x.png")
    assert isinstance(new, Figure) and len(new.axes) == 4
    assert (tmp_path / "x.png").read_bytes().startswith(b"\x89PNG")
    with pytest.raises(LiquidTouchError, match="takes 1 or 4 matplotlib Axes"):
        plot_extraction(extraction, axes=Figure().subplots(1, 3))
    assert matplotlib.get_backend() == backend
