"""Speed and accuracy of one simulated trial's physics (13 s at 240 Hz).

Compares, in the same run, the shipped integration (``slosh.integrate``: RK45,
rtol 1e-5, unrolled float right-hand side) with a baseline (the same model
through the generic vectorised ``accelerations`` at rtol 1e-7, max step 5 ms)
and reports the force error of both against an rtol 1e-9 DOP853 reference.
Also times the whole ``simulate_trial`` (parameters, physics, loads, wrench).

    .venv/bin/python benchmarks/simulate_speed.py
"""

from __future__ import annotations

import time

import numpy as np
from scipy.integrate import solve_ivp

from liquidtouch._core.containers import get_container
from liquidtouch._core.liquids import get_liquid
from liquidtouch.sim.slosh import accelerations, integrate, slosh_system
from liquidtouch.sim.trial import simulate_trial

CASES = [
    ("water", None, 28.0, "grooved-cuboid"),
    ("sugar-water", 160.0, 16.0, "grooved-cuboid"),
    ("detergent", None, 35.0, "grooved-cuboid"),
    ("water", None, 30.0, "glass"),
    ("olive-oil", None, 20.0, "cylinder"),
]
REPEATS = 5


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


def main() -> None:
    import os

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
