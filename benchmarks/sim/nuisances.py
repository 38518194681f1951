"""What each real-bench nuisance costs: λ, ω and property errors, one nuisance at a time.

Every nuisance of :class:`liquidtouch.sim.realism.Realism` is switched on alone at its
default (cited) strength and at 2×, then all together (``lab``), on a fixed test set
of sugar-water trials (the ``sugar`` preset's test trials, a deterministic subset,
GelSight Mini profile, 13 s, full pipeline: render → H.264 → track → fit). The
nuisances draw from their own random streams, so each trial differs from the clean
trial of the same seed by that nuisance alone (paired comparison).

Per world:

- ``dλ`` / ``dω``: median and max over the test trials of |fit − clean trial's fit| /
  clean trial's fit [%] (what the nuisance does to the measurement);
- ``λ err``: median |fit − truth| / truth [%] (truth: the slow mode of the trial's own
  physics, which a physical nuisance moves);
- property MAE of a GPR trained on a **clean** training set (the ``sugar`` preset's
  quick training subset): height [mm], concentration [g/100 g], log10 viscosity;
- trials that crashed or were refused by the pipeline.

    PYTHONPATH=src nice -n 10 .venv/bin/python benchmarks/nuisances.py \
        [--trials 10] [--train 36] [--jobs 2] [--data DIR] [--only NAME ...] [--factors 1 2]

~40 worlds × 10 trials at ~2.5 s a trial: ~8 min on 2 idle cores. Writes
``benchmarks/results/nuisances.csv`` and prints a markdown table.
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

from liquidtouch.batch.features import extract_features
from liquidtouch.experiments.common import X, mae, usable
from liquidtouch.io.dataset import MANIFEST_NAME
from liquidtouch.models.training import train_regression
from liquidtouch.sim.presets import get_preset, simulate_dataset
from liquidtouch.sim.realism import NUISANCES, Realism

TARGETS = ("height_mm", "sugar_concentration", "log10_viscosity_cst")
CSV = Path("benchmarks/results/nuisances.csv")


def test_specs(n: int) -> list:
    """``n`` sugar test trials spread over the preset's test set (deterministic)."""
    specs = [s for s in get_preset("sugar") if s.split == "test"]
    idx = np.random.default_rng(25).choice(len(specs), n, replace=False)
    return [specs[i] for i in sorted(idx)]


def train_specs(n: int) -> list:
    """The sugar preset's quick training subset (first ``n``)."""
    return [s for s in get_preset("sugar", quick=True) if s.split == "train"][:n]


def features(specs: list, root: Path, world: Realism, jobs: int) -> pd.DataFrame:
    """Simulate (unless there) and extract ``specs`` in ``world``; the feature table."""
    if not (root / MANIFEST_NAME).is_file():
        result = simulate_dataset(
            specs, root, jobs=jobs, sensor="mini", realism=world, progress=False
        )
        failed = result.failures
    else:
        failed = []
    table = extract_features(root, jobs=jobs, progress=False)
    table.attrs["sim_failures"] = len(failed)
    return table


def row(name: str, table: pd.DataFrame, clean: pd.DataFrame, model) -> dict[str, object]:
    """One line of the results table (module doc: the columns)."""
    ok = usable(table)
    ref = usable(clean).set_index("trial")
    both = ok[ok["trial"].isin(ref.index)]
    lam_ref = ref.loc[both["trial"], "decay_rate"].to_numpy(float)
    om_ref = ref.loc[both["trial"], "angular_frequency"].to_numpy(float)
    dlam = np.abs(both["decay_rate"].to_numpy(float) / lam_ref - 1.0) * 100
    dom = np.abs(both["angular_frequency"].to_numpy(float) / om_ref - 1.0) * 100
    lam_err = np.abs(ok["decay_rate"] / ok["true_decay_rate"] - 1.0) * 100
    out: dict[str, object] = {
        "world": name,
        "trials": len(table),
        "failed": len(table) - len(ok) + table.attrs.get("sim_failures", 0),
        "dlam_med_pct": float(np.median(dlam)) if len(dlam) else np.nan,
        "dlam_max_pct": float(np.max(dlam)) if len(dlam) else np.nan,
        "dom_med_pct": float(np.median(dom)) if len(dom) else np.nan,
        "dom_max_pct": float(np.max(dom)) if len(dom) else np.nan,
        "lam_err_med_pct": float(np.median(lam_err)) if len(lam_err) else np.nan,
    }
    if len(ok):
        pred = model.predict(X(ok))
        for target in TARGETS:
            out[f"mae_{target}"] = mae(pred[target][0], ok[target])
    return out


def markdown(results: pd.DataFrame) -> str:
    """The results as a markdown table."""
    head = (
        "| world | failed | dλ med / max [%] | dω med / max [%] | λ err med [%] "
        "| MAE h [mm] | MAE c [g/100 g] | MAE log10 ν |\n|---|---|---|---|---|---|---|---|"
    )
    lines = [head]
    for r in results.itertuples(index=False):
        lines.append(
            f"| {r.world} | {r.failed}/{r.trials} | {r.dlam_med_pct:.1f} / {r.dlam_max_pct:.1f} "
            f"| {r.dom_med_pct:.2f} / {r.dom_max_pct:.2f} | {r.lam_err_med_pct:.1f} "
            f"| {r.mae_height_mm:.2f} | {r.mae_sugar_concentration:.1f} "
            f"| {r.mae_log10_viscosity_cst:.3f} |"
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=10, help="test trials per world")
    parser.add_argument("--train", type=int, default=36, help="clean training trials")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--data", type=Path, default=Path("/tmp/liquidtouch-nuisances"))
    parser.add_argument("--only", nargs="*", default=list(NUISANCES), choices=list(NUISANCES))
    parser.add_argument("--factors", nargs="*", type=float, default=[1.0, 2.0])
    parser.add_argument("--no-lab", action="store_true", help="skip the all-together world")
    args = parser.parse_args()
    logging.getLogger("liquidtouch").setLevel(logging.ERROR)

    start = time.perf_counter()
    tests = test_specs(args.trials)
    train = usable(features(train_specs(args.train), args.data / "train", Realism.clean(), 2))
    model = train_regression(X(train), {t: train[t].to_numpy(float) for t in TARGETS})
    clean = features(tests, args.data / "clean", Realism.clean(), args.jobs)
    worlds = [("clean", Realism.clean())]
    for name in args.only:
        for factor in args.factors:
            label = name if factor == 1 else f"{name} ×{factor:g}"
            worlds.append((label, Realism.only(name, factor)))
    if not args.no_lab:
        worlds.append(("lab (all together)", Realism.lab()))
    rows = []
    for label, world in worlds:
        key = label.replace(" ", "").replace("×", "x").replace("(", "").replace(")", "")
        table = clean if label == "clean" else features(tests, args.data / key, world, args.jobs)
        rows.append(row(label, table, clean, model))
        print(f"{label}: done ({time.perf_counter() - start:.0f} s)", file=sys.stderr, flush=True)
    results = pd.DataFrame(rows)
    CSV.parent.mkdir(parents=True, exist_ok=True)
    results.to_csv(CSV, index=False, float_format="%.4g")
    print(markdown(results))
    print(
        f"\n{len(tests)} sugar-water test trials per world (GelSight Mini, 13 s), GPR trained "
        f"on {len(train)} clean trials; {time.perf_counter() - start:.0f} s in all"
    )


if __name__ == "__main__":
    main()
