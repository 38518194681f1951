"""Gaps are gaps (issue 23): λ and ω of recordings with camera stalls and dropped frames.

What it does, per run (``--runs``, 40 by default; seed = run number):

1. ``liquidtouch.simulate_trial`` of a liquid (water, olive oil, mirin, corn oil,
   detergent in turn) at a drawn fill height (18-32 mm) and its rendered markers'
   true positions on both sensors (``sim.gelsight.sensor_scene``, GelSight Mini
   profile, 25 fps, no rendering or tracking), plus 0.01 px of tracking noise.
2. The gap-free reference: ``tactile_signal`` of all frames and the default fit
   (``extract``'s), with the correlated-noise standard errors
   (``FitSettings(noise="correlated")``: the noise model changes only the ±, which the
   "at best" share below uses).
3. The same frames with frames taken out, fitted the same way:

   - ``stall S s``: both sensors deliver no frame for S s (0.3, 0.6, 1.0), the stall
     starting anywhere (uniformly) in the first three e-folding times 3/λ of the
     ring-down (at most the end of the recording minus the stall), from the largest
     excursion of the reference signal on;
   - ``15-18 fps``: each sensor keeps each frame independently with probability
     (15-18 fps drawn uniformly) / 25, so gaps of 1, 2, 3, ... frames come irregularly;
   - ``no gap, noise redrawn``: every frame, with the tracking noise drawn again — how
     often the gap-free fit itself moves beyond the tolerances when only 0.01 px of noise
     changes (a yardstick, not a strict bound: a gapped fit keeps most of the reference's
     noise, a redraw none of it).

Reported: the share of runs with λ within 5 % and ω within 0.5 % of the gap-free fit
(a refused fit counts as outside), over all runs and over the runs where the library
did not report that a gap swallowed the ring-down
(:func:`~liquidtouch.extraction.fit_settings.ring_down_swallowed`: gaps cover half or more of the
ring-down above the noise, the CLI warns; or the fit was refused with
``SwallowedRingDownError``: no oscillation, and a gap where the ring-down starts), the
number of such reports and of refusals (both kinds),
and the median and 95th percentile of |λ/λ_ref − 1| and |ω/ω_ref − 1|.

**At best** (what any fit at its own standard errors could score), from the fits'
correlated-noise standard errors (the asymptotic std of the least-squares fit under the
noise's estimated autocorrelation). For an estimator at that std, the difference between
the fit of a subset of the samples and the fit of all of them has variance Var(subset) −
Var(all) (Hausman: the full fit is the efficient one of the two); with the noise redrawn,
Var(redrawn) + Var(all). The chance that a Gaussian difference of that std lands within
the tolerance, the smaller of λ's and ω's (an upper bound of both together), averaged
over the runs, is the share an estimator with those standard errors would score; a
target above it asks the fit to be more precise than the samples allow.

    nice -n 10 .venv/bin/python benchmarks/gaps.py [--runs N]
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from typing import NamedTuple

import numpy as np
from scipy.stats import norm

from liquidtouch.errors import LiquidTouchError, SwallowedRingDownError
from liquidtouch.extraction.fit_settings import FitSettings, ring_down_swallowed
from liquidtouch.signal.tactile import tactile_signal
from liquidtouch.sim.gelsight import SensorScene, sensor_scene
from liquidtouch.sim.sensors import get_sensor_profile
from liquidtouch.sim.trial import simulate_trial
from liquidtouch.testing.scene_tracks import keep_frames, noisy_true_tracks
from liquidtouch.tracking.tracks import MarkerTracks

LIQUIDS = ("water", "olive-oil", "mirin", "corn-oil", "detergent")
STALLS_S = (0.3, 0.6, 1.0)
PROFILE = "mini"
NOISE_PX = 0.01
LAMBDA_TOL, OMEGA_TOL = 0.05, 0.005
#: the comparison's yardstick: every frame kept, the 0.01 px tracking noise drawn again
NOISE_REDRAWN = "no gap, noise redrawn"


def truth_tracks(seed: int) -> tuple[list[MarkerTracks], SensorScene]:
    """Both sensors' true marker positions of one simulated trial, with tracking noise, and
    the scene (to draw the noise again)."""
    rng = np.random.default_rng(seed)
    liquid = LIQUIDS[seed % len(LIQUIDS)]
    trial = simulate_trial(liquid, height_mm=float(rng.uniform(18, 32)), seed=seed)
    scene = sensor_scene(trial.loads, get_sensor_profile(PROFILE), rng, jitter=False)
    return noisy_true_tracks(scene, rng, NOISE_PX), scene


class Fit(NamedTuple):
    """What the benchmark keeps of one fit (NaN when refused)."""

    decay_rate: float
    angular_frequency: float
    t0: float  # decay start [s]
    swallowed: bool  # the library reported that a gap swallowed the ring-down
    decay_rate_std: float  # correlated-noise standard errors
    angular_frequency_std: float


def fit(tracks: list[MarkerTracks]) -> Fit:
    """The default fit of ``tracks``' signal, with its correlated-noise standard errors."""
    try:
        sig = tactile_signal(tracks)
        result = FitSettings(noise="correlated").fit(sig.t, sig.u)
    except SwallowedRingDownError:  # refused, naming the gap
        return Fit(math.nan, math.nan, math.nan, True, math.nan, math.nan)
    except LiquidTouchError:
        return Fit(math.nan, math.nan, math.nan, False, math.nan, math.nan)
    return Fit(
        result.decay_rate,
        result.angular_frequency,
        result.t0,
        ring_down_swallowed(result),
        result.decay_rate_std,
        result.angular_frequency_std,
    )


def best_share(reference: Fit, other: Fit, redrawn: bool) -> float:
    """Chance that an estimator at the fits' standard errors lands within both tolerances
    (module docstring, "at best")."""
    chances = []
    for value, std_ref, std_other, tol in (
        (reference.decay_rate, reference.decay_rate_std, other.decay_rate_std, LAMBDA_TOL),
        (reference.angular_frequency, reference.angular_frequency_std,
         other.angular_frequency_std, OMEGA_TOL),
    ):  # fmt: skip
        var = std_other**2 + std_ref**2 if redrawn else std_other**2 - std_ref**2
        if not math.isfinite(var):
            return 0.0
        chances.append(2.0 * norm.cdf(tol * value / math.sqrt(max(var, 1e-300))) - 1.0)
    return min(chances)


def setting_tracks(
    tracks: list[MarkerTracks], redrawn: list[MarkerTracks], ref: tuple, rng: np.random.Generator
) -> dict[str, list[MarkerTracks]]:
    """Each setting's tracks (module docstring, 3): ``tracks`` with frames taken out, or
    ``redrawn`` (the same scene with its noise drawn again)."""
    lam, start = ref.decay_rate, ref.t0
    t = tracks[0].t
    out = {}
    for stall in STALLS_S:
        latest = min(start + 3.0 / lam, t[-1] - stall - 0.5)
        begin = rng.uniform(start, max(latest, start))
        kept = ~((t > begin) & (t < begin + stall))
        out[f"stall {stall:g} s"] = keep_frames(tracks, [kept, kept])
    fps = rng.uniform(15, 18)
    p = fps / get_sensor_profile(PROFILE).fps
    keep = [rng.random(tr.t.size) < p for tr in tracks]
    for k in keep:
        k[[0, -1]] = True
    out["15-18 fps"] = keep_frames(tracks, keep)
    out[NOISE_REDRAWN] = redrawn
    return out


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--runs", type=int, default=40)
    args = parser.parse_args()
    start_time = time.perf_counter()
    rows: dict[str, list[tuple[float, float, bool, float]]] = {}
    by_liquid: dict[tuple[str, str], list[tuple[bool, float]]] = {}
    for run in range(args.runs):
        tracks, scene = truth_tracks(run)
        ref = fit(tracks)
        if not math.isfinite(ref.decay_rate):
            print(f"run {run}: the gap-free fit failed", file=sys.stderr)
            continue
        rng = np.random.default_rng(10_000 + run)
        liquid = LIQUIDS[run % len(LIQUIDS)]
        redrawn = noisy_true_tracks(scene, np.random.default_rng(20_000 + run), NOISE_PX)
        for name, setting in setting_tracks(tracks, redrawn, ref, rng).items():
            got = fit(setting)
            best = best_share(ref, got, name == NOISE_REDRAWN)
            err = (
                abs(got.decay_rate / ref.decay_rate - 1),
                abs(got.angular_frequency / ref.angular_frequency - 1),
            )
            rows.setdefault(name, []).append((*err, got.swallowed, best))
            ok = err[0] <= LAMBDA_TOL and err[1] <= OMEGA_TOL
            by_liquid.setdefault((name, liquid), []).append((ok, best))
        print(f"run {run} done", file=sys.stderr)
    print(f"# gaps — {args.runs} simulated trials per setting ({PROFILE} profile, 25 fps)\n")
    print(
        f"Share of runs with λ within {LAMBDA_TOL:.0%} and ω within {OMEGA_TOL:.1%} of the "
        "gap-free fit (a refused fit counts as outside): over all runs, and over the runs "
        "where the library did not report that a gap swallowed the ring-down; the reports "
        "and refusals; the errors' median / p95 over all runs; at best: the share an "
        "estimator at the fits' correlated-noise standard errors would score (docstring).\n"
    )
    print(
        "| setting | within both, all runs | at best | reported swallowed | within both, not "
        "reported | refused | λ median / p95 | ω median / p95 |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for name, errs in rows.items():
        e = np.array([r[:2] for r in errs], dtype=float)
        swallowed = np.array([r[2] for r in errs])
        best = np.mean([r[3] for r in errs])
        ok = (e[:, 0] <= LAMBDA_TOL) & (e[:, 1] <= OMEGA_TOL)
        refused = int(np.sum(~np.isfinite(e[:, 0])))
        kept = ok[~swallowed]
        e = np.where(np.isfinite(e), e, np.inf)
        q = np.percentile(e, [50, 95], axis=0, method="higher")  # refused: inf, not NaN
        print(
            f"| {name} | {ok.mean():.0%} ({len(ok)}) | {best:.0%} | {int(swallowed.sum())} | "
            f"{kept.mean():.0%} ({len(kept)}) | {refused} | {100 * q[0, 0]:.1f} / "
            f"{100 * q[1, 0]:.1f} % | {100 * q[0, 1]:.2f} / {100 * q[1, 1]:.2f} % |"
        )
    print("\nPer liquid: share within both (all runs), and at best.\n")
    settings = list(dict.fromkeys(name for name, _ in by_liquid))
    print("| liquid | " + " | ".join(settings) + " |")
    print("|---|" + "---|" * len(settings))
    for liquid in LIQUIDS:
        cells = [by_liquid.get((name, liquid), []) for name in settings]
        shares = [
            f"{np.mean([ok for ok, _ in c]):.0%} / {np.mean([b for _, b in c]):.0%} ({len(c)})"
            for c in cells
        ]
        print(f"| {liquid} | " + " | ".join(shares) + " |")
    print(f"\n{time.perf_counter() - start_time:.0f} s; command: `{' '.join(sys.argv)}`")


if __name__ == "__main__":
    main()
