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

Ratios are against the baselines measured in the same run (best of two runs
each). A second table gives each drawing method's marker-centroid error (plain
intensity-weighted centroid on a flat, noise-free frame): what the extra work buys.

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

from liquidtouch.sim.encode import encode_video
from liquidtouch.sim.gelsight import (
    contact_geometry,
    contact_offsets,
    frame_timestamps,
    marker_positions,
    marker_rest_positions,
    write_sensor_videos,
)
from liquidtouch.sim.loads import FingerLoads
from liquidtouch.sim.render import iter_frames, make_background, render_frames
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


def timed(fn, repeats: int = 2) -> tuple[float, float]:
    """Best (CPU seconds, wall seconds) of ``repeats`` calls of ``fn()``."""
    best_cpu = best_wall = np.inf
    for _ in range(repeats):
        c0, w0 = time.process_time(), time.perf_counter()
        fn()
        best_cpu = min(best_cpu, time.process_time() - c0)
        best_wall = min(best_wall, time.perf_counter() - w0)
    return best_cpu, best_wall


def naive_render(
    positions: np.ndarray, background: np.ndarray, radius_px: float, keep: list | None = None
) -> None:
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
        if keep is not None:
            keep.append(frame)


def centroid_errors(name: str) -> dict[str, tuple[float, float]]:
    """Max and rms centroid error [px] of both drawing methods on a flat, noise-free frame."""
    profile = get_sensor_profile(name)
    rng = np.random.default_rng(3)
    half = int(np.ceil(profile.marker_radius_px + 4 * profile.marker_edge_px))
    rest = marker_rest_positions(profile)
    size = np.array([profile.width_px, profile.height_px])
    rest = rest[np.all((rest > half + 2) & (rest < size - half - 3), axis=1)]
    positions = rest[None] + rng.uniform(-1.0, 1.0, (4, *rest.shape))
    flat = make_background(profile, rng, lighting=False)
    ours = render_frames(positions, profile, rng, background=flat, noise=False, flicker=False)
    naive: list[np.ndarray] = []
    naive_render(positions, flat, profile.marker_radius_px, keep=naive)
    yy, xx = np.mgrid[-half : half + 1, -half : half + 1]
    out = {}
    for label, frames in (("naive cv2.circle (LINE_AA, 1/16 px)", naive), ("render_frames", ours)):
        errors = []
        for frame, pos in zip(frames, positions, strict=True):
            dark = flat[..., 0] - frame.astype(float).mean(axis=2)
            for x, y in pos:
                xi, yi = round(x), round(y)
                win = dark[yi - half : yi + half + 1, xi - half : xi + half + 1]
                errors.append(
                    [
                        (win * (xx + xi)).sum() / win.sum() - x,
                        (win * (yy + yi)).sum() / win.sum() - y,
                    ]
                )
        err = np.abs(np.array(errors))
        out[label] = (float(err.max()), float(np.sqrt((err**2).mean())))
    return out


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
            base_a, base_b = rows[0][1], rows[1][1]
            print(f"## `{name}`: {profile.width_px}×{profile.height_px} @ {profile.fps:g} fps\n")
            print("| stage | frames/s (CPU) | frames/s (wall) | × baseline A | × baseline B |")
            print("|---|---:|---:|---:|---:|")
            for label, fps_cpu, fps_wall in rows:
                print(
                    f"| {label} | {fps_cpu:.0f} | {fps_wall:.0f} | {fps_cpu / base_a:.2f} "
                    f"| {fps_cpu / base_b:.2f} |"
                )
            print()
            print("| marker drawing | centroid error max [px] | rms [px] |")
            print("|---|---:|---:|")
            for label, (err_max, err_rms) in centroid_errors(name).items():
                print(f"| {label} | {err_max:.3f} | {err_rms:.4f} |")
            print()


if __name__ == "__main__":
    main()
