"""Markerless gels (issue 39): the same λ and ω from the gel's own image as from markers?

1. **Both ways**: each simulated slosh (the paper's liquids, ``--trials`` seeds each) is
   rendered twice from the same loads, on a marker gel (``mini``) and on a plain gel
   (``mini-plain``: only the imprint and the face's texture move), and extracted as
   ``extract`` does (``tracking="auto"`` finds the kind). Per liquid: the median relative
   difference of the markerless λ and ω from the marker λ and ω, and both against the
   truth.
2. **Sub-pixel accuracy**: the plain gel's imprint rendered at uniform shifts of 0.05-2 px
   (reached in 10 frames, sensor noise on), read by the flow tracker and, as the baseline
   of issue 39's sketch, by OpenCV's DIS flow (medium preset) averaged over the same
   cells: bias and std of the cells' motion [% of the shift, px].
3. **Time per frame** against decoding the same video (in this run, the fastest of
   :data:`REPEATS`): 320 × 240 (a Mini) and 640 × 480 simulated (H.264, which decodes
   fast), and the lossless validation video at 320 × 240.
4. **The validation videos** (``../shared/validation/videos``, an independent
   generator): λ and ω against their truth, or the error.

    nice -n 10 .venv/bin/python benchmarks/tracking/markerless.py [--trials 5] [--duration 10]
        [--lossless]
"""

from __future__ import annotations

import argparse
import json
import math
import tempfile
import time
from pathlib import Path

import numpy as np

from liquidtouch.errors import LiquidTouchError
from liquidtouch.extraction.pipeline import extract
from liquidtouch.io.frames import iter_frames
from liquidtouch.sim.encode import X264_PARAMS
from liquidtouch.sim.render import iter_frames as render_frames
from liquidtouch.sim.sensors import get_sensor_profile
from liquidtouch.sim.trial import simulate_trial
from liquidtouch.sim.trial_io import write_trial
from liquidtouch.tracking.flow import FlowTracker

#: the paper's liquids (sugar water at one concentration of its range)
LIQUIDS = {
    "water": {},
    "olive-oil": {},
    "corn-oil": {},
    "mirin": {},
    "detergent": {},
    "sugar-water": {"sugar_concentration": 80.0},
}
HEIGHTS_MM = (18.0, 34.0)
SHIFTS_PX = (0.05, 0.1, 0.25, 0.5, 1.0, 2.0)
#: timings: decoding and tracking are each timed this many times, the fastest kept
REPEATS = 3
VALIDATION = Path(__file__).resolve().parents[2].parent / "shared" / "validation" / "videos"
OUT = Path("benchmarks/results/markerless.md")
#: x264 options of a lossless video (``--lossless``): quantiser 0
LOSSLESS = "qp=0"


def both_ways(trials: int, duration_s: float, root: Path, x264_params: str) -> list[str]:
    """Table 1: markerless against marker λ, ω per liquid (median over the trials), the
    videos encoded with ``x264_params`` (the simulator's default, or lossless)."""
    lines = [
        "| liquid | trials | λ plain/markers − 1 (median) | ω plain/markers − 1 (median) "
        "| ω plain/markers − 1 (min to max) | \\|Δλ\\| / σ, \\|Δω\\| / σ (median) "
        "| λ markers/truth − 1 | λ plain/truth − 1 | refused |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for liquid, extra in LIQUIDS.items():
        d_lam, d_om, z_lam, z_om, m_truth, p_truth, refused = [], [], [], [], [], [], 0
        for seed in range(trials):
            height = HEIGHTS_MM[0] + (HEIGHTS_MM[1] - HEIGHTS_MM[0]) * ((seed * 0.618) % 1.0)
            trial = simulate_trial(
                liquid, height_mm=height, seed=1000 + seed, duration_s=duration_s, **extra
            )
            fits = {}
            for sensor in ("mini", "mini-plain"):
                where = root / f"{liquid}-{seed}-{sensor}"
                out = write_trial(trial, where, sensor=sensor, x264_params=x264_params)
                try:
                    fits[sensor] = extract(out).fit
                except LiquidTouchError:
                    fits[sensor] = None
            marker, plain = fits["mini"], fits["mini-plain"]
            if plain is None or marker is None:
                refused += 1
                continue
            d_lam.append(plain.decay_rate / marker.decay_rate - 1)
            d_om.append(plain.angular_frequency / marker.angular_frequency - 1)
            # the two fits' std combined as if independent (they share the slosh, so their
            # difference varies less): |z| < 1 is agreement within what either can tell
            z_lam.append(_z(plain.decay_rate, marker.decay_rate,
                            plain.decay_rate_std, marker.decay_rate_std))  # fmt: skip
            z_om.append(_z(plain.angular_frequency, marker.angular_frequency,
                           plain.angular_frequency_std, marker.angular_frequency_std))  # fmt: skip
            m_truth.append(marker.decay_rate / trial.true_decay_rate - 1)
            p_truth.append(plain.decay_rate / trial.true_decay_rate - 1)
        med = [f"{100 * np.median(v):+.2f} %" if v else "—" for v in (d_lam, d_om)]
        truth = [f"{100 * np.median(v):+.1f} %" if v else "—" for v in (m_truth, p_truth)]
        span = f"{100 * min(d_om):+.2f} to {100 * max(d_om):+.2f} %" if d_om else "—"
        z = f"{np.median(z_lam):.2f}, {np.median(z_om):.2f}" if z_om else "—"
        lines.append(
            f"| {liquid} | {trials} | {med[0]} | {med[1]} | {span} | {z} | {truth[0]} "
            f"| {truth[1]} | {refused} |"
        )
    return lines


def _z(a: float, b: float, std_a: float, std_b: float) -> float:
    """|a − b| over the two std combined."""
    return abs(a - b) / math.hypot(std_a, std_b)


def _cells_dis(frames: list[np.ndarray], tracker: FlowTracker) -> np.ndarray:
    """DIS flow (medium preset) of each frame against the first, averaged over the cells."""
    import cv2

    dis = cv2.DISOpticalFlow_create(cv2.DISOPTICAL_FLOW_PRESET_MEDIUM)
    grid, crop = tracker.grid, tracker.crop
    first = np.ascontiguousarray(frames[0][crop])
    out = []
    for frame in frames[1:]:
        flow = dis.calc(first, np.ascontiguousarray(frame[crop]), None)[grid.slices]
        means = np.stack([grid.sums(np.ascontiguousarray(flow[..., a])) for a in range(2)], 1)
        out.append(means[tracker.cells] / grid.cell**2)
    return np.array(out)


def _held(shifts: np.ndarray, profile, centre, radius, steps: int) -> tuple:
    """Flow and DIS readings (frames, cells) of x over the held frames, and the cells."""
    frames = [
        f.mean(axis=2).astype(np.uint8)
        for f in render_frames(
            np.zeros((len(shifts), 0, 2)),
            profile,
            np.random.default_rng(7),
            contact_center_px=centre,
            contact_radius_px=radius,
            imprint_motion=lambda i, rel: np.tile(shifts[i], (len(rel), 1)),
        )
    ]
    tracker = FlowTracker()
    reference = tracker.start(frames[0])
    flow = np.stack([tracker.step(f)[:, 0] - reference[:, 0] for f in frames[1:]])
    inner = np.hypot(*(reference - centre).T) < 0.7 * radius  # the textured contact
    dis = _cells_dis(frames, tracker)[:, :, 0]
    return flow[steps:, inner], dis[steps:, inner]


def subpixel(steps: int = 10) -> list[str]:
    """Table 2: bias and std of the cells' motion at uniform rendered shifts.

    Each shift is reached in ``steps`` frames and held for ``steps``; the same frames at
    rest (the same seed, so the same noise) are subtracted, which takes away what the
    reference frame's own noise reads. Bias: of the mean over the contact's cells and the
    held frames; std: of one cell in one frame.
    """
    profile = get_sensor_profile("mini-plain")
    centre = np.array([(profile.width_px - 1) / 2, (profile.height_px - 1) / 2])
    radius = profile.contact_radius_mm_ref / profile.mm_per_px
    lines = [
        "| shift [px] | flow bias | flow std [px] | DIS bias | DIS std [px] |",
        "|---:|---:|---:|---:|---:|",
    ]
    rest = _held(np.zeros((2 * steps + 1, 2)), profile, centre, radius, steps)
    for shift in SHIFTS_PX:
        ramp = shift * np.minimum(np.arange(2 * steps + 1) / steps, 1.0)
        moved = _held(np.column_stack([ramp, 0 * ramp]), profile, centre, radius, steps)
        cells = []
        for m, r in zip(moved, rest, strict=True):
            d = m - r
            cells.append(f"{100 * (np.nanmean(d) / shift - 1):+.1f} % | {np.nanstd(m):.3f}")
        lines.append(f"| {shift:g} | {cells[0]} | {cells[1]} |")
    return lines


def timing(root: Path) -> list[str]:
    """Table 3: flow tracking against decoding, ms per frame, one video per size."""
    lines = [
        "| video | frames | decode [ms/frame] | flow [ms/frame] | flow / decode |",
        "|---|---:|---:|---:|---:|",
    ]
    videos = []
    for sensor in ("mini-plain", "default-plain"):
        trial = simulate_trial("water", height_mm=25.0, seed=5, duration_s=6.0)
        out = write_trial(trial, root / f"timing-{sensor}", sensor=sensor)
        profile = get_sensor_profile(sensor)
        videos.append(
            (f"{profile.width_px}×{profile.height_px} ({sensor}, H.264)", out / "left.mp4")
        )
    label = VALIDATION / "markerless_label_mini" / "left.mp4"
    if label.exists():
        videos.append(("320×240 (markerless_label_mini, lossless)", label))
    for name, video in videos:
        decode, flow = np.inf, np.inf
        for _ in range(REPEATS):  # the fastest of a few: the machine is shared
            start = time.perf_counter()
            frames = [image for _, image in iter_frames(video)]
            decode = min(decode, (time.perf_counter() - start) / len(frames))
            tracker = FlowTracker()
            tracker.start(frames[0])
            start = time.perf_counter()
            for image in frames[1:]:
                tracker.step(image)
            flow = min(flow, (time.perf_counter() - start) / (len(frames) - 1))
        lines.append(
            f"| {name} | {len(frames)} | "
            f"{1e3 * decode:.2f} | {1e3 * flow:.2f} | {flow / decode:.2f} |"
        )
    return lines


def validation() -> list[str]:
    """Table 4: the independent generator's videos against their truth."""
    lines = [
        "| case | tracking | λ (truth) | λ error | ω (truth) | ω error |",
        "|---|---|---:|---:|---:|---:|",
    ]
    if not VALIDATION.exists():
        return [*lines, "| (../shared/validation not available) | | | | | |"]
    for case in sorted(p for p in VALIDATION.iterdir() if p.is_dir()):
        truth = json.loads((case / "truth.json").read_text())
        try:
            result = extract([case / "left.mp4", case / "right.mp4"])
        except LiquidTouchError as exc:
            lines.append(f"| {case.name} | — | error: {str(exc)[:90]}… | | | |")
            continue
        fit = result.fit
        lines.append(
            f"| {case.name} | {result.tracking} | {fit.decay_rate:.4f} ({truth['lam']}) | "
            f"{100 * (fit.decay_rate / truth['lam'] - 1):+.1f} % | "
            f"{fit.angular_frequency:.4f} ({truth['omega']}) | "
            f"{100 * (fit.angular_frequency / truth['omega'] - 1):+.2f} % |"
        )
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=5, help="trials per liquid")
    parser.add_argument("--duration", type=float, default=10.0, help="trial length [s]")
    parser.add_argument("--skip-both-ways", action="store_true", help="only tables 2-4")
    parser.add_argument(
        "--lossless",
        action="store_true",
        help="table 1 with lossless videos (H.264 at qp 0) instead of the simulator's default",
    )
    args = parser.parse_args()
    sections = []
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        sections.append(("Sub-pixel accuracy on rendered shifts (mini-plain)", subpixel()))
        sections.append(("Time per frame against decoding", timing(root)))
        sections.append(("Validation videos (independent generator)", validation()))
        if not args.skip_both_ways:
            codec = f"H.264 {LOSSLESS}" if args.lossless else "H.264 as simulated"
            title = (
                f"Rendered both ways ({args.trials} trials per liquid, {args.duration:g} s, "
                f"{codec})"
            )
            params = LOSSLESS if args.lossless else X264_PARAMS
            sections.insert(0, (title, both_ways(args.trials, args.duration, root, params)))
    text = "\n\n".join(f"### {title}\n\n" + "\n".join(lines) for title, lines in sections)
    print(text)
    out = OUT.with_name("markerless-lossless.md") if args.lossless else OUT
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text + "\n")


if __name__ == "__main__":
    main()
