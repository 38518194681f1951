"""Accuracy and speed of the oscillation fit against a naive curve_fit baseline (issues 2, 23).

The first two methods are the defaults: ``default`` is ``fit_oscillation(t, u)``
with no option (the paper's loss, ``model="auto"``: the model chosen by the data),
what ``extract``, ``features`` and ``fit`` do; ``default ls`` the same with least
squares. The others fix one model.

Run: ``.venv/bin/python benchmarks/fit/fit_accuracy.py [--quick]``; prints markdown tables.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
import warnings

import numpy as np
from scipy.optimize import curve_fit

from liquidtouch.errors import LiquidTouchError
from liquidtouch.fit import model as om
from liquidtouch.fit.oscillation import fit_oscillation
from liquidtouch.fit.synthetic import DRIFT, cubic_damper_signal, quadratic_damper_signal

FPS, DURATION_S = 30.0, 13.0
T = np.arange(round(FPS * DURATION_S)) / FPS


def naive_fit(t: np.ndarray, u: np.ndarray) -> tuple[float, float]:
    """One damped cosine + constant, curve_fit, FFT-peak start (the baseline)."""
    centred = u - u.mean()
    freqs = np.fft.rfftfreq(t.size, t[1] - t[0])
    peak = freqs[1 + np.argmax(np.abs(np.fft.rfft(centred))[1:])]

    def f(t, amp, lam, omega, phase, c):
        return amp * np.exp(-lam * t) * np.cos(omega * t + phase) + c

    p0 = [np.abs(centred).max(), 0.5, 2 * np.pi * peak, 0.0, u.mean()]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        p, _ = curve_fit(f, t, u, p0=p0, maxfev=5000)
    return abs(p[1]), abs(p[2])


def crb(lam, omega, amp, phase, fast, sigma) -> tuple[float, float]:
    """Cramér–Rao bound (std) of λ, ω for the exact model under white noise σ."""
    a, b = amp * math.cos(phase), -amp * math.sin(phase)
    d = [DRIFT[0], DRIFT[1] * T[-1], DRIFT[2] * T[-1] ** 2]
    if fast is None:
        theta, n_modes = np.array([lam, omega, a, b, *d]), 1
    else:
        fl, fw, fa, fp = fast
        theta = np.array(
            [lam, omega, fl - lam, fw, a, b, fa * math.cos(fp), -fa * math.sin(fp), *d]
        )
        n_modes = 2
    jac = om.jacobian(theta, T, om.drift_columns(T, 2), n_modes)  # the signals' quadratic drift
    cov = sigma**2 * np.linalg.inv(jac.T @ jac)
    return math.sqrt(cov[0, 0]), math.sqrt(cov[1, 1])


def model_signal(lam, omega, amp, phase, fast, sigma, rng) -> np.ndarray:
    u = amp * np.exp(-lam * T) * np.cos(omega * T + phase)
    if fast is not None:
        fl, fw, fa, fp = fast
        u = u + fa * np.exp(-fl * T) * np.cos(fw * T + fp)
    u = u + DRIFT[0] + DRIFT[1] * T + DRIFT[2] * T * T
    return u + rng.normal(0, sigma, T.size)


METHODS = {
    "default": lambda t, u: _default(t, u),
    "default ls": lambda t, u: _default(t, u, loss="ls"),
    "ours ls two-mode": lambda t, u: _ours(t, u, "ls", "two-mode", 1.0),
    "ours paper two-mode (δ=1)": lambda t, u: _ours(t, u, "paper", "two-mode", 1.0),
    "ours paper two-mode (δ=0.05)": lambda t, u: _ours(t, u, "paper", "two-mode", 0.05),
    "ours ls single-mode": lambda t, u: _ours(t, u, "ls", "single-mode", 1.0),
    "ours paper amplitude": lambda t, u: _ours(t, u, "paper", "amplitude", 1.0),
    "ours ls amplitude": lambda t, u: _ours(t, u, "ls", "amplitude", 1.0),
    "naive curve_fit": naive_fit,
}


def _default(t, u, **options):
    fit = fit_oscillation(t, u, **options)
    CHOSEN.setdefault(("ls " if options else "") + fit.model, 0)
    CHOSEN[("ls " if options else "") + fit.model] += 1
    return fit.decay_rate, fit.angular_frequency


#: how often the default fit chose each model, per table (reset per table)
CHOSEN: dict[str, int] = {}


def _ours(t, u, loss, model, delta_rel):
    fit = fit_oscillation(t, u, loss=loss, model=model, delta_rel=delta_rel)
    return fit.decay_rate, fit.angular_frequency


def run_method(method, t, u):
    start = time.perf_counter()
    try:
        lam, omega = method(t, u)
    except (LiquidTouchError, RuntimeError):
        lam, omega = math.nan, math.nan
    return lam, omega, time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--quick", action="store_true", help="fewer signals")
    args = parser.parse_args()
    n_seeds = 8 if args.quick else 20
    rng = np.random.default_rng(2022)
    sigma = 0.05
    # exact-model parameter sets: (λ, ω, amplitude, phase, fast mode or None)
    sets = [
        (0.05, 6.0, 1.0, 0.3, None),
        (0.3, 12.0, 1.0, -1.0, None),
        (1.0, 8.0, 1.0, 2.0, None),
        (1.5, 19.0, 1.0, 0.5, None),
        (0.3, 10.0, 1.0, 0.4, (1.5, 12.5, 0.7, -1.1)),
        (0.8, 16.0, 1.0, 1.2, (2.5, 17.0, 0.8, 0.3)),
        # the second mode inside the first one's spectral line (|ω' − ω| < λ, issue 38)
        (0.5, 10.0, 1.0, 0.3, (1.5, 10.4, 0.7, -0.8)),
        (0.8, 14.0, 1.0, 1.0, (2.0, 14.6, 0.6, 2.0)),
        (1.0, 8.0, 1.0, -0.5, (1.8, 8.5, 0.8, 0.9)),
    ]
    print(f"# fit_accuracy — {n_seeds} noise seeds per set, 30 Hz, 13 s, σ = {sigma}\n")
    print("## Exact-model signals: RMSE / Cramér–Rao bound (1.0 = statistically perfect)\n")
    names = list(METHODS)
    print("| λ | ω | fast mode | " + " | ".join(f"{n} λ / ω" for n in names) + " |")
    print("|" + "---|" * (3 + len(names)))
    errors = {n: [] for n in names}
    times = {n: [] for n in names}
    ratios = {n: [] for n in names}
    two_mode_ratios = {n: [] for n in names}
    in_line_ratios = {n: [] for n in names}
    CHOSEN.clear()
    for lam, omega, amp, phase, fast in sets:
        bound = crb(lam, omega, amp, phase, fast, sigma)
        est = {n: [] for n in names}
        for _ in range(n_seeds):
            u = model_signal(lam, omega, amp, phase, fast, sigma, rng)
            for n in names:
                el, ew, dt = run_method(METHODS[n], T, u)
                est[n].append((el, ew))
                times[n].append(dt)
                errors[n].append((abs(el - lam) / lam, abs(ew - omega) / omega))
        cells = []
        for n in names:
            e = np.array(est[n])
            rmse_l = math.sqrt(np.nanmean((e[:, 0] - lam) ** 2))
            rmse_w = math.sqrt(np.nanmean((e[:, 1] - omega) ** 2))
            ratios[n].append((rmse_l / bound[0], rmse_w / bound[1]))
            if fast is not None:
                pooled_in = in_line_ratios if abs(fast[1] - omega) < lam else two_mode_ratios
                pooled_in[n].extend(((e[:, 0] - lam) / bound[0], (e[:, 1] - omega) / bound[1]))
            cells.append(f"{rmse_l / bound[0]:.2f} / {rmse_w / bound[1]:.2f}")
        label = "—" if fast is None else f"λ'={fast[0]}, ω'={fast[1]}"
        print(f"| {lam} | {omega} | {label} | " + " | ".join(cells) + " |")
    print(
        "| **median** | | | "
        + " | ".join(
            "**{:.2f} / {:.2f}**".format(*np.median(np.array(ratios[n]), axis=0)) for n in names
        )
        + " |"
    )
    for label, pooled_ratios in (
        ("two-mode sets, pooled", two_mode_ratios),
        ("in-line two-mode sets (|ω' − ω| < λ), pooled", in_line_ratios),
    ):
        pooled = {
            n: [math.sqrt(np.nanmean(np.concatenate(pooled_ratios[n][i::2]) ** 2)) for i in (0, 1)]
            for n in names
        }
        print(
            f"| **{label}** | | | "
            + " | ".join(f"**{pooled[n][0]:.2f} / {pooled[n][1]:.2f}**" for n in names)
            + " |"
        )
    print()
    print(f"Models the default fits chose: {dict(sorted(CHOSEN.items()))}\n")

    n_nl = 12 if args.quick else 30
    oscillators = {
        "ε'' + 2λ0(1 + κε²)ε' + ω0²ε = 0 (cubic damper, p = 2)": lambda lam0, omega0: (
            cubic_damper_signal(T, lam0, omega0, float(rng.uniform(2, 6)), 0.01, rng)
        ),  # early damping 1.5-2.5× the small-amplitude one
        "ε'' + 2λ0ε' + c|ε'|ε' + ω0²ε = 0 (velocity-squared damper, p = 1)": lambda lam0, omega0: (
            quadratic_damper_signal(
                T, lam0, omega0, float(rng.uniform(0.5, 2.0)) * lam0 / omega0, 0.01, rng
            )
        ),  # early damping 1.2-1.8× the small-amplitude one
    }
    for title, make in oscillators.items():
        print(f"## Non-linear oscillator: {title}, u = ε'' + drift + noise\n")
        print("Error of λ against the small-amplitude λ0 (and of ω against ω0).\n")
        nl_err = {n: [] for n in names}
        CHOSEN.clear()
        for _ in range(n_nl):
            lam0 = float(np.exp(rng.uniform(np.log(0.1), np.log(1.0))))
            omega0 = float(rng.uniform(6, 18))
            u = make(lam0, omega0)
            for n in names:
                el, ew, dt = run_method(METHODS[n], T, u)
                nl_err[n].append((abs(el - lam0) / lam0, abs(ew - omega0) / omega0))
                times[n].append(dt)
        print("| method | median λ err | p90 λ err | median ω err | p90 ω err | failures |")
        print("|---|---|---|---|---|---|")
        for n in names:
            e = np.array(nl_err[n])
            fails = int(np.isnan(e[:, 0]).sum())
            q = np.nanpercentile(e, [50, 90], axis=0)
            print(
                f"| {n} | {100 * q[0, 0]:.1f} % | {100 * q[1, 0]:.1f} % | "
                f"{100 * q[0, 1]:.2f} % | {100 * q[1, 1]:.2f} % | {fails}/{len(e)} |"
            )
        print(f"\nModels the default fits chose: {dict(sorted(CHOSEN.items()))}\n")

    print("## All exact-model signals: relative errors, and time per fit\n")
    print("| method | median λ err | p90 λ err | median ω err | p90 ω err | ms / fit | vs naive |")
    print("|---|---|---|---|---|---|---|")
    naive_ms = 1000 * np.median(times["naive curve_fit"])
    for n in names:
        e = np.array(errors[n])
        q = np.nanpercentile(e, [50, 90], axis=0)
        ms = 1000 * np.median(times[n])
        print(
            f"| {n} | {100 * q[0, 0]:.2f} % | {100 * q[1, 0]:.2f} % | {100 * q[0, 1]:.3f} % | "
            f"{100 * q[1, 1]:.3f} % | {ms:.0f} | {ms / naive_ms:.1f}× |"
        )
    print(f"\ncommand: `{' '.join([sys.executable.split('/')[-1], *sys.argv])}`")


if __name__ == "__main__":
    main()
