"""Segmentation over simulated protocols with random event timings (issue 21).

Each run draws a protocol (``liquidtouch.sim.protocol_scene``: the rig's rules at the
marker level, both gels, the mini sensor at 25 fps): settle before the grasp 0.5-3 s,
lift 0.5-2 s after the grasp, push 0.5-3 s after the lift ends, a push of 0.5-2× the
protocol's 15 mm, hold 8-15 s, lowering 0.1-1 s after the hold and release 0.1-1 s after
the lowering, a liquid of the catalogue (water, mirin, olive oil) at 20-40 mm, a seed.
The camera starts per scenario:

- ``early``: before the grasp (the whole protocol);
- ``lifted``: between the end of the lift and the push;
- ``late``: inside the ring-down, 0.3-3 s after the push ended;

and the stream goes on 2 s after the release. ``live`` (``LiveEstimator``, no protocol
events: it segments on its own) gives the final answer; ``with events`` is the same with
the protocol's events (``run-trial --live``). A run is *right* when the final λ is within
5 % and ω within 1 % of the simulator's truth, *none* when it says "no ring-down found",
*wrong* otherwise.

    python benchmarks/segmentation.py --runs 8          # ~1 run/s·scenario on 2 cores
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time

import numpy as np

from liquidtouch.live.estimator import LiveEstimator
from liquidtouch.sim.protocol_scene import ProtocolTimings, protocol_scene

SCENARIOS = ("early", "lifted", "late")
LIQUIDS = ("water", "mirin", "olive-oil")
SENSORS = ("left", "right")
TOL_DECAY, TOL_FREQ = 0.05, 0.01


def draw(rng: np.random.Generator) -> tuple[ProtocolTimings, dict]:
    """Random event timings (module docstring) and the liquid."""
    base = ProtocolTimings()
    grasp = rng.uniform(0.5, 3.0)
    lift = grasp + base.grasp_duration_s + rng.uniform(0.5, 2.0)
    timings = ProtocolTimings(grasp_s=grasp, lift_s=lift, hold_s=rng.uniform(8.0, 15.0),
                              push_distance_mm=base.push_distance_mm * rng.uniform(0.5, 2.0),
                              lower_after_s=rng.uniform(0.1, 1.0),
                              release_after_s=rng.uniform(0.1, 1.0))  # fmt: skip
    push = lift + timings.lift_duration_s + rng.uniform(0.5, 3.0)
    timings = ProtocolTimings(**{**timings.__dict__, "push_s": push})
    liquid = {"liquid": str(rng.choice(LIQUIDS)), "height_mm": float(rng.uniform(20, 40)),
              "seed": int(rng.integers(1_000_000))}  # fmt: skip
    return timings, liquid


def camera_start(scenario: str, timings: ProtocolTimings, rng: np.random.Generator) -> float:
    events = timings.events()
    if scenario == "early":
        return rng.uniform(0.0, events["grasp"] - 0.2)
    if scenario == "lifted":
        return rng.uniform(events["lift"] + timings.lift_duration_s, events["push"] - 0.2)
    return events["pushed"] + rng.uniform(0.3, 3.0)


def stream(scene, events: dict[str, float] | None) -> object:
    """The final update of ``LiveEstimator`` over the scene (events given when due)."""
    estimator = LiveEstimator(list(SENSORS), protocol=events is not None)
    given = set()
    for k, t_s in enumerate(scene.t):
        for name, when in (events or {}).items():
            if name not in given and when <= t_s:
                estimator.add_event(name, when)
                given.add(name)
        for s, name in enumerate(SENSORS):
            estimator.add_markers(name, t_s + 1e-3 * s, scene.positions[s, k])
    return estimator.finish()


def judge(final, scene) -> dict:
    lam, omega = final.decay_rate, final.angular_frequency
    e_lam = lam / scene.true_decay_rate - 1 if math.isfinite(lam) else math.nan
    e_om = omega / scene.true_angular_frequency - 1 if math.isfinite(omega) else math.nan
    if math.isfinite(e_lam) and abs(e_lam) < TOL_DECAY and abs(e_om) < TOL_FREQ:
        outcome = "right"
    elif final.message.startswith("no ring-down found"):
        outcome = "none"
    else:
        outcome = "wrong"
    return {"outcome": outcome, "err_decay_rate": e_lam, "err_angular_frequency": e_om}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=8, help="per scenario")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", help="write every run here")
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    rows = []
    began = time.monotonic()
    for scenario in SCENARIOS:
        for _ in range(args.runs):
            timings, liquid = draw(rng)
            start = camera_start(scenario, timings, rng)
            scene = protocol_scene(**liquid, timings=timings, camera_start_s=start)
            for mode, events in (("live", None), ("with events", scene.events)):
                known = {n: t for n, t in (events or {}).items() if t >= scene.t[0]}
                row = {"scenario": scenario, "mode": mode, **liquid,
                       "push_x": timings.push_distance_mm / 15.0, "hold_s": timings.hold_s,
                       **judge(stream(scene, known if events else None), scene)}  # fmt: skip
                rows.append(row)
                print(json.dumps(row), file=sys.stderr, flush=True)
    print(f"{len(rows)} runs in {time.monotonic() - began:.0f} s\n")
    print("| scenario | mode | runs | right | none found | wrong | λ error median [min, max] | "
          "max abs ω error |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|")
    for scenario in SCENARIOS:
        for mode in ("live", "with events"):
            sel = [r for r in rows if r["scenario"] == scenario and r["mode"] == mode]
            right = [r for r in sel if r["outcome"] == "right"]
            lam = np.array([r["err_decay_rate"] for r in right]) * 100
            om = np.array([abs(r["err_angular_frequency"]) for r in right]) * 100
            count = {k: sum(r["outcome"] == k for r in sel) for k in ("right", "none", "wrong")}
            lam_text = (f"{np.median(lam):+.1f} % [{lam.min():+.1f}, {lam.max():+.1f}]"
                        if lam.size else "–")  # fmt: skip
            om_text = f"{om.max():.2f} %" if om.size else "–"
            print(f"| {scenario} | {mode} | {len(sel)} | {count['right']} | {count['none']} | "
                  f"{count['wrong']} | {lam_text} | {om_text} |")  # fmt: skip
    wrong = [r for r in rows if r["outcome"] == "wrong"]
    for r in wrong:
        print(f"wrong: {r}")
    if args.json:
        with open(args.json, "w", encoding="utf-8") as out:
            json.dump(rows, out, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
