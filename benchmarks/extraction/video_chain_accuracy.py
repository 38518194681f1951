"""How well λ and ω survive the whole video chain, stage by stage, against the simulator's truth.

For each simulated trial (usual seeded variability, several liquids and fill
heights; ``--clean`` adds the same cases with ``Variability.none()``) the slow
mode's λ and ω are fitted (``free_decay`` + ``fit_oscillation``, the defaults
of ``liquidtouch.extraction.pipeline``) on four signals:

- ``force``: the total lateral gel force, 3 Hz zero-phase low-pass, every 8th
  sample (30 Hz) — what the sensor would see if tracking were perfect;
- ``truth``: the true marker tracks (``truth_tracks.npz``) through ``signal.py``;
- ``x264 dz``: the rendered videos encoded with x264's default quantisation dead
  zone (the simulator's encoding before this benchmark), tracked;
- ``video``: the videos as the simulator writes them now (no dead zone), tracked.

Prints one row per trial (λ/λ_true − 1 and ω/ω_true − 1 per signal) and a
summary (median signed error, median and 90th percentile of the absolute error).

    .venv/bin/python benchmarks/video_chain_accuracy.py [--quick] [--clean]
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.signal import butter, sosfiltfilt

from liquidtouch.extraction.pipeline import extract
from liquidtouch.fit.oscillation import fit_oscillation
from liquidtouch.ring_down.segments import free_decay
from liquidtouch.signal.tactile import tactile_signal
from liquidtouch.sim.trial import simulate_trial
from liquidtouch.sim.trial_io import write_trial
from liquidtouch.sim.variability import Variability
from liquidtouch.tracking.tracks import MarkerTracks

CASES = [  # (liquid, sugar concentration, height mm)
    ("water", None, 18.0),
    ("water", None, 32.0),
    ("mirin", None, 25.0),
    ("olive-oil", None, 25.0),
    ("corn-oil", None, 35.0),
    ("sugar-water", 60.0, 30.0),
    ("sugar-water", 120.0, 38.0),
    ("sugar-water", 160.0, 20.0),
]
SIGNALS = ("force", "truth", "x264 dz", "video")


def truth_tracks(trial_dir: Path) -> list[MarkerTracks]:
    """The simulator's true marker tracks as ``MarkerTracks`` (all valid)."""
    z = np.load(trial_dir / "truth_tracks.npz", allow_pickle=False)
    out = []
    for s, name in enumerate(z["sensors"]):
        pos = z["positions_px"][s].astype(float)
        valid = np.ones(pos.shape[:2], bool)
        out.append(MarkerTracks(z["timestamps_s"], pos, valid, pos[0].copy(), str(name)))
    return out


def fit_errors(trial, root: Path) -> dict[str, tuple[float, float]]:
    """(λ/λ_true − 1, ω/ω_true − 1) of each signal in ``SIGNALS``."""
    t = trial.t_s
    sos = butter(4, 3.0, fs=1.0 / (t[1] - t[0]), output="sos")
    signals = {"force": (t[::8], sosfiltfilt(sos, trial.slosh_force_n())[::8])}
    fits = {}
    for name, params in (("x264 dz", ""), ("video", None)):
        tdir = write_trial(trial, root / name.replace(" ", "_"), x264_params=params)
        if name == "video":
            sig = tactile_signal(truth_tracks(tdir))
            signals["truth"] = (sig.t, sig.u)
        fits[name] = extract(tdir).fit
    for name, (tt, uu) in signals.items():
        fits[name] = fit_oscillation(*free_decay(tt, uu))
    lam, om = trial.true_decay_rate, trial.true_angular_frequency
    return {k: (f.decay_rate / lam - 1, f.angular_frequency / om - 1) for k, f in fits.items()}


def main() -> None:
    quick, clean = "--quick" in sys.argv, "--clean" in sys.argv
    seeds = [1] if quick else [1, 2, 3]
    variabilities = [("seeded", None)] + ([("clean", Variability.none())] if clean else [])
    rows = []
    start = time.perf_counter()
    head = " | ".join(f"λ {s} | ω {s}" for s in SIGNALS)
    print(f"| variability | liquid | h mm | seed | λ true 1/s | ω true rad/s | {head} |")
    print("|" + "---|" * (6 + 2 * len(SIGNALS)))
    for var_name, var in variabilities:
        for liquid, conc, height in CASES:
            for seed in seeds:
                trial = simulate_trial(
                    liquid, sugar_concentration=conc, height_mm=height, seed=seed, variability=var
                )
                label = liquid if conc is None else f"{liquid} {conc:g}"
                with tempfile.TemporaryDirectory() as tmp:
                    try:
                        errs = fit_errors(trial, Path(tmp))
                    except Exception as exc:  # report, keep going
                        print(f"<!-- {label} {height:g} mm seed {seed}: {exc} -->")
                        continue
                cells = " | ".join(f"{errs[s][0]:+.3f} | {errs[s][1]:+.4f}" for s in SIGNALS)
                print(
                    f"| {var_name} | {label} | {height:g} | {seed} | {trial.true_decay_rate:.3f} "
                    f"| {trial.true_angular_frequency:.2f} | {cells} |",
                    flush=True,
                )
                rows.append((var_name, errs))
    print(f"\n{len(rows)} trials, {time.perf_counter() - start:.0f} s\n")
    print("| variability | signal | λ median err | λ median abs | λ p90 abs | ω median err "
          "| ω median abs | ω p90 abs |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|")
    for var_name, _ in variabilities:
        for s in SIGNALS:
            e = np.array([errs[s] for v, errs in rows if v == var_name])
            if not len(e):
                continue
            lam, om = e[:, 0], e[:, 1]
            print(
                f"| {var_name} | {s} | {np.median(lam):+.3f} | {np.median(np.abs(lam)):.3f} | "
                f"{np.percentile(np.abs(lam), 90):.3f} | {np.median(om):+.4f} | "
                f"{np.median(np.abs(om)):.4f} | {np.percentile(np.abs(om), 90):.4f} |"
            )


if __name__ == "__main__":
    main()
