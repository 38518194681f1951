"""Which recording format keeps up with two GelSight sensors, and what each does to λ.

Run: .venv/bin/python benchmarks/record_formats.py [--quick] [--frames 150]

1. **Encode speed on one core** (the process pinned to one CPU, OpenCV and the
   codecs single-threaded): rendered 640 × 480 GelSight frames (the simulator's
   ``default`` sensor, with noise) encoded as the recorder writes them (FFV1 in
   Matroska and PNG, grey and colour; grey includes the BGR → grey conversion)
   and as H.264 (libx264 ``ultrafast`` CRF 20, yuv420p, without and with x264's
   quantisation dead zone). Two sensors at 30 fps need 60 frames/s: a format
   keeps up when its encode rate is above that (the capture threads and the rest
   of the machine need the remainder of the core).
2. **λ bias through each format**: simulated trials (``default`` sensor,
   640 × 480 at 30 fps, 13 s, seeded variability) rendered once and written
   through each format with the same per-frame timestamps, then
   ``liquidtouch.extraction.extract``: λ/λ_true − 1 and ω/ω_true − 1 per format,
   and FFV1's λ against PNG's (the same grey frames; Matroska stores the
   timestamps to 1 ms, PNG's timestamps.csv to 1 µs).
3. **Probe: the median-interval clock.** ``clock.uniform_clock`` steps at the
   frame period fitted to all timestamps (``clock.frame_period``). Until it did,
   it stepped at the *median* frame interval, which with jittered or
   millisecond-rounded timestamps misses the real period by ~0.3 % and moves λ
   with it. The same extractions are repeated with the median interval (in this
   process only, :func:`median_period`) to show what the fitted period changed.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from liquidtouch.extraction.pipeline import extract
from liquidtouch.sim.gelsight import SENSOR_NAMES
from liquidtouch.sim.trial import simulate_trial
from liquidtouch.testing.video_formats import make_writer, render_sensors

NEEDED_FPS = 60.0  # two sensors at 30 fps
CASES = [  # (liquid, sugar concentration, fill height [mm], seed)
    ("water", None, 32.0, 1),  # the slowest decay: the hardest case for lossy video
    ("olive-oil", None, 25.0, 2),
    ("sugar-water", 60.0, 30.0, 3),
]
FORMATS = ("png", "ffv1", "x264 no dead zone", "x264 default")


# --- 1. encode speed --------------------------------------------------------------------


def encode_speed(frames: list[np.ndarray], fps: float, work: Path) -> list[dict[str, object]]:
    rows = []
    variants = [
        ("ffv1", True),
        ("ffv1", False),
        ("png", True),
        ("png", False),
        ("x264 no dead zone", False),
        ("x264 default", False),
    ]
    t = np.arange(len(frames)) / fps
    for fmt, grey in variants:
        best = np.inf
        size = 0
        for attempt in range(2):
            directory = work / f"speed-{fmt.replace(' ', '-')}-{grey}-{attempt}"
            directory.mkdir()
            writer = make_writer(fmt, directory, "left", fps, grey=grey)
            start = time.process_time()
            for rgb, t_s in zip(frames, t, strict=True):
                writer.write(rgb, t_s)
            writer.close()
            elapsed = max(time.process_time() - start, 1e-9)
            best = min(best, elapsed)
            size = sum(p.stat().st_size for p in directory.rglob("*") if p.is_file())
            shutil.rmtree(directory)
        rate = len(frames) / best
        colour = "grey" if grey else ("colour (BGR)" if fmt in ("ffv1", "png") else "YUV 4:2:0")
        rows.append(
            {
                "format": fmt,
                "pixels": colour,
                "encode_fps": rate,
                "keeps_up": rate >= NEEDED_FPS,
                "mb_per_min_per_sensor": size / len(frames) * 30 * 60 / 1e6,
            }
        )
    return rows


# --- 2. λ bias --------------------------------------------------------------------------


def write_trial_as(fmt: str, sensors, timestamps, fps: float, out: Path) -> Path:
    out.mkdir()
    entries = []
    for name, frames in zip(SENSOR_NAMES, sensors, strict=True):
        writer = make_writer(fmt, out, name, fps, grey=True)
        for rgb, t_s in zip(frames, timestamps, strict=True):
            writer.write(rgb, float(t_s))
        writer.close()
        entries.append(writer.entry)
    (out / "meta.json").write_text(json.dumps({"fps": fps, "sensors": entries}))
    return out


def median_period(t) -> float:
    """The median frame interval [s]: the clock's step before the fitted period (probe only)."""
    return float(np.median(np.diff(np.asarray(t, dtype=float))))


def extract_both(directory: Path) -> tuple[tuple[float, float], tuple[float, float]]:
    """(λ, ω) of ``extract(directory)``, as the library does it and with the median clock."""
    import liquidtouch.tracking.clock as clock

    result = extract(directory)
    library = (result.fit.decay_rate, result.fit.angular_frequency)
    original = clock.frame_period
    clock.frame_period = median_period
    try:
        result = extract(directory)
    finally:
        clock.frame_period = original
    return library, (result.fit.decay_rate, result.fit.angular_frequency)


def lambda_bias(cases, work: Path) -> list[dict[str, object]]:
    rows = []
    for liquid, sugar, height, seed in cases:
        trial = simulate_trial(liquid, height_mm=height, sugar_concentration=sugar, seed=seed)
        sensors, timestamps, fps = render_sensors(trial, seed)
        row: dict[str, object] = {
            "case": f"{liquid}{f' {sugar:g}' if sugar else ''} {height:g} mm",
            "true_lambda": trial.true_decay_rate,
            "true_omega": trial.true_angular_frequency,
        }
        for fmt in FORMATS:
            directory = work / f"{liquid}-{seed}-{fmt.replace(' ', '-')}"
            write_trial_as(fmt, sensors, timestamps, fps, directory)
            row[fmt], row[f"{fmt} median clock"] = extract_both(directory)
            shutil.rmtree(directory)
        rows.append(row)
        del sensors
    return rows


# --- report -----------------------------------------------------------------------------


def print_report(speed, bias, n_frames: int) -> None:
    print("# record_formats — encoding two GelSight sensors, and λ through each format\n")
    print(
        f"## Encode speed on one core: 640×480 rendered GelSight frames ({n_frames} frames, "
        "best of 2, process CPU time)\n"
    )
    print(f"Two sensors at 30 fps need {NEEDED_FPS:.0f} frames/s.\n")
    print("| format | pixels | encode fps | keeps up with 2 × 30 fps | MB/min per sensor |")
    print("|---|---|---|---|---|")
    for r in speed:
        print(
            f"| {r['format']} | {r['pixels']} | {r['encode_fps']:.0f} | "
            f"{'yes' if r['keeps_up'] else 'no'} | {r['mb_per_min_per_sensor']:.0f} |"
        )
    for clock, suffix in (
        ("the library's clock (fitted frame period)", ""),
        ("probe: the former clock (median frame interval)", " median clock"),
    ):
        print(
            f"\n## λ and ω through each format, {clock} (default sensor 640×480 @ 30 fps, "
            "13 s; PNG/FFV1 grey as the recorder stores them)\n"
        )
        head = " | ".join(f"{f} λ / ω err" for f in FORMATS)
        print(f"| trial | λ true [1/s] | ω true [rad/s] | {head} | FFV1 λ vs PNG |")
        print("|---|---|---|" + "---|" * len(FORMATS) + "---|")
        errs: dict[str, list[float]] = {f: [] for f in FORMATS}
        for row in bias:
            cells = []
            for f in FORMATS:
                lam, om = row[f + suffix]
                e_lam = lam / row["true_lambda"] - 1
                errs[f].append(e_lam)
                cells.append(f"{e_lam:+.3f} / {om / row['true_omega'] - 1:+.4f}")
            ffv1_vs_png = row["ffv1" + suffix][0] / row["png" + suffix][0] - 1
            print(
                f"| {row['case']} | {row['true_lambda']:.3f} | {row['true_omega']:.2f} | "
                + " | ".join(cells)
                + f" | {ffv1_vs_png:+.4f} |"
            )
        medians = " | ".join(f"**{np.median(errs[f]):+.3f}**" for f in FORMATS)
        print(f"| **median λ err** | | | {medians} | |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one trial for the λ bias")
    parser.add_argument("--frames", type=int, default=150, help="frames for the speed test")
    args = parser.parse_args()
    cpu = min(os.sched_getaffinity(0))
    os.sched_setaffinity(0, {cpu})  # one core
    cv2.setNumThreads(1)
    work = Path(tempfile.mkdtemp(prefix="record-formats-"))
    try:
        trial = simulate_trial("water", height_mm=25.0, seed=0)
        sensors, _, fps = render_sensors(trial, 0)
        frames = sensors[0][100 : 100 + args.frames]  # during the push and ring-down
        del sensors
        speed = encode_speed(frames, fps, work)
        bias = lambda_bias(CASES[:1] if args.quick else CASES, work)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    print_report(speed, bias, len(frames))


if __name__ == "__main__":
    main()
