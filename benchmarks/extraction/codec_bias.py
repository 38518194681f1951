"""λ and ω bias of lossy codecs, against the lossless result of the same frames.

Run: .venv/bin/python benchmarks/codec_bias.py [--full] [--mechanism] [--cases N] [--only TEXT]
[--jobs N] [--figure PNG]

Each case is a simulated trial (``default`` sensor, 640 × 480 at 30 fps, 13 s,
seeded variability; liquids from λ ≈ 0.14 to 3.4 /s; ``--full`` adds pushes of
half and double the usual distance, i.e. other motion amplitudes). Both sensors
are rendered once (``record_formats.render_sensors``) and

- **lossless**: the grey frames are tracked straight from memory (what PNG or
  FFV1 store: the baseline of every ratio);
- every **codec** of the grid encodes the same RGB frames, the file is decoded
  and tracked (``io.frames.iter_frames`` → ``track_markers``).

Every variant is timed by the rendered timestamps (the decoded ones are
replaced: OpenCV's writers keep only a nominal rate), so the rows differ only
by the codec's pixels. λ and ω come from ``tactile_signal`` and
``FitSettings().fit`` (what ``extract`` does), ``frozen`` is
``codec_check.frozen_steps`` (share of the moving markers' frame steps that are
exactly zero while another moved), ``MB/min`` the size per sensor-minute.

Grids: default (a few minutes on one core): x264 ``fast`` CRF 18/23/28 with
x264's defaults, CRF 18 without the dead zone, MPEG-4 (OpenCV ``mp4v``), MJPEG
(OpenCV), FFV1. ``--full``: x264 CRF 10/18/23/28 × ``fast``/``slow`` × dead zone
on/off, lossless x264 (``qp=0``), MPEG-4 ``mp4v`` and ``XVID``, MJPEG, FFV1.
Mitigation probe (last column): the same λ fitted to the reference frames
(I and P) only, the B-frames left out (:func:`fit_at_frames`), against the
lossless tracks at the same frames.

``--simulator``: the simulator's encoder (``sim.encode``: ``ultrafast``) at CRF
20/23/26 without the dead zone, CRF 20 with it, ``superfast`` and ``veryfast`` at
CRF 20/23 without it, lossless x264 (``ultrafast``, ``qp=0``), against FFV1:
which setting is fastest with no effect on λ. ``encode frames/s per core`` is
the encoder's process CPU time (RGB in, file out) per frame.

``--mechanism``: x264 ``fast`` CRF 18 with one option changed at a time
(trellis, psy-rd, fast P-skip, AQ, macroblock tree, B-frames, sub-pel motion
estimation, dead zone) to find what freezes the motion.
"""

from __future__ import annotations

import argparse
import math
import shutil
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, replace
from pathlib import Path

import cv2
import numpy as np

from liquidtouch.extraction.codec_check import frozen_steps
from liquidtouch.extraction.fit_settings import FitSettings
from liquidtouch.fit.oscillation import fit_oscillation
from liquidtouch.io.frames import iter_frames
from liquidtouch.ring_down.start import free_decay_start
from liquidtouch.signal.tactile import tactile_signal
from liquidtouch.sim.encode import X264_PARAMS, encode_video
from liquidtouch.sim.trial import simulate_trial
from liquidtouch.testing import progress_bar
from liquidtouch.testing.video_formats import make_writer, render_sensors
from liquidtouch.tracking.tracks import track_markers

CASES = [  # (liquid, sugar concentration, fill height [mm], push scale)
    ("water", None, 32.0, 1.0),  # λ ≈ 0.14 /s, the slowest decay
    ("sugar-water", 60.0, 30.0, 1.0),  # λ ≈ 0.28
    ("olive-oil", None, 25.0, 1.0),  # λ ≈ 1.1
    ("detergent", None, 25.0, 1.0),  # λ ≈ 3.4
]
FULL_CASES = [
    *CASES,
    ("mirin", None, 25.0, 1.0),  # λ ≈ 0.63
    ("sugar-water", 160.0, 20.0, 1.0),  # λ ≈ 1.2
    ("water", None, 32.0, 0.5),
    ("water", None, 32.0, 2.0),
    ("olive-oil", None, 25.0, 0.5),
    ("olive-oil", None, 25.0, 2.0),
]
DEAD_ZONE_OFF = X264_PARAMS  # "deadzone-inter=0:deadzone-intra=0"


@dataclass(frozen=True)
class Codec:
    """One encoding: ``kind`` x264 / opencv / ffv1; x264's CRF, preset and extra params."""

    name: str
    kind: str
    crf: int = 0
    preset: str = "fast"
    params: str = ""
    fourcc: str = ""


def x264(crf: int, preset: str = "fast", params: str = "", label: str = "") -> Codec:
    name = label or f"x264 {preset} CRF {crf}" + (" dz off" if params == DEAD_ZONE_OFF else "")
    return Codec(name, "x264", crf, preset, params)


DEFAULT_GRID = [
    Codec("FFV1", "ffv1"),
    x264(18),
    x264(18, params=DEAD_ZONE_OFF),
    x264(23),
    x264(28),
    Codec("MPEG-4 mp4v (OpenCV)", "opencv", fourcc="mp4v"),
    Codec("MJPEG (OpenCV)", "opencv", fourcc="MJPG"),
]
FULL_GRID = [
    Codec("FFV1", "ffv1"),
    x264(0, "fast", "qp=0", label="x264 lossless (qp=0)"),
    *[
        x264(crf, preset, params)
        for preset in ("fast", "slow")
        for params in ("", DEAD_ZONE_OFF)
        for crf in (10, 18, 23, 28)
    ],
    Codec("MPEG-4 mp4v (OpenCV)", "opencv", fourcc="mp4v"),
    Codec("MPEG-4 XVID (OpenCV)", "opencv", fourcc="XVID"),
    Codec("MJPEG (OpenCV)", "opencv", fourcc="MJPG"),
]
SIMULATOR_GRID = [  # the simulator's own encoder (sim.encode): ultrafast, no dead zone
    Codec("FFV1", "ffv1"),
    *[x264(crf, "ultrafast", DEAD_ZONE_OFF) for crf in (20, 23, 26)],
    x264(20, "ultrafast"),
    *[x264(crf, p, DEAD_ZONE_OFF) for p in ("superfast", "veryfast") for crf in (20, 23)],
    x264(0, "ultrafast", "qp=0", label="x264 ultrafast lossless (qp=0)"),
]
MECHANISM_GRID = [
    x264(18),
    *[
        x264(18, params=p, label=f"x264 fast CRF 18 {p}")
        for p in (
            "trellis=0",
            "psy=0",
            "fast-pskip=0",
            "aq-mode=0",
            "mbtree=0",
            "bframes=0",
            "subme=0",
            "subme=9",
            DEAD_ZONE_OFF,
            "mbtree=0:bframes=0",
            "mbtree=0:bframes=0:" + DEAD_ZONE_OFF,
            "subme=9:bframes=0",
            "subme=9:" + DEAD_ZONE_OFF,
            "subme=9:bframes=0:" + DEAD_ZONE_OFF,
        )
    ],
    x264(18, "ultrafast"),
    x264(18, "slow"),
]


def encode(codec: Codec, frames: list[np.ndarray], t_s: np.ndarray, fps: float, work: Path):
    """Write ``frames`` (RGB) with ``codec``; return the file."""
    if codec.kind == "x264":
        path = work / "v.mp4"
        encode_video(
            path, frames, t_s, fps, crf=codec.crf, preset=codec.preset, x264_params=codec.params
        )
        return path
    if codec.kind == "ffv1":
        writer = make_writer("ffv1", work, "v", fps, grey=True)
        for rgb, t in zip(frames, t_s, strict=True):
            writer.write(rgb, float(t))
        writer.close()
        return work / writer.entry
    suffix = ".mp4" if codec.fourcc == "mp4v" else ".avi"
    path = work / f"v{suffix}"
    height, width = frames[0].shape[:2]
    out = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*codec.fourcc), fps, (width, height))
    for rgb in frames:
        out.write(cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
    out.release()
    return path


def frame_types(path: Path) -> np.ndarray:
    """Picture type (``I``, ``P``, ``B``) of every decoded frame of a video."""
    import av

    with av.open(str(path)) as container:
        names = {1: "I", 2: "P", 3: "B"}
        return np.array([names.get(int(f.pict_type), "?") for f in container.decode(video=0)])


def fit_at_frames(tracks, keep: np.ndarray) -> float:
    """λ [1/s] fitted to the kept frames only (probe: the B-frames left out).

    u at a kept frame is the raw displacement of the signal's markers projected
    on its PCA weights (no resampling, no low-pass: the kept frames are not
    uniform); the window starts where ``extract``'s does.
    """
    signal = tactile_signal(tracks)
    by_name = {tr.sensor: tr for tr in tracks}
    disp = np.stack([by_name[s].displacement[:, m] for s, m in signal.markers], axis=1)
    u = np.einsum("tnc,nc->t", disp, signal.weights)
    t = tracks[0].t - tracks[0].t[0]
    start = signal.t[free_decay_start(signal.t, signal.u)]
    sel = keep & (t >= start) & np.isfinite(u)
    return fit_oscillation(t[sel], u[sel], **FitSettings().fit_options()).decay_rate


def fit_tracks(tracks) -> tuple[float, float, float]:
    """(λ [1/s], ω [rad/s], frozen-step share) of tracks, as ``extract`` fits them."""
    signal = tactile_signal(tracks)
    fit = FitSettings().fit(signal.t, signal.u)
    return fit.decay_rate, fit.angular_frequency, frozen_steps(tracks)[0]


def run_case(case, grid: list[Codec]) -> list[dict[str, object]]:
    """Render one case, track it lossless and through every codec of ``grid``; one row each."""
    liquid, sugar, height, push_scale = case
    seed = 1
    trial = simulate_trial(liquid, height_mm=height, sugar_concentration=sugar, seed=seed)
    if push_scale != 1.0:
        distance = trial.params.push_distance_mm * push_scale
        trial = simulate_trial(
            liquid,
            height_mm=height,
            sugar_concentration=sugar,
            seed=seed,
            parameters={"push_distance_mm": distance},
        )
    sensors, t_s, fps = render_sensors(trial, seed)
    label = f"{liquid}{f' {sugar:g}' if sugar else ''} {height:g} mm" + (
        f" push ×{push_scale:g}" if push_scale != 1.0 else ""
    )
    base_tracks = [
        track_markers(
            ((t, cv2.cvtColor(f, cv2.COLOR_RGB2GRAY)) for t, f in zip(t_s, fr, strict=True)),
            f"s{s}",
        )
        for s, fr in enumerate(sensors)
    ]
    lam0, om0, frozen0 = fit_tracks(base_tracks)
    common = {"case": label, "true_lambda": trial.true_decay_rate}
    rows = [{**common, "codec": "lossless (memory)", "lambda": lam0, "omega": om0,
             "lambda_base": lam0, "omega_base": om0, "frozen": frozen0, "mb_per_min": math.nan,
             "lambda_ref": math.nan, "lambda_ref_base": math.nan,
             "encode_fps": math.nan, "seconds": 0.0}]  # fmt: skip
    work = Path(tempfile.mkdtemp(prefix="codec-bias-"))
    try:
        for codec in grid:
            start = time.perf_counter()
            tracks, size, types, encode_cpu_s = [], 0, None, 0.0
            for s, frames in enumerate(sensors):
                cpu = time.process_time()  # one case per process, nothing else runs in it
                path = encode(codec, frames, t_s, fps, work)
                encode_cpu_s += time.process_time() - cpu
                size += path.stat().st_size
                types = frame_types(path) if types is None else types
                tr = track_markers(iter_frames(path), f"s{s}")
                if len(tr.t) != len(t_s):
                    raise RuntimeError(f"{codec.name}: {len(tr.t)} frames decoded of {len(t_s)}")
                tracks.append(replace(tr, t=t_s.copy()))  # the rendered clock (docstring)
                path.unlink()
            try:
                lam, om, frozen = fit_tracks(tracks)
            except Exception as exc:  # a fit that fails is a result too
                print(f"<!-- {label} {codec.name}: {exc} -->", file=sys.stderr)
                lam = om = frozen = math.nan
            lam_ref = lam_ref0 = math.nan
            keep = types != "B"
            if (~keep).any() and keep.sum() > 40:
                try:
                    lam_ref = fit_at_frames(tracks, keep)
                    lam_ref0 = fit_at_frames(base_tracks, keep)
                except Exception as exc:  # e.g. a fast decay seen in too few frames
                    print(f"<!-- {label} {codec.name} I/P only: {exc} -->", file=sys.stderr)
            minutes = len(t_s) / fps / 60 * len(sensors)
            rows.append({**common, "codec": codec.name, "lambda": lam, "omega": om,
                         "lambda_base": lam0, "omega_base": om0, "frozen": frozen,
                         "lambda_ref": lam_ref, "lambda_ref_base": lam_ref0,
                         "mb_per_min": size / 1e6 / minutes,
                         "encode_fps": len(t_s) * len(sensors) / encode_cpu_s,
                         "seconds": time.perf_counter() - start})  # fmt: skip
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return rows


def summarise(rows: list[dict[str, object]]) -> None:
    """Print the per-case table and the per-codec medians (markdown)."""
    print("| case | λ true [1/s] | codec | λ vs lossless | λ vs truth | ω vs lossless | "
          "frozen steps | MB/min/sensor | λ vs lossless, I/P frames only |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r['case']} | {r['true_lambda']:.3f} | {r['codec']} | "
            f"{r['lambda'] / r['lambda_base'] - 1:+.3f} | "
            f"{r['lambda'] / r['true_lambda'] - 1:+.3f} "
            f"| {r['omega'] / r['omega_base'] - 1:+.4f} | {r['frozen']:.3f} | "
            f"{r['mb_per_min']:.1f} | {r['lambda_ref'] / r['lambda_ref_base'] - 1:+.3f} |"
        )
    print("\n## Median over cases\n")
    print("| codec | λ vs lossless: median | min | max | λ vs truth: median | "
          "ω vs lossless: median | frozen steps: median | MB/min/sensor | "
          "encode frames/s per core | "
          "I/P frames only: λ vs lossless median | min | max |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for codec in dict.fromkeys(r["codec"] for r in rows):
        sel = [r for r in rows if r["codec"] == codec]
        lam = np.array([r["lambda"] / r["lambda_base"] - 1 for r in sel])
        truth = np.array([r["lambda"] / r["true_lambda"] - 1 for r in sel])
        om = np.array([r["omega"] / r["omega_base"] - 1 for r in sel])
        frozen = np.array([r["frozen"] for r in sel])
        size = np.array([r["mb_per_min"] for r in sel])
        fps = np.array([r["encode_fps"] for r in sel])
        ref = np.array([r["lambda_ref"] / r["lambda_ref_base"] - 1 for r in sel])
        ref_cells = (
            f"{np.nanmedian(ref):+.3f} | {np.nanmin(ref):+.3f} | {np.nanmax(ref):+.3f}"
            if np.isfinite(ref).any()
            else "– | – | –"
        )
        print(
            f"| {codec} | {np.nanmedian(lam):+.3f} | {np.nanmin(lam):+.3f} | "
            f"{np.nanmax(lam):+.3f} | {np.nanmedian(truth):+.3f} | {np.nanmedian(om):+.4f} | "
            f"{np.nanmedian(frozen):.3f} | "
            f"{np.nanmedian(size) if np.isfinite(size).any() else math.nan:.1f} | "
            f"{np.nanmedian(fps) if np.isfinite(fps).any() else math.nan:.0f} | {ref_cells} |"
        )


def plot(rows: list[dict[str, object]], path: Path) -> None:
    """λ bias vs CRF, one line per x264 preset × dead zone, median over cases."""
    from matplotlib.figure import Figure

    from liquidtouch.io.figures import save_figure

    fig = Figure(figsize=(6, 4))
    ax = fig.subplots()
    lines: dict[str, dict[int, list[float]]] = {}
    for r in rows:
        name = str(r["codec"])
        if not name.startswith("x264 ") or "CRF" not in name or name.count(" ") > 5:
            continue
        words = name.split()
        key = " ".join(words[:2] + words[4:])
        lines.setdefault(key, {}).setdefault(int(words[3]), []).append(
            r["lambda"] / r["lambda_base"] - 1
        )
    for key, by_crf in lines.items():
        crfs = sorted(by_crf)
        ax.plot(crfs, [100 * np.nanmedian(by_crf[c]) for c in crfs], "o-", label=key)
    ax.axhline(5, color="0.5", ls=":", lw=1)
    ax.set_xlabel("CRF")
    ax.set_ylabel("λ bias vs lossless, median [%]")
    ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, path)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--full", action="store_true", help="the whole grid and all cases")
    parser.add_argument("--mechanism", action="store_true", help="x264 options one at a time")
    parser.add_argument(
        "--simulator", action="store_true", help="the simulator's encoder settings (ultrafast)"
    )
    parser.add_argument("--jobs", type=int, default=1, help="cases in parallel (processes)")
    parser.add_argument("--figure", type=Path, help="write λ bias vs CRF (PNG)")
    parser.add_argument("--cases", type=int, help="only the first N cases")
    parser.add_argument("--only", help="only the codecs whose name contains this text")
    args = parser.parse_args()
    cv2.setNumThreads(1)
    grid = MECHANISM_GRID if args.mechanism else FULL_GRID if args.full else DEFAULT_GRID
    grid = SIMULATOR_GRID if args.simulator else grid
    cases = (FULL_CASES if args.full else CASES)[: args.cases]
    grid = [codec for codec in grid if args.only is None or args.only in codec.name]
    start = time.perf_counter()
    rows: list[dict[str, object]] = []
    with (
        progress_bar("cases", len(cases)) as advance,
        ProcessPoolExecutor(max_workers=max(1, args.jobs)) as pool,
    ):
        for case_rows in pool.map(run_case, cases, [grid] * len(cases)):
            rows += case_rows
            advance()
    print(f"# codec_bias — {len(cases)} cases × {len(grid)} codecs, fit model "
          f"{FitSettings().model!r}, {time.perf_counter() - start:.0f} s\n")  # fmt: skip
    summarise(rows)
    if args.figure:
        plot(rows, args.figure)
        print(f"\nfigure: {args.figure}")


if __name__ == "__main__":
    main()
