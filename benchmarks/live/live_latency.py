"""Can the streaming estimator keep up? Per-frame latency and lag on a real-time replay.

Simulates one water trial with two 640 × 480 sensors at 30 fps (the ``default``
profile), replays it in real time through :func:`liquidtouch.live.live_updates`
(refreshes on a worker thread) and prints the per-frame latency of
``add_frame`` (tracking and bookkeeping), the lag of each frame's processing
behind the moment it was due, and the wall-clock lag of the estimates. The
baseline, measured in the same run: the budget per frame (two sensors at
30 fps: 16.7 ms) and the offline tracking time per frame of the same videos.
Pin it to one core to measure the issue's setting::

    taskset -c 0 python benchmarks/live_latency.py --duration 13
"""

from __future__ import annotations

import argparse
import math
import tempfile
import time
from pathlib import Path

import numpy as np


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=13.0, help="trial length [s]")
    parser.add_argument("--trial", type=Path, default=None, help="an existing trial directory")
    args = parser.parse_args()

    from liquidtouch.extraction.pipeline import track_sources
    from liquidtouch.io.sources import resolve_sources
    from liquidtouch.live import live_updates

    with tempfile.TemporaryDirectory() as tmp:
        trial = args.trial
        if trial is None:
            from liquidtouch.sim.trial import simulate_trial
            from liquidtouch.sim.trial_io import write_trial

            simulated = simulate_trial("water", height_mm=25.0, seed=2, duration_s=args.duration)
            trial = write_trial(simulated, Path(tmp) / "trial", sensor="default")
        began = time.perf_counter()
        tracks = track_sources(resolve_sources(trial))
        n_frames = sum(len(tr.t) for tr in tracks)
        offline_ms = 1e3 * (time.perf_counter() - began) / n_frames

        began = time.monotonic()
        updates = list(live_updates(trial, realtime=True))
        wall = time.monotonic() - began
    final = updates[-1]
    timing = final.timing
    lags = np.array([u.lag_s for u in updates[:-1] if math.isfinite(u.lag_s)])
    budget_ms = 1e3 / 60.0
    rows = [
        ("frame budget (2 × 30 fps)", budget_ms),
        ("offline decode + track, per frame", offline_ms),
        ("live add_frame latency, median", timing["latency_ms_median"]),
        ("live add_frame latency, p95", timing["latency_ms_p95"]),
        ("live add_frame latency, max", timing["latency_ms_max"]),
    ]
    print(f"trial {trial.name}: {n_frames} frames, replay took {wall:.2f} s wall")
    print(f"{'quantity':40s} {'ms':>8s} {'/ budget':>9s}")
    for name, value in rows:
        print(f"{name:40s} {value:8.2f} {value / budget_ms:9.2f}")
    print(
        f"frame processing lag behind its due time [s]: median {timing['frame_lag_s_median']:.4f}"
        f", p95 {timing['frame_lag_s_p95']:.4f}, max {timing['frame_lag_s_max']:.4f}"
    )
    print(
        f"estimate lag behind its newest frame [s] ({lags.size} updates): median "
        f"{np.median(lags):.3f}, max {lags.max():.3f}"
    )
    print(
        f"final: λ {final.decay_rate:.4f} 1/s, ω {final.angular_frequency:.4f} rad/s, "
        f"{final.stopped_because}"
    )


if __name__ == "__main__":
    main()
