"""Calibration check of the simulator: the paper's method on simulated force signals.

For every trial of a sugar-water preset (physics only, no video) the total
lateral gel force is low-pass filtered (zero-phase 3 Hz, as the tactile
pipeline does), sampled at the camera's 30 fps from 0.3 s after the push, and
fitted with ``liquidtouch.fit_oscillation``; a Gaussian-process regressor (RBF +
white noise on standardised λ, ω) trained on the train split predicts height,
concentration and μ = log10 ν of the test split. Also reports how well the
fit recovers the true small-amplitude λ, ω. Prints a markdown table next to the
paper's published test errors.

    .venv/bin/python benchmarks/sim_calibration.py [--quick]
"""

from __future__ import annotations

import sys
import time

import numpy as np
from scipy.signal import butter, sosfiltfilt
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel
from sklearn.linear_model import LinearRegression
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import PolynomialFeatures, StandardScaler

from liquidtouch.fit.oscillation import fit_oscillation
from liquidtouch.sim.presets import get_preset
from liquidtouch.sim.trial import simulate_trial

PAPER = {  # target: (GPR MAE, quadratic MAE) on the paper's sugar-water test set
    "height_mm": (0.56, 0.84),
    "sugar_concentration": (15.3, 20.0),
    "log10_viscosity_cst": (0.16, 0.23),
}


def features(trial) -> tuple[float, float]:
    t = trial.t_s
    f = trial.slosh_force_n()
    sos = butter(4, 3.0, fs=1.0 / (t[1] - t[0]), output="sos")
    u = sosfiltfilt(sos, f)
    keep = t >= trial.params.push_end_s + 0.3
    step = round((t[1] - t[0]) ** -1 / 30.0)
    tt, uu = t[keep][::step], u[keep][::step]
    fit = fit_oscillation(tt, uu)
    return fit.decay_rate, fit.angular_frequency


def main() -> None:
    quick = "--quick" in sys.argv
    specs = get_preset("sugar", quick=quick)
    rows = []
    start = time.perf_counter()
    for spec in specs:
        trial = simulate_trial(seed=spec.seed, **spec.kwargs)
        try:
            lam, om = features(trial)
        except Exception as exc:  # report, keep going
            print(f"<!-- {spec.name}: {exc} -->")
            continue
        rows.append((spec.split, lam, om, trial))
    elapsed = time.perf_counter() - start
    tr = [r for r in rows if r[0] == "train"]
    te = [r for r in rows if r[0] == "test"]
    x_tr = np.array([[r[1], r[2]] for r in tr])
    x_te = np.array([[r[1], r[2]] for r in te])
    scaler = StandardScaler().fit(x_tr)
    lam_true = np.array([r[3].true_decay_rate for r in rows])
    om_true = np.array([r[3].true_angular_frequency for r in rows])
    lam_fit = np.array([r[1] for r in rows])
    om_fit = np.array([r[2] for r in rows])
    print(
        f"sugar preset{' (quick)' if quick else ''}: {len(tr)} train, {len(te)} test trials "
        f"fitted, {len(specs) - len(rows)} failed; {elapsed:.0f} s\n"
    )
    print("| fit vs truth | median abs rel error | 90th percentile |")
    print("|---|---|---|")
    for name, fit, true in (("λ", lam_fit, lam_true), ("ω", om_fit, om_true)):
        rel = np.abs(fit / true - 1)
        print(f"| {name} | {np.median(rel):.3f} | {np.percentile(rel, 90):.3f} |")
    print("\n| target | GPR MAE (sim) | paper GPR | quadratic MAE (sim) | paper quadratic |")
    print("|---|---|---|---|---|")
    for target, paper in PAPER.items():
        y_tr = np.array([getattr(r[3], target) for r in tr])
        y_te = np.array([getattr(r[3], target) for r in te])
        kernel = ConstantKernel() * RBF([1.0, 1.0]) + WhiteKernel(0.1)
        gpr = GaussianProcessRegressor(
            kernel, normalize_y=True, n_restarts_optimizer=2, random_state=0
        )
        gpr.fit(scaler.transform(x_tr), y_tr)
        mae = np.mean(np.abs(gpr.predict(scaler.transform(x_te)) - y_te))
        quad = make_pipeline(PolynomialFeatures(2), LinearRegression()).fit(x_tr, y_tr)
        mae_q = np.mean(np.abs(quad.predict(x_te) - y_te))
        print(f"| {target} | {mae:.3f} | {paper[0]} | {mae_q:.3f} | {paper[1]} |")


if __name__ == "__main__":
    main()
