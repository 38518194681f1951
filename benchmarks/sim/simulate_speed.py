"""Speed and accuracy of one simulated trial's physics (13 s at 240 Hz).

Compares, in the same run, the shipped integration (``slosh.integrate``: RK45,
rtol 1e-5, unrolled float right-hand side) with a baseline (the same model
through the generic vectorised ``accelerations`` at rtol 1e-7, max step 5 ms)
and reports the force error of both against an rtol 1e-9 DOP853 reference.
Also times the whole ``simulate_trial`` (parameters, physics, loads, wrench).

Videos (issue 27): one ``simulate trial`` with videos (default sensor, 640 × 480,
13 s; ``simulate_trial`` + ``write_trial`` in this process) against decoding its
own two videos (decode-only: the grey frames ``extract`` reads, ``io.frames.iter_video``,
and the RGB frames, PyAV ``rgb24``), and the same trial with the renderer before
issue 27 (``src/liquidtouch/sim/render.py`` at git revision 675ffb2, loaded from git by
:func:`renderer_at`; sensors one after the other), alternating
old and new; then the renderer alone, frames per second per core (process CPU
time) before and after, and the ``liquidtouch simulate trial`` command's wall time
(a fresh process: imports included).

    .venv/bin/python benchmarks/simulate_speed.py [--videos-only] [--repeats N]
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from types import ModuleType

import numpy as np
from scipy.integrate import solve_ivp

import liquidtouch.sim.gelsight as gelsight
from liquidtouch.sim import get_container, get_liquid
from liquidtouch.sim.slosh import accelerations, integrate, slosh_system
from liquidtouch.sim.trial import simulate_trial
from liquidtouch.sim.trial_io import write_trial

CASES = [
    ("water", None, 28.0, "grooved-cuboid"),
    ("sugar-water", 160.0, 16.0, "grooved-cuboid"),
    ("detergent", None, 35.0, "grooved-cuboid"),
    ("water", None, 30.0, "glass"),
    ("olive-oil", None, 20.0, "cylinder"),
]
REPEATS = 5
#: main at the merge of issue 25: its renderer is the one before issue 27 (``render.py``
#: there is what the frozen ``benchmarks/render_v0.py`` copied)
OLD_RENDERER_REVISION = "675ffb2"
REPO = Path(__file__).resolve().parents[2]
CLI = "import sys; from liquidtouch.cli import run; sys.argv[0] = 'liquidtouch'; run()"


def push(t: float) -> float:
    tau = (t - 1.0) / 0.3
    return 0.0 if tau <= 0 or tau >= 1 else 0.015 / 0.09 * (60 * tau - 180 * tau**2 + 120 * tau**3)


def baseline(system, t, y0, rtol=1e-7, max_step=0.005, method="RK45"):
    def rhs(tt, y):
        acc, rel = accelerations(system, y)
        out = [y[1], acc - push(tt)]
        for i in range(len(system.modes)):
            out += [y[3 + 2 * i], rel[i]]
        return out

    return solve_ivp(
        rhs,
        (t[0], t[-1]),
        y0,
        t_eval=t,
        rtol=rtol,
        atol=rtol * 1e-4,
        max_step=max_step,
        method=method,
    ).y


def best_time(fn) -> tuple[float, object]:
    times, out = [], None
    for _ in range(REPEATS):
        start = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - start)
    return min(times), out


def run_case(liquid: str, conc: float | None, h: float, container: str) -> str:
    t = np.arange(0.0, 13.0 + 1e-9, 1 / 240)
    system = slosh_system(get_liquid(liquid, sugar_concentration=conc), get_container(container), h)
    y0 = np.zeros(6)

    def force(y: np.ndarray) -> np.ndarray:
        return system.support_stiffness_n_m * y[0] + system.support_damping_n_s_m * y[1]

    ref = force(baseline(system, t, y0, rtol=1e-9, max_step=0.002, method="DOP853"))
    ours_s, ours = best_time(lambda: integrate(system, t, push, y0))
    base_s, base = best_time(lambda: baseline(system, t, y0))
    scale = np.abs(ref).max()
    err_ours = np.abs(force(ours) - ref).max() / scale
    err_base = np.abs(force(base) - ref).max() / scale
    trial_s, _ = best_time(
        lambda: simulate_trial(liquid, sugar_concentration=conc, height_mm=h, container=container)
    )
    name = f"{liquid}{'' if conc is None else f' c={conc:g}'} h={h:g} {container}"
    return (
        f"| {name} | {ours_s * 1e3:.0f} | {base_s * 1e3:.0f} | {base_s / ours_s:.1f}x | "
        f"{err_ours:.1e} | {err_base:.1e} | {trial_s * 1e3:.0f} |"
    )


def clocks() -> tuple[float, float]:
    return time.perf_counter(), time.process_time()


def since(start: tuple[float, float]) -> tuple[float, float]:
    wall, cpu = clocks()
    return wall - start[0], cpu - start[1]


def renderer_at(revision: str) -> ModuleType:
    """``liquidtouch.sim.render`` as it was at git ``revision``, loaded as a module of its own
    (``git show`` of the repository this script is in); it imports the rest of liquidtouch
    from the working tree (the sensor profiles, the errors)."""
    path = "src/liquidtouch/sim/render.py"
    shown = subprocess.run(
        ["git", "-C", str(REPO), "show", f"{revision}:{path}"], capture_output=True, text=True
    )
    if shown.returncode != 0:
        raise SystemExit(f"cannot read {path} at {revision} from git: {shown.stderr.strip()}")
    name = f"render_at_{revision}"
    with tempfile.TemporaryDirectory(prefix="render-at-") as tmp:
        source = Path(tmp) / f"{name}.py"
        source.write_text(shown.stdout, encoding="utf-8")
        spec = importlib.util.spec_from_file_location(name, source)
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module  # dataclasses look their module up while it loads
        spec.loader.exec_module(module)
    return module


def decode_grey(paths: list[Path]) -> None:
    from liquidtouch.io.frames import iter_video

    for path in paths:
        for _ in iter_video(path):
            pass


def decode_rgb(paths: list[Path]) -> None:
    import av

    for path in paths:
        with av.open(str(path)) as container:
            for frame in container.decode(video=0):
                frame.to_ndarray(format="rgb24")


class _Sequential(ThreadPoolExecutor):
    def __init__(self, max_workers=None):
        super().__init__(max_workers=1)


def write_old(trial, out: Path, old_renderer: ModuleType) -> None:
    """``write_trial`` with the renderer ``old_renderer`` (:func:`renderer_at`) and the sensors in
    sequence."""
    saved = gelsight.iter_frames, gelsight.ThreadPoolExecutor
    gelsight.iter_frames, gelsight.ThreadPoolExecutor = old_renderer.iter_frames, _Sequential
    try:
        write_trial(trial, out)
    finally:
        gelsight.iter_frames, gelsight.ThreadPoolExecutor = saved


def video_section(repeats: int, old_renderer: ModuleType) -> None:
    import cv2

    from liquidtouch.sim.sensors import get_sensor_profile

    print("## `simulate trial` with videos vs decoding its videos (default sensor, 13 s)\n")
    print(f"machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}; "
          f"best of {repeats}, old and new alternating\n")  # fmt: skip
    work = Path(tempfile.mkdtemp(prefix="simspeed-"))
    kwargs = dict(height_mm=25.0, container="grooved-cuboid", seed=1)
    best: dict[str, list[float]] = {}

    def keep(label: str, wall_cpu: tuple[float, float]) -> None:
        old = best.get(label, [np.inf, np.inf])
        best[label] = [min(old[0], wall_cpu[0]), min(old[1], wall_cpu[1])]

    for i in range(repeats):
        start = clocks()
        trial = simulate_trial("water", **kwargs)
        write_trial(trial, work / f"new{i}")
        keep("simulate trial (new)", since(start))
        start = clocks()
        trial = simulate_trial("water", **kwargs)
        write_old(trial, work / f"old{i}", old_renderer)
        keep("simulate trial (before issue 27)", since(start))
        videos = [work / f"new{i}" / f"{s}.mp4" for s in ("left", "right")]
        start = clocks()
        decode_grey(videos)
        keep("decode-only, grey (what extract reads)", since(start))
        start = clocks()
        decode_rgb(videos)
        keep("decode-only, RGB (PyAV rgb24)", since(start))
        start = clocks()
        subprocess.run(
            [sys.executable, "-c", CLI, "simulate", "trial", "--liquid", "water",
             "--height-mm", "25", "--seed", "1", "--out", str(work / f"cli{i}")],
            check=True, capture_output=True,
        )  # fmt: skip
        wall, _ = since(start)
        keep("`liquidtouch simulate trial` command (fresh process)", (wall, np.nan))
    n_frames = sum(sum(1 for _ in __import__("av").open(str(v)).decode(video=0)) for v in videos)
    grey, rgb = (
        best["decode-only, grey (what extract reads)"],
        best["decode-only, RGB (PyAV rgb24)"],
    )
    print("| step | wall s | CPU s | wall / grey decode | wall / RGB decode |")
    print("|---|---:|---:|---:|---:|")
    for label, (wall, cpu) in best.items():
        print(
            f"| {label} | {wall:.2f} | {cpu:.2f} | {wall / grey[0]:.2f}x | {wall / rgb[0]:.2f}x |"
        )
    print(f"\n({n_frames} frames in the two videos)\n")

    print("## Renderer alone: frames per second per core (process CPU time, cv2 on one thread)\n")
    cv2.setNumThreads(1)
    print("| sensor | before issue 27 | now | speed-up | max abs pixel difference |")
    print("|---|---:|---:|---:|---:|")
    for name in ("default", "mini"):
        profile = get_sensor_profile(name)
        trial = simulate_trial("water", **kwargs)
        scene = gelsight.sensor_scene(trial.loads, profile, np.random.default_rng(1))
        args = dict(
            background=gelsight.make_background(profile, np.random.default_rng(2)),
            contact_center_px=scene.geometry.center_px[0],
            contact_radius_px=float(scene.geometry.radius_px[0]),
            contact_offsets_px=scene.offsets_px[0],
        )
        times: dict[str, float] = {}
        for _ in range(repeats):
            for label, fn in (("old", old_renderer.iter_frames), ("new", gelsight.iter_frames)):
                start = clocks()
                for _frame in fn(scene.positions_px[0], profile, np.random.default_rng(3), **args):
                    pass
                times[label] = min(times.get(label, np.inf), since(start)[1])
        pos, rng = scene.positions_px[0], np.random.default_rng
        pairs = zip(
            old_renderer.iter_frames(pos, profile, rng(3), **args),
            gelsight.iter_frames(pos, profile, rng(3), **args),
            strict=True,
        )
        diff = max(int(np.abs(a.astype(int) - b.astype(int)).max()) for a, b in pairs)
        n = len(scene.timestamps_s)
        print(f"| {name} | {n / times['old']:.0f} | {n / times['new']:.0f} | "
              f"{times['old'] / times['new']:.2f}x | {diff} |")  # fmt: skip
    cv2.setNumThreads(-1)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--videos-only", action="store_true", help="only the video sections")
    parser.add_argument("--repeats", type=int, default=3, help="repeats of the video sections")
    args = parser.parse_args()
    video_section(args.repeats, renderer_at(OLD_RENDERER_REVISION))
    if args.videos_only:
        return
    print()

    print(
        f"machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} "
        f"(timings are best of {REPEATS})\n"
    )
    print(
        "| case | shipped [ms] | baseline [ms] | speed-up | shipped force err "
        "| baseline force err | simulate_trial [ms] |"
    )
    print("|---|---|---|---|---|---|---|")
    for case in CASES:
        print(run_case(*case))


if __name__ == "__main__":
    main()
