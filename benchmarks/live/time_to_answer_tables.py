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
#: resamples of the test trials behind a coverage's 95 % interval
N_BOOTSTRAP = 400
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


def estimates(test: dict, kind: str, target: str, gated: bool) -> tuple[np.ndarray, np.ndarray]:
    """(mean, std) per refresh; ``gated``: NaN where not reported (std above REPORT_STD, the
    --until-std rule), the final always."""
    mean, std = test["pred"][kind][target].T.copy()
    if not gated:
        return mean, std
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
        "median p90 over the liquid's trials; 'record' = the offline estimate on the full record"
    )
    readings = (
        ("shown", False, "every estimate, as `live` shows it without --until-std (experiment 9)"),
        ("gated", True, f"an estimate counts once --until-std is met: {gate}"),
    )
    for kind in KINDS:
        for name, gated, what in readings:
            print(f"\n{kind}, {name}: {what}")
            head = f"{'liquid':12s} {'n':>2s} {'height':>13s} {'log10 ν':>13s} {'both':>13s}"
            print(f"{head} {'record':>7s} {'offline |Δh| |Δμ|':>18s} {'offline right: h, ν':>22s}")
            for liquid in TEST_LIQUIDS:
                liquid_tests = [t for t in tests if t["liquid"] == liquid]
                print(f"{liquid:12s} {_settle_line(liquid_tests, kind, gated)}")
    print(
        "(offline |Δh| |Δμ|: mean absolute error of the final estimate; offline right: the "
        "median time over the trials whose final estimate is within tolerance, and how many)"
    )


def _settle_line(tests: list[dict], kind: str, gated: bool) -> str:
    """One liquid's row of the time-to-answer table (``gated``: with the --until-std rule)."""
    cells = {t: [] for t in (*TARGETS, "both")}
    record, errs = [], {t: [] for t in TARGETS}
    right = {t: [] for t in TARGETS}  # the settle time where the final is right
    for test in tests:
        if not len(test["rows"]):  # no fit: never answered
            for c in cells.values():
                c.append(math.inf)
            for target in TARGETS:
                right[target].append(math.nan)
            continue
        t_s, ok_all = test["rows"][:, 0], None
        for target in TARGETS:
            mean, _ = estimates(test, kind, target, gated)
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
    return (
        f"{len(cells['both']):2d} {line} {np.median(record):7.2f} "
        f"{np.mean(errs[TARGETS[0]]):8.2f} {np.mean(errs[TARGETS[1]]):8.3f} {right_cells:>22s}"
    )


def _median_of_right(times: list[float]) -> str:
    """Median settle time [s] of the trials whose final estimate is right (the others NaN),
    and how many of all they are."""
    right = [t for t in times if not math.isnan(t)]
    median = f"{np.percentile(right, 50, method='lower'):.2f}" if right else "-"
    return f"{median} ({len(right)}/{len(times)})"


def _in_bin(rows: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """The (t, mean, std, truth) rows with lo ≤ t < hi and a finite mean and std."""
    keep = (rows[:, 0] >= lo) & (rows[:, 0] < hi) & np.isfinite(rows[:, 1:3]).all(axis=1)
    return rows[keep]


def coverage_cells(z_rows, lo: float, hi: float) -> str:
    """±1σ, ±2σ, RMS z and count of the (t, mean, std, truth) rows with lo ≤ t < hi."""
    rows = _in_bin(np.array(z_rows, dtype=float).reshape(-1, 4), lo, hi)
    if not len(rows):
        return f"{'-':>20s}"
    one, two, z_rms = _z_stats(rows)
    return f"{one:4.0%} {two:4.0%} {z_rms:4.2f} {len(rows):4d}"


def _z_stats(rows: np.ndarray) -> tuple[float, float, float]:
    """(±1σ, ±2σ coverage, RMS z) of finite (t, mean, std, truth) rows."""
    cov = coverage(rows[:, 1], rows[:, 2], rows[:, 3], (1.0, 2.0))
    z_rms = math.sqrt(float(np.mean(((rows[:, 1] - rows[:, 3]) / rows[:, 2]) ** 2)))
    return cov[1.0], cov[2.0], z_rms


def interval_cells(per_trial: list[np.ndarray], liquids: list[str], lo: float, hi: float) -> str:
    """95 % interval of ±1σ, ±2σ and RMS z over the test trials: :data:`N_BOOTSTRAP`
    resamples of the trials within each liquid (a trial's refreshes stay together)."""
    kept = [_in_bin(r, lo, hi) for r in per_trial]
    if not sum(len(r) for r in kept):
        return f"{'-':>23s}"
    rng = np.random.default_rng(0)
    groups = [np.flatnonzero(np.asarray(liquids) == liquid) for liquid in dict.fromkeys(liquids)]
    draws = []
    for _ in range(N_BOOTSTRAP):
        pick = np.concatenate([rng.choice(g, len(g)) for g in groups])
        draws.append(_z_stats(np.concatenate([kept[i] for i in pick])))
    low, high = np.percentile(draws, [2.5, 97.5], axis=0)
    return (
        f"{low[0] * 100:3.0f}-{high[0] * 100:<3.0f} {low[1] * 100:3.0f}-{high[1] * 100:<3.0f} "
        f"{low[2]:.2f}-{high[2]:.2f}"
    )


def report_coverage(tests: list[dict]) -> None:
    bins = [f"{lo:g}-{hi:g} s" if math.isfinite(hi) else f"≥{lo:g} s" for lo, hi in BINS_S]
    nominal = ", ".join(f"±{k:g}σ {nominal_coverage(k):.0%}" for k in COVERAGE_KS)
    head = " ".join(f"{b:>20s}" for b in [*bins, "final"])
    every = {
        (kind, target): _coverage_rows(tests, kind, target, False)
        for kind in KINDS
        for target in TARGETS
    }
    for title, gated in (("every refresh", False), ("reported values only", True)):
        print(
            f"\ncoverage of the truth, {title} (±1σ ±2σ rms-z n; nominal {nominal}, rms z 1), "
            "by ring-down time; final: the offline estimate"
        )
        print(f"{'model / target':30s} {head}")
        for kind in KINDS:
            for target in TARGETS:
                stream, final = (
                    _coverage_rows(tests, kind, target, True) if gated else every[kind, target]
                )
                cells = [coverage_cells(np.concatenate(stream), lo, hi) for lo, hi in BINS_S]
                cells.append(coverage_cells(np.concatenate(final), 0.0, math.inf))
                print(f"{kind + ' ' + target:30s} " + " ".join(cells))
    for col, name in ((1, "λ (of the final λ)"), (3, "ω (of the final ω)")):
        rows = np.concatenate([
            np.column_stack([r[:-1, 0], r[:-1, col], displayed_std(r, col)[:-1],
                             np.full(len(r) - 1, r[-1, col])])
            for r in (test["rows"] for test in tests)
        ])  # fmt: skip
        cells = [coverage_cells(rows, lo, hi) for lo, hi in BINS_S]
        print(f"{'streamed ' + name:30s} " + " ".join(cells))
    print(
        f"\n95 % interval of every refresh's ±1σ [%], ±2σ [%] and rms z over the test trials "
        f"({N_BOOTSTRAP} resamples of the trials within each liquid; the training set is one draw)"
    )
    print(f"{'model / target':30s} " + " ".join(f"{b:>23s}" for b in [*bins, "final"]))
    liquids = [t["liquid"] for t in tests]
    for (kind, target), (stream, final) in every.items():
        cells = [interval_cells(stream, liquids, lo, hi) for lo, hi in BINS_S]
        cells.append(interval_cells(final, liquids, 0.0, math.inf))
        print(f"{kind + ' ' + target:30s} " + " ".join(cells))


def _coverage_rows(
    tests: list[dict], kind: str, target: str, gated: bool
) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Per test trial, its streamed (t, mean, std, truth) rows and its final one."""
    stream, final = [], []
    for test in tests:
        t_s = test["rows"][:, 0]
        mean, std = estimates(test, kind, target, gated)
        rows = np.column_stack([t_s, mean, std, np.full(len(t_s), test["truth"][target])])
        stream.append(rows[:-1])
        final.append(np.column_stack([[0.0], rows[-1:, 1:]]))
    return stream, final


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
            stream = np.concatenate(_coverage_rows(tests, kind, target, False)[0])
            for k in COVERAGE_KS:
                fractions = [
                    coverage(*_in_bin(stream, lo, hi)[:, 1:].T, (k,))[k] for lo, hi in BINS_S
                ]
                ax.plot(centres, fractions, style, marker="o", label=f"{kind} ±{k:g}σ")
        for k in COVERAGE_KS:
            ax.axhline(nominal_coverage(k), color="grey", lw=0.8)
        ax.set(xlabel="ring-down time [s] (bin)", ylabel=f"coverage of {target}", ylim=(0, 1))
    for liquid, colour in colours.items():
        axes[0, 0].plot([], [], color=colour, label=liquid)
    axes[0, 0].legend(fontsize=7)
    axes[1, 0].legend(fontsize=7)
    return save_figure(fig, path, tight=True)
