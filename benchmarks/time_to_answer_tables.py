"""The tables and figure of ``time_to_answer.py``: time to answer per liquid, coverage of
the truth per ring-down time, the sugar-water-only models on other liquids, the latency.

Each test record holds ``rows`` (per refresh: t_s, λ, σλ, ω, σω, the std as the property
models get it, :mod:`liquidtouch.live.uncertainty`), ``truth`` and ``pred`` (per model kind
and target, ``(U, 2)`` mean and std per refresh; the last refresh is the final estimate).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from liquidtouch.experiments.time_to_answer import BINS_S, TOLERANCES, settle_time_s
from liquidtouch.live.calibration import COVERAGE_KS, coverage, nominal_coverage
from liquidtouch.live.uncertainty import DECAY_REL_STD_FLOOR, FREQ_REL_STD_FLOOR

TEST_LIQUIDS = ("water", "olive-oil", "corn-oil", "mirin", "detergent", "sugar-water")
TARGETS = ("height_mm", "log10_viscosity_cst")
KINDS = ("gpr", "physics-gpr")
#: a property is reported once its std is at most this (the stream's --until-std)
REPORT_STD = {"height_mm": 1.0, "log10_viscosity_cst": 0.1}
#: liquids a sugar-water-only model is judged on
OTHER_LIQUIDS = ("olive-oil", "corn-oil", "mirin")


def quantiles(values: list[float]) -> str:
    v = np.asarray(values, float)
    med, p90 = np.percentile(v, 50, method="lower"), np.percentile(v, 90, method="higher")
    return f"{med:6.2f} {p90:6.2f}"


def displayed_std(rows: np.ndarray, col: int) -> np.ndarray:
    """The streamed λ (``col`` 1) or ω (3) std the stream shows: the floor added back."""
    floor = DECAY_REL_STD_FLOOR if col == 1 else FREQ_REL_STD_FLOOR
    return np.hypot(rows[:, col + 1], rows[:, col] * floor)


def report_calibration(models: dict) -> None:
    print(
        "\ncalibration (10-fold cross-conformal on the training rows): std scale, ±1σ/±2σ in-sample"
    )
    for kind, model in models.items():
        for target, cal in model.calibration.items():
            print(
                f"  {kind:12s} {target:22s} n={cal.n:3d} scale {cal.std_scale:5.2f} "
                f"{cal.coverage_of(1):4.0%} {cal.coverage_of(2):4.0%}"
            )


def reported(test: dict, kind: str, target: str) -> tuple[np.ndarray, np.ndarray]:
    """(mean, std) per refresh, NaN where not reported (std above REPORT_STD); final always."""
    mean, std = test["pred"][kind][target].T.copy()
    hide = ~(std <= REPORT_STD[target])
    hide[-1] = False
    mean[hide], std[hide] = np.nan, np.nan
    return mean, std


def report_sugar_only(tests: list[dict], kinds: tuple[str, ...]) -> None:
    print(
        "\nsugar-water-only GPR on the other liquids, final (offline) estimate: ±1σ ±2σ rms-z n; "
        "sugar-only: the 3 training concentrations × the training heights; sugar-paper: the "
        "paper's 9 concentrations (0-160) × the training heights"
    )
    for kind in kinds:
        for target in TARGETS:
            final = [
                (0.0, t["pred"][kind][target][-1, 0], t["pred"][kind][target][-1, 1],
                 t["truth"][target])
                for t in tests if t["liquid"] in OTHER_LIQUIDS
            ]  # fmt: skip
            _, mean, _, truth = np.array(final).T
            mae = np.nanmean(np.abs(mean - truth))
            cells = coverage_cells(final, 0.0, math.inf)
            print(f"  {kind:12s} {target:22s} {cells}  MAE {mae:.3g}")


def report_time_to_answer(tests: list[dict]) -> None:
    gate = ", ".join(f"{t} std ≤ {v:g}" for t, v in REPORT_STD.items())
    print(
        "\nring-down time [s] until within tolerance for good (height 1 mm, log10 ν 0.1); "
        f"median p90; reported once {gate}; 'record' = the offline estimate on the full record"
    )
    for kind in KINDS:
        print(f"\n{kind}")
        head = f"{'liquid':12s} {'n':>2s} {'height':>13s} {'log10 ν':>13s} {'both':>13s}"
        print(f"{head} {'record':>7s} {'offline |Δh| |Δμ|':>18s} {'offline right: h, ν':>22s}")
        for liquid in TEST_LIQUIDS:
            cells = {t: [] for t in (*TARGETS, "both")}
            record, errs = [], {t: [] for t in TARGETS}
            right = {t: [] for t in TARGETS}  # the settle time where the final is right
            for test in (t for t in tests if t["liquid"] == liquid):
                if not len(test["rows"]):  # no fit: never answered
                    for c in cells.values():
                        c.append(math.inf)
                    for target in TARGETS:
                        right[target].append(math.nan)
                    continue
                t_s, ok_all = test["rows"][:, 0], None
                for target in TARGETS:
                    mean, _ = reported(test, kind, target)
                    with np.errstate(invalid="ignore"):
                        ok = np.abs(mean - test["truth"][target]) <= TOLERANCES[target]
                    cells[target].append(settle_time_s(t_s, ok))
                    ok_all = ok if ok_all is None else ok_all & ok
                    errs[target].append(abs(mean[-1] - test["truth"][target]))
                    is_right = errs[target][-1] <= TOLERANCES[target]
                    right[target].append(cells[target][-1] if is_right else math.nan)
                cells["both"].append(settle_time_s(t_s, ok_all))
                record.append(t_s[-1])
            line = " ".join(f"{quantiles(cells[c]):>13s}" for c in (*TARGETS, "both"))
            right_cells = " ".join(_median_of_right(right[t]) for t in TARGETS)
            print(
                f"{liquid:12s} {len(cells['both']):2d} {line} {np.median(record):7.2f} "
                f"{np.mean(errs[TARGETS[0]]):8.2f} {np.mean(errs[TARGETS[1]]):8.3f} "
                f"{right_cells:>22s}"
            )
    print(
        "(offline |Δh| |Δμ|: mean absolute error of the final estimate; offline right: the "
        "median time over the trials whose final estimate is within tolerance, and how many)"
    )


def _median_of_right(times: list[float]) -> str:
    """Median settle time [s] of the trials whose final estimate is right (the others NaN),
    and how many of all they are."""
    right = [t for t in times if not math.isnan(t)]
    median = f"{np.percentile(right, 50, method='lower'):.2f}" if right else "-"
    return f"{median} ({len(right)}/{len(times)})"


def coverage_cells(z_rows: list[tuple[float, float, float, float]], lo: float, hi: float) -> str:
    rows = np.array([r for r in z_rows if lo <= r[0] < hi]).reshape(-1, 4)
    rows = rows[np.isfinite(rows[:, 1]) & np.isfinite(rows[:, 2])]
    if not len(rows):
        return f"{'-':>20s}"
    cov = coverage(rows[:, 1], rows[:, 2], rows[:, 3])
    z_rms = math.sqrt(np.mean(((rows[:, 1] - rows[:, 3]) / rows[:, 2]) ** 2))
    return f"{cov[1.0]:4.0%} {cov[2.0]:4.0%} {z_rms:4.2f} {len(rows):4d}"


def report_coverage(tests: list[dict]) -> None:
    bins = [f"{lo:g}-{hi:g} s" if math.isfinite(hi) else f"≥{lo:g} s" for lo, hi in BINS_S]
    nominal = ", ".join(f"±{k:g}σ {nominal_coverage(k):.0%}" for k in COVERAGE_KS)
    for title, gated in (("every refresh", False), ("reported values only", True)):
        print(
            f"\ncoverage of the truth, {title} (±1σ ±2σ rms-z n; nominal {nominal}, rms z 1), "
            "by ring-down time; final: the offline estimate"
        )
        head = " ".join(f"{b:>20s}" for b in [*bins, "final"])
        print(f"{'model / target':30s} {head}")
        for kind in KINDS:
            for target in TARGETS:
                stream, final = [], []
                for test in tests:
                    t_s = test["rows"][:, 0]
                    if gated:
                        mean, std = reported(test, kind, target)
                    else:
                        mean, std = test["pred"][kind][target].T
                    truth = test["truth"][target]
                    stream += [
                        (t, m, s, truth)
                        for t, m, s in zip(t_s[:-1], mean[:-1], std[:-1], strict=True)
                    ]
                    final.append((0.0, mean[-1], std[-1], truth))
                cells = [coverage_cells(stream, lo, hi) for lo, hi in BINS_S]
                cells.append(coverage_cells(final, 0.0, math.inf))
                print(f"{kind + ' ' + target:30s} " + " ".join(cells))
    for col, name in ((1, "λ (of the final λ)"), (3, "ω (of the final ω)")):
        rows = []
        for test in tests:
            r, shown = test["rows"], displayed_std(test["rows"], col)
            rows += [
                (t, v, s, r[-1, col])
                for t, v, s in zip(r[:-1, 0], r[:-1, col], shown[:-1], strict=True)
            ]
        cells = [coverage_cells(rows, lo, hi) for lo, hi in BINS_S]
        print(f"{'streamed ' + name:30s} " + " ".join(cells))


def report_latency(tests: list[dict]) -> None:
    med = [t["timing"]["latency_ms_median"] for t in tests]
    p95 = [t["timing"]["latency_ms_p95"] for t in tests]
    worst = max(t["timing"]["latency_ms_max"] for t in tests)
    budget = 1e3 / 50.0  # two Mini sensors at 25 fps
    print(
        f"\nper-frame add_frame latency [ms] (refreshes in the call), over {len(tests)} streams: "
        f"median {np.median(med):.2f}, p95 {np.median(p95):.2f}, max {worst:.1f}; "
        f"frame budget (2 × 25 fps) {budget:.0f} ms, median / budget {np.median(med) / budget:.2f}"
    )


def plot(tests: list[dict], path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from liquidtouch.io.figures import save_figure

    fig, axes = plt.subplots(2, 2, figsize=(11, 7))
    colours = dict(zip(TEST_LIQUIDS, plt.cm.tab10.colors, strict=False))
    centres = [lo + (min(hi, lo + 2.0) - lo) / 2 for lo, hi in BINS_S]
    for col, target in enumerate(TARGETS):
        ax = axes[0, col]
        for test in tests:
            t_s, mean = test["rows"][:, 0], test["pred"]["gpr"][target][:, 0]
            ax.plot(t_s, np.abs(mean - test["truth"][target]), color=colours[test["liquid"]])
        ax.axhline(TOLERANCES[target], color="k", ls="--", lw=1)
        ax.set(yscale="log", xlabel="ring-down time [s]", ylabel=f"GPR |error| of {target}")
        ax = axes[1, col]
        for kind, style in zip(KINDS, ("-", ":"), strict=True):
            for k in COVERAGE_KS:
                fractions = []
                for lo, hi in BINS_S:
                    rows = [
                        (m, s, test["truth"][target])
                        for test in tests
                        for tt, (m, s) in zip(
                            test["rows"][:-1, 0], test["pred"][kind][target][:-1], strict=True
                        )
                        if lo <= tt < hi
                    ]
                    arr = np.array(rows).reshape(-1, 3)
                    arr = arr[np.isfinite(arr).all(axis=1)]
                    fractions.append(coverage(arr[:, 0], arr[:, 1], arr[:, 2], (k,))[k])
                ax.plot(centres, fractions, style, marker="o", label=f"{kind} ±{k:g}σ")
        for k in COVERAGE_KS:
            ax.axhline(nominal_coverage(k), color="grey", lw=0.8)
        ax.set(xlabel="ring-down time [s] (bin)", ylabel=f"coverage of {target}", ylim=(0, 1))
    for liquid, colour in colours.items():
        axes[0, 0].plot([], [], color=colour, label=liquid)
    axes[0, 0].legend(fontsize=7)
    axes[1, 0].legend(fontsize=7)
    return save_figure(fig, path, tight=True)
