"""The default fit on the independent validation signals (issue 38).

``fit_oscillation(t, u)`` with no option on each signal of ``../shared/validation/signals``
(180 signals, six families, truth in ``truth.json``; its README describes them). Per family
and overall: the median |error| of λ and ω, the share with λ within 5 % and ω within 1 %,
the share whose reported ±1σ / ±2σ covers the truth (λ and ω each), the RMS of error / std
(1 when the ± is as wide as the scatter), the models chosen and the time per fit. Skips
(exit 0) when the signals are absent.

Run: ``.venv/bin/python benchmarks/fit/validation.py [--per-family N] [--jobs J]``.
"""

from __future__ import annotations

import argparse
import collections
import json
import math
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from liquidtouch.errors import LiquidTouchError
from liquidtouch.fit.oscillation import fit_oscillation

SIGNALS = Path(__file__).resolve().parents[2].parent / "shared" / "validation" / "signals"
#: the issue's accuracy targets: λ within 5 %, ω within 1 %
LAM_TOL, OMEGA_TOL = 0.05, 0.01


def fit_one(path: Path) -> dict[str, float | str]:
    """The default fit of one signal file: λ, ω, their std, the model and the time [s]."""
    data = np.loadtxt(path, delimiter=",", skiprows=1)
    start = time.process_time()
    try:
        fit = fit_oscillation(data[:, 0], data[:, 1])
    except LiquidTouchError as exc:
        return {"model": f"error: {type(exc).__name__}", "seconds": time.process_time() - start}
    return {
        "lam": fit.decay_rate,
        "lam_std": fit.decay_rate_std,
        "omega": fit.angular_frequency,
        "omega_std": fit.angular_frequency_std,
        "model": fit.model,
        "seconds": time.process_time() - start,
    }


def summary(rows: list[dict], truths: list[dict]) -> dict[str, float | str]:
    """The table's cells for one family (or all): errors, shares, coverage, models, time."""
    nan = math.nan
    lam = np.array([r.get("lam", nan) for r in rows])
    omega = np.array([r.get("omega", nan) for r in rows])
    lam_std = np.array([r.get("lam_std", nan) for r in rows])
    omega_std = np.array([r.get("omega_std", nan) for r in rows])
    lam_true = np.array([t["lam"] for t in truths])
    omega_true = np.array([t["omega"] for t in truths])
    lam_err = np.abs(lam - lam_true)
    omega_err = np.abs(omega - omega_true)
    # a failed fit counts as a miss everywhere (NaN compares False)
    both = (lam_err < LAM_TOL * lam_true) & (omega_err < OMEGA_TOL * omega_true)
    models = collections.Counter(str(r["model"]) for r in rows)
    return {
        "n": len(rows),
        "lam_err": float(np.nanmedian(lam_err / lam_true)),
        "omega_err": float(np.nanmedian(omega_err / omega_true)),
        "within": float(both.mean()),
        "lam_1": float((lam_err <= lam_std).mean()),
        "lam_2": float((lam_err <= 2 * lam_std).mean()),
        "omega_1": float((omega_err <= omega_std).mean()),
        "omega_2": float((omega_err <= 2 * omega_std).mean()),
        # RMS of error / std: 1 when the ± is as wide as the scatter, below 1 when wider
        "lam_z": float(np.sqrt(np.nanmean((lam_err / lam_std) ** 2))),
        "omega_z": float(np.sqrt(np.nanmean((omega_err / omega_std) ** 2))),
        "models": ", ".join(f"{m} {c}" for m, c in models.most_common()),
        "ms": 1000 * float(np.median([r["seconds"] for r in rows])),
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--per-family", type=int, default=30, help="signals per family (≤ 30)")
    parser.add_argument("--jobs", type=int, default=1, help="worker processes")
    args = parser.parse_args()
    if not (SIGNALS / "truth.json").exists():
        print(f"validation signals not found at {SIGNALS}; skipped")
        return 0
    truth = json.loads((SIGNALS / "truth.json").read_text())
    by_family: dict[str, list[str]] = collections.defaultdict(list)
    for name in sorted(truth):
        if len(by_family[truth[name]["family"]]) < args.per_family:
            by_family[truth[name]["family"]].append(name)
    names = [n for family in by_family.values() for n in family]
    paths = [SIGNALS / f"{n}.csv" for n in names]
    if args.jobs > 1:
        with ProcessPoolExecutor(args.jobs) as pool:
            rows = list(pool.map(fit_one, paths))
    else:
        rows = [fit_one(p) for p in paths]
    result = dict(zip(names, rows, strict=True))
    print(f"# validation — the default fit on {len(names)} independent signals\n")
    print(
        "| family | n | median λ err | median ω err | λ ≤ 5 % & ω ≤ 1 % | λ ±1σ | λ ±2σ "
        "| ω ±1σ | ω ±2σ | RMS z λ / ω | ms / fit | models |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    groups = {**by_family, "**all**": names}
    for family, members in groups.items():
        s = summary([result[n] for n in members], [truth[n] for n in members])
        print(
            f"| {family} | {s['n']} | {100 * s['lam_err']:.1f} % | {100 * s['omega_err']:.2f} % "
            f"| {100 * s['within']:.0f} % | {100 * s['lam_1']:.0f} % | {100 * s['lam_2']:.0f} % "
            f"| {100 * s['omega_1']:.0f} % | {100 * s['omega_2']:.0f} % "
            f"| {s['lam_z']:.2f} / {s['omega_z']:.2f} | {s['ms']:.0f} "
            f"| {s['models']} |"
        )
    print(f"\ncommand: `{' '.join([sys.executable.split('/')[-1], *sys.argv])}`")
    return 0


if __name__ == "__main__":
    sys.exit(main())
