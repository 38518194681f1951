"""Speed of the GelSight renderer and H.264 writer, per sensor profile, on one core.

Measures frames per second of CPU time (the machine may be shared, so wall time is
also shown) for:

- baseline A, naive drawing: background copy + one anti-aliased ``cv2.circle``
  per marker at 1/16-px precision (no imprint, no noise), per frame;
- baseline B, encode a constant frame (the codec's floor cost);
- render only (``iter_frames``: lighting, moving imprint, markers, noise, flicker);
- encode only (pre-rendered frames → libx264 ultrafast, crf 20, 1 thread);
- render + encode (``encode_video(iter_frames(...))``);
- the whole ``write_sensor_videos`` call (both sensors, timestamps, truth file),
  counted per sensor-frame.

Ratios are against baseline A in the same run.

    .venv/bin/python benchmarks/render_speed.py [--frames N]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from liquidtouch.sim.gelsight import (
    contact_geometry,
    contact_offsets,
    frame_timestamps,
    marker_positions,
    write_sensor_videos,
)
from liquidtouch.sim.loads import FingerLoads
from liquidtouch.sim.render import encode_video, iter_frames, make_background
from liquidtouch.sim.sensors import get_sensor_profile


def slosh_loads(duration_s: float) -> FingerLoads:
    t = np.arange(0.0, duration_s + 1e-9, 0.005)
    osc = 0.1 * np.exp(-0.3 * t) * np.cos(2 * np.pi * 1.5 * t)
    shear = np.zeros((len(t), 2, 2))
    shear[:, :, 0] = osc[:, None]
    shear[:, :, 1] = -1.0
    return FingerLoads(
        t_s=t,
        shear_force_n=shear,
        twist_moment_nmm=np.stack([2 * osc, 2 * osc], axis=1),
        normal_force_n=np.array([5.0, 5.0]),
        contact_center_mm=np.array([[1.0, -0.5], [1.0, -0.5]]),
    )


def timed(fn) -> tuple[float, float]:
    """(CPU seconds, wall seconds) of ``fn()``."""
    c0, w0 = time.process_time(), time.perf_counter()
    fn()
    return time.process_time() - c0, time.perf_counter() - w0


def naive_render(positions: np.ndarray, background: np.ndarray, radius_px: float) -> None:
    bg8 = np.clip(background, 0, 255).astype(np.uint8)
    shift = 4
    for pos in positions:
        frame = bg8.copy()
        for x, y in pos:
            cv2.circle(
                frame,
                (round(x * 16), round(y * 16)),
                round(radius_px * 16),
                (20, 20, 25),
                thickness=-1,
                lineType=cv2.LINE_AA,
                shift=shift,
            )
        cv2.cvtColor(frame, cv2.COLOR_RGB2YUV_I420)


def bench_profile(name: str, n_frames: int, out_dir: Path) -> list[tuple[str, float, float]]:
    profile = get_sensor_profile(name)
    duration_s = n_frames / (profile.fps * profile.rate_factor)
    loads = slosh_loads(duration_s)
    rng = np.random.default_rng(0)
    ts, _ = frame_timestamps(loads.duration_s, profile, rng, jitter=False, drops=False)
    ts = ts[:n_frames]
    n = len(ts)
    geom = contact_geometry(loads, profile)
    offsets = contact_offsets(loads, profile, ts)[0]
    positions = marker_positions(loads, profile, ts)[0]
    background = make_background(profile, rng)
    kwargs = dict(
        background=background,
        contact_center_px=geom.center_px[0],
        contact_radius_px=float(geom.radius_px[0]),
        contact_offsets_px=offsets,
    )

    def render_only() -> None:
        for _ in iter_frames(positions, profile, np.random.default_rng(1), **kwargs):
            pass

    frames = [f.copy() for f in iter_frames(positions, profile, np.random.default_rng(1), **kwargs)]
    constant = [frames[0]] * n
    rows = [
        (
            "baseline A: naive cv2.circle drawing",
            *timed(lambda: naive_render(positions, background, profile.marker_radius_px)),
        ),
        (
            "baseline B: encode a constant frame",
            *timed(lambda: encode_video(out_dir / "c.mp4", constant, ts, profile.fps)),
        ),
        ("render only", *timed(render_only)),
        ("encode only", *timed(lambda: encode_video(out_dir / "e.mp4", frames, ts, profile.fps))),
        (
            "render + encode",
            *timed(
                lambda: encode_video(
                    out_dir / "b.mp4",
                    iter_frames(positions, profile, np.random.default_rng(1), **kwargs),
                    ts,
                    profile.fps,
                )
            ),
        ),
    ]
    holder = {}
    cpu, wall = timed(
        lambda: holder.setdefault("rec", write_sensor_videos(loads, out_dir / "trial", sensor=name))
    )
    n_sensor_frames = 2 * holder["rec"].n_frames
    rows.append(
        (
            "write_sensor_videos (both sensors, per sensor-frame)",
            cpu * n / n_sensor_frames,
            wall * n / n_sensor_frames,
        )
    )
    return [(label, n / c, n / w) for label, c, w in rows]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=300, help="frames per measurement")
    args = parser.parse_args()
    cv2.setNumThreads(1)
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    print(f"# Renderer speed ({args.frames} frames per measurement, one core)\n")
    print(f"Machine: {os.cpu_count()} CPUs, load average {load} at start (shared machine).\n")
    with tempfile.TemporaryDirectory() as tmp:
        for name in ("default", "mini"):
            profile = get_sensor_profile(name)
            rows = bench_profile(name, args.frames, Path(tmp))
            base = rows[0][1]
            print(f"## `{name}`: {profile.width_px}×{profile.height_px} @ {profile.fps:g} fps\n")
            print("| stage | frames/s (CPU) | frames/s (wall) | × baseline A |")
            print("|---|---:|---:|---:|")
            for label, fps_cpu, fps_wall in rows:
                print(f"| {label} | {fps_cpu:.0f} | {fps_wall:.0f} | {fps_cpu / base:.2f} |")
            print()


if __name__ == "__main__":
    main()
