"""How many calibration trials to record: error and interval coverage against training-set size.

Synthetic (λ, ω) tables (:mod:`synthetic_tables`: first-mode sloshing physics in
container A, 4 % noise on λ, 0.3 % on ω) of five liquids (water, mirin, corn oil,
olive oil, detergent at its zero-shear viscosity). A lab records ``H`` fill heights
per liquid (evenly over 16-40 mm) and ``R`` trials per (liquid, height); a GPR per
target is trained on them with the 10-fold cross-conformal calibration of
``liquidtouch train`` (its default calibration groups), and judged on 500 new
trials per liquid at random heights (held-out seeds): mean absolute error,
coverage of the calibrated ±1σ, ±2σ and 90 % interval, and the RMS of
z = error / std (1 when calibrated).

Second table: a GPR trained on sugar water alone (the paper's 9 heights × 12
concentrations) predicting olive oil, corn oil and mirin (the same physics, other
liquids): is its calibrated std still honest off its own liquid?

Usage: nice -n 10 python benchmarks/learning_curve.py [--seeds 2]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
import pandas as pd

from liquidtouch.models.conformal import default_groups
from liquidtouch.models.training import train_regression
from liquidtouch.testing.synthetic_tables import (
    CONTAINER_A,
    LAMBDA_NOISE,
    LIQUID_VISCOSITY_CST,
    OMEGA_NOISE,
    paper_split,
    sloshing_features,
)

LIQUIDS = ("water", "mirin", "corn-oil", "olive-oil", "detergent")
TARGETS = ("height_mm", "log10_viscosity_cst")
HEIGHTS = (3, 4, 6, 9)
REPEATS = (1, 2, 3)


def table(liquids, heights_mm: np.ndarray, repeats: int, rng: np.random.Generator):
    """(X, {target: y}) of ``repeats`` noisy trials per (liquid, height)."""
    X, y = [], {t: [] for t in TARGETS}
    for liquid in liquids:
        h = np.repeat(np.asarray(heights_mm, float), repeats)
        nu = np.full(h.size, LIQUID_VISCOSITY_CST[liquid])
        lam, omega = sloshing_features(h, nu, **CONTAINER_A)
        lam = lam * np.exp(LAMBDA_NOISE * rng.standard_normal(h.size))
        omega = omega * (1 + OMEGA_NOISE * rng.standard_normal(h.size))
        X.append(np.column_stack([lam, omega]))
        y["height_mm"].append(h)
        y["log10_viscosity_cst"].append(np.log10(nu))
    return np.concatenate(X), {t: np.concatenate(v) for t, v in y.items()}


def groups_of(y: dict) -> np.ndarray | None:
    """``train``'s default calibration groups of a table's rows (a liquid is its viscosity)."""
    liquid = [f"{v:g}" for v in y["log10_viscosity_cst"]]
    return default_groups(pd.DataFrame({"liquid": liquid, "height_mm": y["height_mm"]}))


def scores(model, X: np.ndarray, y: dict) -> dict[str, tuple[float, ...]]:
    """Per target: MAE, ±1σ and ±2σ coverage, RMS z, 90 % interval coverage."""
    out = {}
    pred = model.predict(X)
    bounds = model.predict_interval(X, 0.9)
    for target, (mean, std) in pred.items():
        z = (mean - y[target]) / std
        lo, hi = bounds[target]
        out[target] = (
            float(np.mean(np.abs(mean - y[target]))),
            float(np.mean(np.abs(z) <= 1)),
            float(np.mean(np.abs(z) <= 2)),
            float(math.sqrt(np.mean(z**2))),
            float(np.mean((y[target] >= lo) & (y[target] <= hi))),
        )
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=2, help="repeats of each design")
    args = parser.parse_args()
    began = time.perf_counter()
    print(
        "GPR per target, 10-fold cross-conformal calibration; 5 liquids × H heights × R trials; "
        "test: 500 trials per liquid at random heights 16-40 mm (mean over "
        f"{args.seeds} seeds)\n"
    )
    head = "MAE  ±1σ  ±2σ  rmsz  90%"
    print(f"{'H':>2s} {'R':>2s} {'rows':>4s}  {'height [mm]: ' + head:40s} {'log10 ν: ' + head}")
    for n_heights in HEIGHTS:
        for repeats in REPEATS:
            rows = []
            for seed in range(args.seeds):
                rng = np.random.default_rng(1000 * seed + 10 * n_heights + repeats)
                X, y = table(LIQUIDS, np.linspace(16, 40, n_heights), repeats, rng)
                model = train_regression(
                    X, y, "gpr", calibration_folds=10, calibration_groups=groups_of(y)
                )
                test_rng = np.random.default_rng(10_000 + seed)
                Xt, yt = table(LIQUIDS, test_rng.uniform(16, 40, 500), 1, test_rng)
                rows.append(scores(model, Xt, yt))
            cells = []
            for target in TARGETS:
                m = np.mean([r[target] for r in rows], axis=0)
                cells.append(f"{m[0]:5.3f} {m[1]:4.0%} {m[2]:4.0%} {m[3]:4.2f} {m[4]:4.0%}")
            n = len(LIQUIDS) * n_heights * repeats
            print(f"{n_heights:2d} {repeats:2d} {n:4d}  {cells[0]:40s} {cells[1]}")

    print("\nsugar-water GPR (9 heights × 12 concentrations) on olive oil, corn oil and mirin:")
    for seed in range(args.seeds):
        train, _ = paper_split(seed=seed)
        X = train[["decay_rate", "angular_frequency"]].to_numpy()
        targets = {t: train[t].to_numpy() for t in TARGETS}
        model = train_regression(
            X, targets, "gpr", calibration_folds=10, calibration_groups=default_groups(train)
        )
        rng = np.random.default_rng(20_000 + seed)
        Xt, yt = table(("olive-oil", "corn-oil", "mirin"), rng.uniform(16, 40, 300), 1, rng)
        for target, (mae, c1, c2, zr, c90) in scores(model, Xt, yt).items():
            print(
                f"  seed {seed} {target:20s} MAE {mae:.3f}  ±1σ {c1:4.0%}  ±2σ {c2:4.0%}  "
                f"rms z {zr:4.2f}  90 % interval {c90:4.0%}"
            )
    print(f"\n{time.perf_counter() - began:.0f} s")


if __name__ == "__main__":
    main()
