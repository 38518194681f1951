"""Benchmark: (λ, ω) → height, sugar concentration, log10 viscosity; data efficiency; transfer.

On generated tables shaped like the paper's sugar experiment (benchmarks/synthetic_tables.py:
container A L = 120 mm, b = 60 mm; 17 heights 16-40 mm × 12 concentrations 0-160 g/100 g;
4 % noise on λ, 0.3 % on ω), in one run:

1. test MAE of h, c, μ for GPR, the quadratic model and the physics-informed GPR
   (train 9 heights × 12, test the other 8 × 12); the plain GPR is the baseline;
2. extrapolation in height (train 16-32 mm, test 33-40 mm);
3. data efficiency: MAE of c and h vs 10…108 training points (PNG);
4. transfer to container B (L = 100 mm, b = 50 mm, wall factor 1.65) vs training from
   scratch, with 5…100 points of B (PNG).

Usage: python benchmarks/regression.py [--seeds 3] [--out benchmarks/results]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from liquidtouch.io.tables import FEATURE_COLUMNS
from liquidtouch.models.property_model import MODEL_KINDS
from liquidtouch.models.training import train_regression
from liquidtouch.models.transfer import fit_transfer
from liquidtouch.testing.synthetic_tables import (
    CONTAINER_B,
    PAPER_CONCENTRATIONS,
    PAPER_HEIGHTS_MM,
    paper_split,
    sugar_table,
)

FEATURES = list(FEATURE_COLUMNS)
TARGETS = ["height_mm", "sugar_concentration", "log10_viscosity_cst"]
KINDS = list(MODEL_KINDS)


def _mae(model, table, targets) -> dict[str, float]:
    pred = model.predict(table[FEATURES].to_numpy())
    return {t: float(np.mean(np.abs(pred[t][0] - table[t].to_numpy()))) for t in targets}


def _fit(table, targets, kind):
    return train_regression(table[FEATURES].to_numpy(), {t: table[t] for t in targets}, kind)


def accuracy(seeds: int) -> list[str]:
    rows = {k: {t: [] for t in TARGETS} for k in KINDS}
    times = {k: [] for k in KINDS}
    for seed in range(seeds):
        train, test = paper_split(seed)
        for kind in KINDS:
            t0 = time.perf_counter()
            model = _fit(train, TARGETS, kind)
            times[kind].append(time.perf_counter() - t0)
            for t, v in _mae(model, test, TARGETS).items():
                rows[kind][t].append(v)
    base = {t: np.mean(rows["gpr"][t]) for t in TARGETS}
    out = [
        "| model | MAE h [mm] | MAE c [g/100 g] | MAE μ [log10 cSt] | vs GPR (h, c, μ) | fit [s] |",
        "|---|---|---|---|---|---|",
    ]
    for kind in KINDS:
        m = {t: np.mean(rows[kind][t]) for t in TARGETS}
        ratio = ", ".join(f"{m[t] / base[t]:.2f}" for t in TARGETS)
        out.append(
            f"| {kind} | {m['height_mm']:.3f} | {m['sugar_concentration']:.2f} | "
            f"{m['log10_viscosity_cst']:.4f} | {ratio} | {np.mean(times[kind]):.2f} |"
        )
    return out


def extrapolation(seeds: int) -> list[str]:
    res = {k: [] for k in KINDS}
    for seed in range(seeds):
        train = sugar_table(np.linspace(16, 32, 9), PAPER_CONCENTRATIONS, seed=100 + seed)
        test = sugar_table(np.linspace(33, 40, 8), PAPER_CONCENTRATIONS, seed=200 + seed)
        for kind in KINDS:
            res[kind].append(_mae(_fit(train, ["height_mm"], kind), test, ["height_mm"]))
    base = np.mean([r["height_mm"] for r in res["gpr"]])
    out = ["| model | MAE h on 33-40 mm [mm] | vs GPR |", "|---|---|---|"]
    for kind in KINDS:
        m = np.mean([r["height_mm"] for r in res[kind]])
        out.append(f"| {kind} | {m:.3f} | {m / base:.2f} |")
    return out


def data_efficiency(seeds: int, png: Path) -> list[str]:
    sizes = [10, 20, 40, 60, 80, 108]
    curves = {(k, t): np.zeros((seeds, len(sizes))) for k in KINDS for t in TARGETS[:2]}
    for seed in range(seeds):
        train, test = paper_split(seed)
        rng = np.random.default_rng(seed)
        for j, n in enumerate(sizes):
            sub = train.iloc[rng.choice(len(train), n, replace=False)]
            for kind in KINDS:
                mae = _mae(_fit(sub, TARGETS[:2], kind), test, TARGETS[:2])
                for t in TARGETS[:2]:
                    curves[(kind, t)][seed, j] = mae[t]
    plot_curves(
        sizes,
        {f"{k}": curves[(k, "sugar_concentration")].mean(0) for k in KINDS},
        {f"{k}": curves[(k, "height_mm")].mean(0) for k in KINDS},
        "training points (container A)",
        "data efficiency (test: 8 × 12 held-out heights)",
        path=png,
    )
    out = ["| n train | " + " | ".join(f"{k} c / h" for k in KINDS) + " |"]
    out.append("|---" * (len(KINDS) + 1) + "|")
    for j, n in enumerate(sizes):
        cells = [
            f"{curves[(k, 'sugar_concentration')][:, j].mean():.2f} / "
            f"{curves[(k, 'height_mm')][:, j].mean():.3f}"
            for k in KINDS
        ]
        out.append(f"| {n} | " + " | ".join(cells) + " |")
    return out


def transfer_vs_scratch(seeds: int, png: Path) -> list[str]:
    sizes = [5, 10, 15, 25, 50, 100]
    targets = TARGETS
    train_a, _ = paper_split(0)
    model_a = _fit(train_a, targets, "gpr")
    pool = sugar_table(PAPER_HEIGHTS_MM[0::2], PAPER_CONCENTRATIONS, 300, CONTAINER_B, name="B")
    test = sugar_table(PAPER_HEIGHTS_MM[1::2], PAPER_CONCENTRATIONS, 301, CONTAINER_B, name="B")
    as_is = _mae(model_a, test, targets)
    res = {m: np.zeros((seeds, len(sizes), len(targets))) for m in ("transfer", "scratch")}
    for seed in range(seeds):
        rng = np.random.default_rng(400 + seed)
        for j, n in enumerate(sizes):
            tune = pool.iloc[rng.choice(len(pool), n, replace=False)]
            tuned = fit_transfer(
                model_a, tune[FEATURES].to_numpy(), {t: tune[t].to_numpy() for t in targets}
            ).model
            scratch = _fit(tune, targets, "gpr")
            res["transfer"][seed, j] = list(_mae(tuned, test, targets).values())
            res["scratch"][seed, j] = list(_mae(scratch, test, targets).values())
    plot_curves(
        sizes,
        {m: res[m][:, :, 1].mean(0) for m in res},
        {m: res[m][:, :, 0].mean(0) for m in res},
        "points of container B",
        "container B: transfer of model A vs GPR from scratch",
        path=png,
    )
    out = [
        f"Model A unchanged on container B: MAE h {as_is['height_mm']:.2f} mm, "
        f"c {as_is['sugar_concentration']:.1f}, μ {as_is['log10_viscosity_cst']:.3f}.",
        "",
        "| n (B) | transfer h / c / μ | scratch h / c / μ | scratch ÷ transfer (c) |",
        "|---|---|---|---|",
    ]
    for j, n in enumerate(sizes):
        tr, sc = res["transfer"][:, j].mean(0), res["scratch"][:, j].mean(0)
        out.append(
            f"| {n} | {tr[0]:.2f} / {tr[1]:.1f} / {tr[2]:.3f} | "
            f"{sc[0]:.2f} / {sc[1]:.1f} / {sc[2]:.3f} | {sc[1] / tr[1]:.2f} |"
        )
    return out


def plot_curves(
    sizes,
    c_curves: dict,
    h_curves: dict,
    xlabel: str,
    title: str,
    ax=None,
    path: Path | None = None,
):
    """MAE of concentration (left) and height (right) vs training points; return the Figure.

    ``ax``: a pair of matplotlib Axes to draw into (default: a new Figure, which
    needs no display and does not touch pyplot's backend); ``path``: also save a PNG.
    """
    from matplotlib.figure import Figure

    from liquidtouch.io.figures import save_figure

    if ax is None:
        fig = Figure(figsize=(9, 3.6))
        axes = fig.subplots(1, 2)
    else:
        axes = list(ax)
        fig = axes[0].figure
    for axis, curves, ylabel in (
        (axes[0], c_curves, "MAE sugar concentration [g/100 g]"),
        (axes[1], h_curves, "MAE height [mm]"),
    ):
        for name, values in curves.items():
            axis.plot(sizes, values, "o-", label=name)
        axis.set_xscale("log")
        axis.set_yscale("log")
        axis.set_xlabel(xlabel)
        axis.set_ylabel(ylabel)
        axis.grid(True, which="both", alpha=0.3)
    axes[0].legend()
    fig.suptitle(title)
    if ax is None:
        fig.tight_layout()
    if path is not None:
        save_figure(fig, path)
    return fig


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    args = parser.parse_args()
    t0 = time.perf_counter()
    sections = [
        ("Test MAE, train 9 × 12 / test 8 × 12 (baseline: plain GPR)", accuracy(args.seeds)),
        ("Height extrapolation: train 16-32 mm, test 33-40 mm", extrapolation(args.seeds)),
        (
            "Data efficiency: MAE c / h vs training points (regression_data_efficiency.png)",
            data_efficiency(args.seeds, args.out / "regression_data_efficiency.png"),
        ),
        (
            "Container transfer vs training from scratch (regression_transfer.png)",
            transfer_vs_scratch(args.seeds, args.out / "regression_transfer.png"),
        ),
    ]
    for title, lines in sections:
        print(f"### {title}\n")
        print("\n".join(lines) + "\n")
    print(f"_{args.seeds} seeds; total {time.perf_counter() - t0:.0f} s_")


if __name__ == "__main__":
    main()
