"""Recording on a loaded machine: frames delivered in bursts still make one trial (issue 41).

The simulated MJPEG GelSight can be scripted to send no ``X-Timestamp`` (the recorder
stamps frames on arrival) and to hold its frames and send them together every
``burst_s`` seconds, as a loaded machine delivers them. Before, the frame period of such
stamps was fitted at 31-55 fps for a 30 fps camera: ``record`` exited 0 and ``extract``
refused the trial ("videos of one trial differ in frame rate"). Loopback only; every
wait is bounded.
"""

from __future__ import annotations

import time

import numpy as np
import pytest
from helpers import grid, render_blobs

from liquidtouch.acquire.recording import record
from liquidtouch.errors import DeviceError
from liquidtouch.extraction.pipeline import extract
from liquidtouch.io.dataset import read_trial_meta
from liquidtouch.io.frames import read_frames
from liquidtouch.sim.rig.mjpeg import MjpegServer
from liquidtouch.tracking.clock import fit_frame_period

FPS = 30.0
BURST_S = 0.2  # the servers send their frames together every 0.2 s [s]
LAM, OMEGA = 0.5, 2 * np.pi * 1.3  # a slow ring-down: 3 s of it is 1.5 decay times


def _ring_down(base_s: float, push_s: float, seconds: float, amplitude_px: float = 2.0):
    """``frame_source(t_s)`` of markers ringing down from ``push_s`` [s, time.monotonic]:
    frames drawn ahead for the times ``base_s + k / FPS`` (the nearest is served), so that
    drawing does not slow the servers on a busy machine (their skipped frames would be
    hidden among the delivered ones)."""
    rest = grid()
    tau = base_s + np.arange(int(seconds * FPS)) / FPS - push_s
    shift = np.where(tau >= 0, amplitude_px * np.exp(-LAM * tau) * np.cos(OMEGA * tau), 0.0)
    images = [render_blobs(rest + np.array([s, 0.3 * s])) for s in shift]

    def source(t_s: float) -> np.ndarray:
        return images[min(max(round((t_s - base_s) * FPS), 0), len(images) - 1)]

    return source


def _skipped(server: MjpegServer) -> int:
    """Frame slots the server skipped while it ran (its producer fell behind)."""
    return int(np.sum(np.rint(np.diff(server.sent_timestamps) * server.fps) - 1))


@pytest.mark.slow(seconds=25)
def test_two_healthy_streams_delivered_in_bursts_make_a_trial_that_extracts(tmp_path):
    out = tmp_path / "trial"
    base = time.monotonic()
    source = _ring_down(base, base + 4.0, 16.0)  # the push after the cameras are warmed up
    with (
        MjpegServer(source, fps=FPS, timed=True, stamped=False, burst_s=BURST_S) as a,
        MjpegServer(source, fps=FPS, timed=True, stamped=False, burst_s=BURST_S) as b,
    ):
        servers = {a.url: a, b.url: b}
        summary = record(list(servers), 8.0, out, fmt="ffv1")
    for name in ("left", "right"):
        stamps, _ = read_frames(out / f"{name}.mkv")
        steps = np.diff(stamps)
        assert np.mean(steps < 0.25 / FPS) > 0.5  # they came in bursts of ~6 frames
        # a server that skips frames on this busy machine (a few): among delivered frames
        # only some of them can be seen, the others count as a slower camera
        fit = fit_frame_period(stamps)
        assert fit.delivered and 0.97 * FPS <= fit.fps <= 1.01 * FPS
        s = summary.sensors[name]
        assert s.measured_fps == pytest.approx(fit.fps, rel=1e-4)  # what extract fits
        # bursts are not drops (6 of every 6 were, before): at most the frame slots the
        # server skipped, and one burst's frames more (the last frames' delay, when a busy
        # reader splits their burst, cannot be told from drops)
        assert s.drops <= _skipped(servers[s.source]) + round(BURST_S * FPS)
    # meta.json: what extract fits
    assert read_trial_meta(out).fps == pytest.approx(summary.fps, rel=1e-9)
    result = extract(out)  # before: "videos of one trial differ in frame rate"
    assert 0.97 * FPS <= result.signal.fps <= 1.01 * FPS
    # read on the lattice under the bursts, the ring-down is the one the servers drew
    assert result.fit.angular_frequency == pytest.approx(OMEGA, rel=0.01)
    assert result.fit.decay_rate == pytest.approx(LAM, rel=0.1)


@pytest.mark.slow(seconds=8)
def test_sensors_of_different_rates_are_refused_when_recording(tmp_path):
    """A mismatch is found by ``record``, not by ``extract`` after the trial was kept."""
    frame = grid()
    with (
        MjpegServer(lambda: render_blobs(frame), fps=FPS) as a,
        MjpegServer(lambda: render_blobs(frame), fps=0.8 * FPS) as b,
        pytest.raises(DeviceError, match=r"differ in frame rate.*one --sensor profile"),
    ):
        record([a.url, b.url], 2.0, tmp_path / "trial", fmt="png")
    assert not any(p.name.endswith("trial") for p in tmp_path.iterdir())
