"""The default fit's λ and ω against the simulator's truth, and where the error comes from.

Per trial (every liquid of ``LIQUIDS`` × ``--fills`` × pushes of 0.5, 1 and 2 × 15 mm ×
``--seeds``): ``simulate_trial``; the **marker** signal (both gels' true marker positions,
GelSight Mini profile at 25 fps, plus ``NOISE_PX`` of tracking noise, through
``tactile_signal``: the 4 Hz low-pass and the PCA) and the **force** signal (the total
lateral gel force, read at the same clock, the same 4 Hz low-pass); each through the default
fit (``FitSettings``, its window and model choice; ``noise="white"`` only to save the
jackknife's time: λ and ω are the same). The truth is the simulator's: the small-amplitude
eigenvalue of the slow mode (``SimulatedTrial.true_decay_rate``).

Table 1: λ/λ_true − 1 and ω/ω_true − 1 per liquid and push, median [10th, 90th
percentile] and the share beyond 5 % (λ) / 1 % (ω).

Table 2, the decomposition: the same marker-level trials with one ingredient changed at a
time (module constants patched for the run, nothing shipped):

- ``p = 2``: the amplitude model's exponent held at 2, the simulator's own damping law
  (``fit.amplitude_solve.EXPONENT_BOUNDS``; the default fits p in [1, 2]);
- ``amplitude, p = 2``: that, and the amplitude model always reported, its gain kept
  however small (the default reports the model of lowest BIC, and a single mode when the
  gain does not lower it);
- ``least squares``: ``loss="ls"`` instead of the paper's loss;
- ``window to the noise``: the default fit refitted on its window up to where its fitted
  envelope reaches its noise std (the samples after it are noise);
- ``linear damping``: the simulator's amplitude-dependent damping off (``sim.slosh``'s
  κ1 = κ2 = 0), so the decay rate is λ_true at every amplitude;
- ``Newtonian``: the shear thinning off (only detergent has it);
- ``no slip``: the grasp's slip drift off (its time constant 10⁹ s);
- ``no marker noise``: no tracking noise;
- ``clean``: ``Variability.none()``, no slip drift, no marker noise, linear damping.

    nice -n 10 .venv/bin/python benchmarks/fit_bias.py [--seeds 1 2] [--fills 20 30 38]
        [--variants default "p = 2" ...]
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import itertools
import math
import shlex
import sys
import time
from collections.abc import Iterator
from unittest import mock

import numpy as np

import liquidtouch.fit.amplitude_solve as amplitude_solve
import liquidtouch.fit.oscillation as oscillation
import liquidtouch.sim.slosh as slosh
import liquidtouch.sim.trial as sim_trial
from liquidtouch.errors import LiquidTouchError
from liquidtouch.extraction.fit_settings import FitSettings
from liquidtouch.fit.oscillation import MIN_DURATION_S, fit_oscillation
from liquidtouch.fit.selection import Selection, select_model
from liquidtouch.signal.lowpass import DEFAULT_LOWPASS_HZ, lowpass
from liquidtouch.signal.tactile import tactile_signal
from liquidtouch.sim.gelsight import sensor_scene
from liquidtouch.sim.sensors import get_sensor_profile
from liquidtouch.sim.trial import simulate_trial
from liquidtouch.sim.variability import Variability
from liquidtouch.testing.scene_tracks import noisy_true_tracks

LIQUIDS = ("water", "olive-oil", "mirin", "corn-oil", "sugar-water 60", "sugar-water 140",
           "detergent")  # fmt: skip
PUSHES = (0.5, 1.0, 2.0)
NOISE_PX = 0.02
TOL_DECAY, TOL_FREQ = 0.05, 0.01
VARIANTS = ("default", "p = 2", "amplitude, p = 2", "least squares", "window to the noise",
            "linear damping", "Newtonian", "no slip", "no marker noise", "clean")  # fmt: skip


def _amplitude_kept(candidates: dict) -> Selection:
    """The amplitude model whatever the criterion says (its gain is then never dropped)."""
    chosen = select_model(candidates)
    if "amplitude" not in chosen.bic:  # a single-mode fit asked for (the ring-down check)
        return chosen
    return Selection("amplitude", chosen.bic, chosen.n_effective)


@contextlib.contextmanager
def variant(name: str) -> Iterator[dict]:
    """Patch the simulator or the fit for one variant (module docstring); yields the
    ``simulate_trial`` keywords and the marker noise."""
    settings: dict = {"parameters": {}, "noise_px": NOISE_PX}
    with contextlib.ExitStack() as stack:
        if name in ("p = 2", "amplitude, p = 2"):
            stack.enter_context(mock.patch.object(amplitude_solve, "EXPONENT_BOUNDS",
                                                  (2.0, 2.0 + 1e-6)))  # fmt: skip
        if name == "amplitude, p = 2":
            stack.enter_context(mock.patch.object(oscillation, "select_model", _amplitude_kept))
        if name in ("linear damping", "clean"):
            stack.enter_context(mock.patch.object(slosh, "NONLINEAR_GAIN", 0.0))
            stack.enter_context(mock.patch.object(slosh, "BREAKING_GAIN", 0.0))
        if name == "Newtonian":
            get = sim_trial.get_liquid
            stack.enter_context(mock.patch.object(sim_trial, "get_liquid", lambda *a, **k:
                dataclasses.replace(get(*a, **k), shear_thinning=False)))  # fmt: skip
        if name in ("no slip", "clean"):
            settings["parameters"]["slip_time_constant_s"] = 1e9
        if name in ("no marker noise", "clean"):
            settings["noise_px"] = 0.0
        if name == "clean":
            settings["variability"] = Variability.none()
        yield settings


def signals(liquid: str, height: float, push: float, seed: int, settings: dict):
    """(marker signal, force signal on its clock, true λ, true ω) of one trial."""
    name, _, sugar = liquid.partition(" ")
    extra = {"sugar_concentration": float(sugar)} if sugar else {}
    parameters = {"push_distance_mm": 15.0 * push, **settings["parameters"]}
    trial = simulate_trial(name, height_mm=height, seed=seed, parameters=parameters,
                           variability=settings.get("variability"), **extra)  # fmt: skip
    rng = np.random.default_rng(10_000 + seed)
    scene = sensor_scene(trial.loads, get_sensor_profile("mini"), rng, jitter=False)
    sig = tactile_signal(noisy_true_tracks(scene, rng, settings["noise_px"]))
    force = np.interp(sig.t, trial.t_s, trial.slosh_force_n())
    force = lowpass(force, sig.fps, DEFAULT_LOWPASS_HZ)
    return sig, force, trial.true_decay_rate, trial.true_angular_frequency


def errors(
    t: np.ndarray, u: np.ndarray, lam: float, omega: float, name: str = "default"
) -> tuple[float, float]:
    """(λ, ω) relative errors of the default fit (or the variant ``name``'s); NaN when it
    refuses. ``window to the noise``: refitted on the window up to where the first fit's
    envelope reaches its noise std (``ln(|A| / σ) / λ`` after its start, at least
    ``MIN_DURATION_S``)."""
    settings = FitSettings(noise="white", loss="ls" if name == "least squares" else "paper")
    try:
        fit = settings.fit(t, u)
        if name == "window to the noise":
            t_w, u_w = settings.window(t, u)
            ring_s = math.log(max(abs(fit.amplitude) / fit.noise_std, 1.0)) / fit.decay_rate
            keep = t_w <= t_w[0] + max(ring_s, MIN_DURATION_S)
            fit = fit_oscillation(t_w[keep], u_w[keep], **settings.fit_options())
    except LiquidTouchError:
        return np.nan, np.nan
    return fit.decay_rate / lam - 1, fit.angular_frequency / omega - 1


def summary(values: list[float], tol: float, digits: int = 1) -> str:
    v = np.asarray(values, dtype=float)
    ok = v[np.isfinite(v)]
    beyond = np.mean(~(np.abs(v) <= tol))  # a refused fit counts as beyond
    if ok.size == 0:
        return f"refused · {beyond:.0%}"
    p10, p50, p90 = 100 * np.percentile(ok, [10, 50, 90])
    return f"{p50:+.{digits}f} [{p10:+.{digits}f}, {p90:+.{digits}f}] % · {beyond:.0%}"


def default_table(default: list[dict]) -> None:
    """Table 1 (module docstring): the default fit per liquid and push, marker and force."""
    print("## Default fit vs the simulator's truth, marker and force level\n")
    print("| liquid | push | n | λ marker | λ force | ω marker | ω force |")
    print("|---|---|---|---|---|---|---|")
    groups = [(liq, push) for liq in LIQUIDS for push in (*PUSHES, None)] + [("all", None)]
    for liquid, push in groups:
        sel = [r for r in default if liquid in ("all", r["liquid"]) and push in (None, r["push"])]
        cells = [
            summary([r[level][k] for r in sel], tol, 2 * k + 1)
            for k, tol in ((0, TOL_DECAY), (1, TOL_FREQ))
            for level in ("marker", "force")
        ]
        label = "all" if push is None else f"{push:g}×"
        print(f"| {liquid} | {label} | {len(sel)} | " + " | ".join(cells) + " |")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--fills", type=float, nargs="+", default=[20.0, 30.0, 38.0])
    parser.add_argument("--variants", nargs="+", default=list(VARIANTS), choices=VARIANTS)
    args = parser.parse_args()
    began = time.monotonic()
    rows: list[dict] = []
    for name in args.variants:
        liquids = ("detergent",) if name == "Newtonian" else LIQUIDS
        grid = itertools.product(liquids, args.fills, PUSHES, args.seeds)
        for liquid, height, push, seed in grid:
            with variant(name) as settings:
                sig, force, lam, omega = signals(liquid, height, push, seed, settings)
                marker = errors(sig.t, sig.u, lam, omega, name)
                at_force = errors(sig.t, force, lam, omega) if name == "default" else None
            rows.append(dict(variant=name, liquid=liquid, push=push, marker=marker, force=at_force))
        print(f"{name} done ({time.monotonic() - began:.0f} s)", file=sys.stderr, flush=True)
    took = time.monotonic() - began
    n_trials = len(args.fills) * len(PUSHES) * len(args.seeds)
    print(f"# fit_bias — {n_trials} trials per liquid and variant ({took:.0f} s)\n")
    print(
        "Cells: median [10th, 90th percentile] of the relative error · share beyond "
        f"{TOL_DECAY:.0%} (λ) or {TOL_FREQ:.0%} (ω), a refused fit counted beyond.\n"
    )
    default = [r for r in rows if r["variant"] == "default"]
    if default:
        default_table(default)
    print("\n## Where the λ error comes from: one ingredient changed at a time (marker level)\n")
    print("| liquid | " + " | ".join(args.variants) + " |")
    print("|---" * (len(args.variants) + 1) + "|")
    for liquid in (*LIQUIDS, "all but detergent"):
        cells = []
        for name in args.variants:
            sel = [
                r
                for r in rows
                if r["variant"] == name
                and (
                    liquid == r["liquid"]
                    or (liquid == "all but detergent" and r["liquid"] != "detergent")
                )
            ]
            cells.append(summary([r["marker"][0] for r in sel], TOL_DECAY) if sel else "–")
        print(f"| {liquid} | " + " | ".join(cells) + " |")
    print(f"\ncommand: `{shlex.join(['python', *sys.argv])}`")
    return 0


if __name__ == "__main__":
    sys.exit(main())
