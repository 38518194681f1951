"""Does λ depend on how hard the bottle was pushed? Paper model vs amplitude-dependent damping.

The same liquid and fill is simulated with the push at 0.5×, 1× and 2× the default
(:data:`DEFAULT_PUSH_MM`, the mean of the drawn push in ``sim/variability.py``),
everything else fixed by the seed. Each signal is fitted with the paper's model
(``model="two-mode"``: paper loss, two modes) and with ``model="amplitude"``
(:mod:`liquidtouch.fit.amplitude`), both on the free decay as ``extract`` does.

- force level (the bulk): total lateral gel force, the signal's zero-phase low-pass
  (``lowpass_filter.DEFAULT_LOWPASS_HZ``), 30 Hz;
- ``--video``: a subset through the whole chain (simulate → render → extract);
- ``--classify``: all liquids at drawn pushes, λ vs truth and an SVM classifier
  (``models.classifier.LiquidClassifier``, as ``liquidtouch classify``) trained
  on the features of each model.

The predicted viscosity uses the physics relation of the models
(``models.physics_prior.stokes_viscosity_feature``: log10 ν = 2 log10 λ − log10 ω
+ const, Stokes boundary layer), so its spread across pushes needs no training.

    nice -n 10 .venv/bin/python benchmarks/push_invariance.py [--quick] [--video] [--classify]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from liquidtouch.errors import LiquidTouchError
from liquidtouch.extraction.fit_settings import FitSettings
from liquidtouch.models.physics_prior import stokes_viscosity_feature
from liquidtouch.signal.lowpass import DEFAULT_LOWPASS_HZ, lowpass
from liquidtouch.sim.trial import simulate_trial
from liquidtouch.testing import progress_bar

DEFAULT_PUSH_MM = 15.0
PUSH_FACTORS = (0.5, 1.0, 2.0)
LIQUIDS = {"water": (18.0, 30.0), "olive-oil": (18.0, 30.0), "detergent": (20.0, 30.0)}
#: ``default`` is ``FitSettings()`` (``model="auto"``, issue 23): what ``extract`` fits
MODELS = {
    "default": FitSettings(),
    "paper": FitSettings(model="two-mode"),
    "amplitude": FitSettings(model="amplitude"),
}
ALL_LIQUIDS = ("water", "olive-oil", "corn-oil", "mirin", "detergent", "sugar-water")
FIGURE = Path("benchmarks/results/push_invariance.png")


def force_signal(trial) -> tuple[np.ndarray, np.ndarray]:
    """The gel force as the tactile chain would see it: its low-pass, 30 Hz samples."""
    fps = 1.0 / (trial.t_s[1] - trial.t_s[0])
    return trial.t_s[::8], lowpass(trial.slosh_force_n(), fps, DEFAULT_LOWPASS_HZ)[::8]


def video_signal(trial, root: Path) -> tuple[np.ndarray, np.ndarray]:
    """The tactile signal of the rendered videos (simulate → render → track)."""
    from liquidtouch.extraction.pipeline import extract
    from liquidtouch.sim.trial_io import write_trial

    sig = extract(write_trial(trial, root / "trial"), fit=False).signal
    return sig.t, sig.u


def fit_all(t: np.ndarray, u: np.ndarray) -> dict[str, tuple[float, float, float]]:
    """(λ [1/s], ω [rad/s], seconds) of each model in :data:`MODELS` (NaN when refused)."""
    out = {}
    for name, settings in MODELS.items():
        start = time.perf_counter()
        try:
            fit = settings.fit(t, u)
            out[name] = (fit.decay_rate, fit.angular_frequency, time.perf_counter() - start)
        except LiquidTouchError:
            out[name] = (np.nan, np.nan, time.perf_counter() - start)
    return out


def push_rows(seeds: list[int], video: bool) -> list[dict]:
    """One row per (liquid, fill, seed, push factor, model): λ/λ0, ω, time."""
    cases = [(liq, h, s) for liq, hs in LIQUIDS.items() for h in hs for s in seeds]
    if video:  # a subset: one fill per liquid
        cases = [(liq, hs[-1], s) for liq, hs in LIQUIDS.items() for s in seeds]
    rows = []
    with progress_bar("video" if video else "force", len(cases) * len(PUSH_FACTORS)) as advance:
        for liquid, height, seed in cases:
            for factor in PUSH_FACTORS:
                trial = simulate_trial(
                    liquid,
                    height_mm=height,
                    seed=seed,
                    parameters={"push_distance_mm": factor * DEFAULT_PUSH_MM},
                )
                if video:
                    with tempfile.TemporaryDirectory() as tmp:
                        t, u = video_signal(trial, Path(tmp))
                else:
                    t, u = force_signal(trial)
                for model, (lam, omega, sec) in fit_all(t, u).items():
                    rows.append(
                        dict(liquid=liquid, height=height, seed=seed, factor=factor, model=model,
                             ratio=lam / trial.true_decay_rate, omega=omega, lam=lam, sec=sec)
                    )  # fmt: skip
                advance()
    return rows


def spreads(rows: list[dict], liquid: str, model: str) -> tuple[np.ndarray, np.ndarray]:
    """Per (fill, seed): range of λ/λ0 and of predicted log10 ν across the pushes."""
    groups: dict[tuple, list[dict]] = {}
    for r in rows:
        if r["liquid"] == liquid and r["model"] == model:
            groups.setdefault((r["height"], r["seed"]), []).append(r)
    lam_spread, nu_spread = [], []
    for group in groups.values():
        lam = np.array([r["lam"] for r in group])
        omega = np.array([r["omega"] for r in group])
        ratio = np.array([r["ratio"] for r in group])
        lam_spread.append(np.ptp(ratio))
        nu_spread.append(10 ** np.ptp(stokes_viscosity_feature(lam, omega)) - 1)
    return np.array(lam_spread), np.array(nu_spread)


def print_push_tables(rows: list[dict], title: str) -> None:
    print(f"## {title}: λ across push strengths {PUSH_FACTORS} × {DEFAULT_PUSH_MM:g} mm\n")
    print("λ spread = range of λ/λ0 over the three pushes (per fill and seed, median); "
          "ν spread = max/min − 1 of the predicted viscosity (ν ∝ λ²/ω).\n")  # fmt: skip
    print("| liquid | model | median abs(λ/λ0−1) | median λ/λ0−1 | λ spread | p90 λ spread "
          "| ν spread | ms / fit |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|")
    for liquid in [*LIQUIDS, "all"]:
        for model in MODELS:
            sel = [r for r in rows if r["model"] == model and liquid in ("all", r["liquid"])]
            err = np.array([r["ratio"] for r in sel]) - 1
            if liquid == "all":
                parts = [spreads(rows, liq, model) for liq in LIQUIDS]
                lam_s = np.concatenate([p[0] for p in parts])
                nu_s = np.concatenate([p[1] for p in parts])
            else:
                lam_s, nu_s = spreads(rows, liquid, model)
            ms = 1000 * np.median([r["sec"] for r in sel])
            print(
                f"| {liquid} | {model} | {100 * np.nanmedian(np.abs(err)):.1f} % | "
                f"{100 * np.nanmedian(err):+.1f} % | {100 * np.nanmedian(lam_s):.1f} % | "
                f"{100 * np.nanpercentile(lam_s, 90):.1f} % | {100 * np.nanmedian(nu_s):.1f} % | "
                f"{ms:.0f} |"
            )
    print("\nMedian λ/λ0 − 1 by push strength:\n")
    print("| model | " + " | ".join(f"{f:g}×" for f in PUSH_FACTORS) + " |")
    print("|---|" + "---|" * len(PUSH_FACTORS))
    for model in MODELS:
        cells = [
            np.nanmedian([r["ratio"] - 1 for r in rows if r["model"] == model and r["factor"] == f])
            for f in PUSH_FACTORS
        ]
        print(f"| {model} | " + " | ".join(f"{100 * c:+.1f} %" for c in cells) + " |")
    print()


def classification(seeds: list[int]) -> None:
    """All liquids at drawn pushes: λ vs truth and SVM accuracy, per model."""
    from liquidtouch.models.classifier import LiquidClassifier

    heights = (15.0, 22.0, 29.0, 36.0)
    feats: dict[str, list] = {m: [] for m in MODELS}
    labels, split, truth = [], [], []
    total = len(ALL_LIQUIDS) * len(heights) * len(seeds)
    with progress_bar("classify", total) as advance:
        for liquid in ALL_LIQUIDS:
            conc = 80.0 if liquid == "sugar-water" else None
            for height in heights:
                for seed in seeds:
                    trial = simulate_trial(
                        liquid, sugar_concentration=conc, height_mm=height, seed=100 + seed
                    )
                    for model, (lam, omega, _) in fit_all(*force_signal(trial)).items():
                        feats[model].append((lam, omega))
                    labels.append(liquid)
                    split.append(seed % 2)  # even seeds train, odd seeds test
                    truth.append(trial.true_decay_rate)
                    advance()
    labels, split, truth = np.array(labels), np.array(split), np.array(truth)
    print(f"## All liquids at drawn pushes (force level, {len(labels)} trials)\n")
    print("| model | median abs(λ/λ_true−1) | p90 | worst liquid (median abs) | "
          "SVM test accuracy |")  # fmt: skip
    print("|---|---|---|---|---|")
    for model, values in feats.items():
        x = np.array(values)
        ok = np.isfinite(x).all(axis=1)
        err = np.abs(x[:, 0] / truth - 1)
        per = {liq: np.nanmedian(err[labels == liq]) for liq in ALL_LIQUIDS}
        worst = max(per, key=per.get)
        train, test = ok & (split == 0), ok & (split == 1)
        clf = LiquidClassifier().fit(x[train], labels[train])
        acc = float(np.mean(clf.predict(x[test]) == labels[test]))
        print(
            f"| {model} | {100 * np.nanmedian(err):.1f} % | "
            f"{100 * np.nanpercentile(err, 90):.1f} % | {worst} {100 * per[worst]:.1f} % | "
            f"{100 * acc:.1f} % ({int(test.sum())}) |"
        )
    print()


def figure(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from liquidtouch.io.figures import save_figure

    fig, axes = plt.subplots(1, len(LIQUIDS), figsize=(4 * len(LIQUIDS), 3.4), sharey=True)
    colours = {"default": "tab:green", "paper": "tab:red", "amplitude": "tab:blue"}
    for ax, liquid in zip(axes, LIQUIDS, strict=True):
        for model, colour in colours.items():
            sel = [r for r in rows if r["liquid"] == liquid and r["model"] == model]
            for key in sorted({(r["height"], r["seed"]) for r in sel}):
                pts = sorted(
                    (r["factor"], r["ratio"]) for r in sel if (r["height"], r["seed"]) == key
                )
                ax.plot(*zip(*pts, strict=True), "-o", color=colour, alpha=0.35, ms=3, lw=1)
            med = [
                np.nanmedian([r["ratio"] for r in sel if r["factor"] == f]) for f in PUSH_FACTORS
            ]
            ax.plot(PUSH_FACTORS, med, "-", color=colour, lw=2.5, label=model)
        ax.axhline(1.0, color="k", lw=0.8)
        ax.set_xscale("log", base=2)
        ax.set_xticks(PUSH_FACTORS, [f"{f:g}×" for f in PUSH_FACTORS])
        ax.set_title(liquid)
        ax.set_xlabel(f"push (× {DEFAULT_PUSH_MM:g} mm)")
    axes[0].set_ylabel("λ / λ0 (small-amplitude truth)")
    axes[0].legend()
    save_figure(fig, path, tight=True)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--quick", action="store_true", help="fewer seeds")
    parser.add_argument("--video", action="store_true", help="also the video chain subset")
    parser.add_argument("--classify", action="store_true", help="also all liquids + SVM")
    parser.add_argument("--figure", type=Path, default=FIGURE)
    args = parser.parse_args()
    seeds = [1, 2] if args.quick else [1, 2, 3, 4, 5]
    print(f"# push_invariance — {len(seeds)} seeds × fills {LIQUIDS}\n")
    rows = push_rows(seeds, video=False)
    print_push_tables(rows, "Force level")
    figure(rows, args.figure)
    print(f"Figure: `{args.figure}`\n")
    if args.video:
        print_push_tables(push_rows([1, 2], video=True), "Video chain (one fill per liquid)")
    if args.classify:
        classification([0, 1, 2, 3] if args.quick else [0, 1, 2, 3, 4, 5])
    print(f"command: `{' '.join(['.venv/bin/python', *sys.argv])}`")


if __name__ == "__main__":
    main()
