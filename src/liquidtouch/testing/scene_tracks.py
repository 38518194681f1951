"""Marker tracks without rendering: a simulated scene's true positions plus tracking noise,
and the same tracks with frames taken out.

Shared by the benchmarks that study the signal and the fit apart from the tracker
(``benchmarks/signal/gaps.py``, ``benchmarks/fit/fit_std.py``, ``benchmarks/fit/fit_bias.py``)
and by the tests. Not in the simulator: ``liquidtouch.sim`` must not load the estimation
pipeline (``MarkerTracks``).
"""

from __future__ import annotations

import numpy as np

from liquidtouch.sim.gelsight import SENSOR_NAMES, SensorScene
from liquidtouch.tracking.tracks import MarkerTracks


def noisy_true_tracks(
    scene: SensorScene, rng: np.random.Generator, noise_px: float
) -> list[MarkerTracks]:
    """Both sensors' tracks as a tracker with ``noise_px`` [px] of Gaussian noise per
    coordinate would give them: ``scene``'s true positions plus noise drawn from ``rng``
    (left sensor first), every marker valid, the first (noisy) frame the reference."""
    tracks = []
    for s, name in enumerate(SENSOR_NAMES):
        pos = scene.positions_px[s] + rng.normal(0, noise_px, scene.positions_px[s].shape)
        valid = np.ones(pos.shape[:2], bool)
        tracks.append(MarkerTracks(scene.timestamps_s.copy(), pos, valid, pos[0].copy(), name))
    return tracks


def keep_frames(tracks: list[MarkerTracks], keep: list[np.ndarray]) -> list[MarkerTracks]:
    """``tracks`` with only the frames ``keep`` (one boolean mask per sensor) says came."""
    return [
        MarkerTracks(tr.t[k], tr.positions[k], tr.valid[k], tr.reference, tr.sensor)
        for tr, k in zip(tracks, keep, strict=True)
    ]
