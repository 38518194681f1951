"""Time to answer: ring-down seconds until the streamed height and viscosity are right, and
whether their std means what it says.

One run, on simulated trials (GelSight Mini videos, 320 × 240 at 25 fps):

1. a training set — every liquid of the catalogue (water, olive oil, corn oil,
   mirin, detergent, sugar water at 40/100/160 g/100 g) × ``--train-heights``
   fill heights 16-40 mm — extracted offline as ``liquidtouch extract`` does,
   and a GPR and a physics-GPR trained on it as ``liquidtouch train`` does
   (targets ``height_mm``, ``log10_viscosity_cst``; cross-conformal calibration,
   10 folds with ``train``'s default groups), plus two GPRs trained on sugar water
   alone, judged on olive oil, corn oil and mirin: on that set's sugar-water trials
   (``sugar-only``, 3 concentrations) and on the paper's sugar design (``sugar-paper``:
   its 9 training concentrations 0-160 at the same heights, simulated as well — the
   README's advice of 8-9 levels of what the model must interpolate);
2. ``--trials`` test trials per liquid (random heights 18-38 mm; sugar water at a
   random concentration 20-140) streamed through
   :func:`liquidtouch.live.live_updates` (``realtime=False``); every refresh's
   λ, ω and their streamed std (recorded whether or not the λ/ω gates show them)
   go through each model as the stream does
   (:func:`~liquidtouch.live.properties.predict_with_fit_std`; the std without its
   floors, :mod:`liquidtouch.live.uncertainty`); a property is reported once its std
   is at most the tolerance (``REPORT_STD``, ``--until-std``'s rule);
3. tables: the ring-down time [s] until height is within 1 mm and log10 ν within
   0.1 of the truth and stays there (median, 90th percentile per liquid; ``inf``:
   the final estimate is still off), in two readings — every estimate as ``live``
   shows it without ``--until-std``, and only once its std is at most the tolerance —
   against the offline estimate on the full record (the final update refits the
   whole record as ``extract``); the ±1σ/±2σ coverage of the truth per ring-down
   time, with a 95 % interval from resampling the test trials within each liquid,
   and of the final λ, ω by the streamed ones; the per-frame latency of ``add_frame``
   (refreshes run in the call here; ``benchmarks/live_latency.py`` measures the
   real-time, threaded case); a PNG of coverage and error vs ring-down time.

The simulated features are saved (``--save data.json``) and a run can be
re-analysed from them (``--load data.json``; several runs of other ``--seed`` are pooled
into one test set) without simulating again: each refresh's
row holds the streaming fit's own std and window, so the models' λ, ω std is recomputed
with the current rule (:func:`~liquidtouch.live.uncertainty.property_feature_std`);
``--as-streamed`` keeps the std the stream gave, ``--model-std-scores`` calibrates on
scores of the model's std alone (the rule before the total-std scores).

Usage: nice -n 10 python benchmarks/time_to_answer.py [--trials 4] [--train-heights 8]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from time_to_answer_tables import (
    KINDS,
    TARGETS,
    TEST_LIQUIDS,
    plot,
    report_calibration,
    report_coverage,
    report_latency,
    report_sugar_only,
    report_time_to_answer,
)

from liquidtouch.io.dataset import TRUTH_COLUMNS
from liquidtouch.live.uncertainty import (
    DECAY_REL_STD_FLOOR,
    FREQ_REL_STD_FLOOR,
    property_feature_std,
)
from liquidtouch.sim.presets import TRAIN_CONCENTRATIONS

TRAIN_SUGAR = (40.0, 100.0, 160.0)
#: columns of the per-refresh rows: the λ, ω std as the property models got them in the
#: stream, then the streaming fit's own: window [s], std of λ and ω as streamed
#: (``REFRESH_NOISE``: correlated noise in runs before 2026-11-25's change, jackknife
#: since), and the jackknife std (the larger of it and the correlated one)
ROW_COLUMNS = ("t_s", "decay_rate", "decay_rate_std", "angular_frequency", "angular_frequency_std",
               "window_s", "decay_rate_fit_std", "angular_frequency_fit_std",
               "decay_rate_jackknife_std", "angular_frequency_jackknife_std")  # fmt: skip
#: the saved rows' std: what the models get, without the streamed std's floors (earlier
#: files held the std with them: stripped on loading)
ROW_STD = "without-floors"


def simulate(root: Path, name: str, liquid: str, height_mm: float, conc, seed: int, dur: float):
    """Simulate and write one Mini trial; its directory and labels."""
    from liquidtouch.sim.trial import simulate_trial
    from liquidtouch.sim.trial_io import write_trial

    trial = simulate_trial(
        liquid, height_mm=height_mm, sugar_concentration=conc, seed=seed, duration_s=dur
    )
    return write_trial(trial, root / name, sensor="mini"), trial.labels()


def training_set(root: Path, n_heights: int, duration_s: float, advance) -> list[dict]:
    """One record per training trial: offline fit (λ, ω, std, κ), labels and the training
    set it belongs to (``all``: every liquid; ``sugar-paper``: the paper's sugar design)."""
    from liquidtouch.extraction.pipeline import extract

    entries = [("all", liq, None) for liq in TEST_LIQUIDS if liq != "sugar-water"]
    entries += [("all", "sugar-water", c) for c in TRAIN_SUGAR]
    entries += [("sugar-paper", "sugar-water", float(c)) for c in TRAIN_CONCENTRATIONS]
    out = []
    for i, (which, liquid, conc) in enumerate(entries):
        for j, h in enumerate(np.linspace(16.0, 40.0, n_heights)):
            directory, labels = simulate(
                root, f"train_{i}_{j}", liquid, float(h), conc, 1000 + 37 * i + j, duration_s
            )
            fit = fit_record(extract(directory).fit)
            out.append(
                {"set": which, "liquid": liquid, "sugar_concentration": conc, "fit": fit}
                | labels_of(labels)
            )
            advance()
    return out


def fit_record(fit) -> dict:
    keys = ("decay_rate", "decay_rate_std", "angular_frequency", "angular_frequency_std",
            "damping_gain", "damping_gain_std")  # fmt: skip
    return {k: float(getattr(fit, k)) for k in keys}


def labels_of(labels: dict) -> dict:
    return {t: float(labels[t]) for t in TARGETS}


def train_rows(train: list[dict], which: str = "all", liquids=None) -> list[dict]:
    """The training records of set ``which`` (of ``liquids``: all when ``None``)."""
    return [
        r
        for r in train
        if r.get("set", "all") == which and (liquids is None or r["liquid"] in liquids)
    ]


def train_matrix(rows: list[dict]) -> tuple[np.ndarray, dict]:
    X = np.array([(r["fit"]["decay_rate"], r["fit"]["angular_frequency"]) for r in rows])
    return X, {t: np.array([r[t] for r in rows]) for t in TARGETS}


class _Recorder:
    """A stand-in regression model that records the (λ, σλ, ω, σω) of every refresh."""

    kind = "regression"
    targets = ("call",)

    def __init__(self) -> None:
        self.calls: list[tuple[float, ...]] = []

    def predict(self, X, X_std=None):
        X, X_std = np.asarray(X, float), np.asarray(X_std, float)
        self.calls.append((X[0, 0], X_std[0, 0], X[0, 1], X_std[0, 1]))
        n = len(self.calls) - 1
        return {"call": (np.array([float(n)]), np.array([0.0]))}

    def in_domain(self, X) -> np.ndarray:
        """Every row is in the domain (the stream's out-of-domain flag is not measured here)."""
        return np.ones(len(X), bool)


class _FitRecorder:
    """Wraps the streaming refresh's ``fit_oscillation``: each streaming fit's own std
    (correlated noise, as streamed) and its jackknife std (the same window refitted with
    ``noise="jackknife"``), keyed by the fit's (λ, ω)."""

    def __init__(self, fit_oscillation) -> None:
        self.fit_oscillation, self.fits = fit_oscillation, {}

    def __call__(self, t, u, **options):
        fit = self.fit_oscillation(t, u, **options)
        jk = fit
        if options.get("noise") != "jackknife":
            jk = self.fit_oscillation(t, u, **(options | {"noise": "jackknife"}))
        self.fits[(fit.decay_rate, fit.angular_frequency)] = (
            fit.duration_s, fit.decay_rate_std, fit.angular_frequency_std,
            jk.decay_rate_std, jk.angular_frequency_std,
        )  # fmt: skip
        return fit


def stream_trial(directory: Path) -> dict:
    """Every refresh's row (``ROW_COLUMNS``) — ungated — of one stream, and its timing."""
    import liquidtouch.live.refresh as refresh_module
    from liquidtouch.live import live_updates

    recorder = _Recorder()
    fits = _FitRecorder(refresh_module.fit_oscillation)
    refresh_module.fit_oscillation = fits  # benchmark only: record the fits' own std
    try:
        updates = list(live_updates(directory, realtime=False, model=recorder))
    finally:
        refresh_module.fit_oscillation = fits.fit_oscillation
    rows = []
    for u in updates:
        if "call" in u.predicted:
            call = recorder.calls[int(u.predicted["call"][0])]
            rows.append((u.t_s, *call, *fits.fits.get((call[0], call[2]), (np.nan,) * 5)))
    return {"rows": np.array(rows).tolist(), "timing": updates[-1].timing}


def predictions(model, rows: np.ndarray) -> dict[str, np.ndarray]:
    """``{target: (U, 2) mean, std}`` per refresh (NaN where the fit gave no λ or ω)."""
    X, X_std = rows[:, [1, 3]], rows[:, [2, 4]]
    ok = np.isfinite(X).all(axis=1)
    out = {t: np.full((len(rows), 2), np.nan) for t in model.targets}
    if ok.any():
        for target, (mean, std) in model.predict(X[ok], X_std[ok]).items():
            out[target][ok] = np.column_stack([mean, std])
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=4, help="test trials per liquid")
    parser.add_argument("--train-heights", type=int, default=8, help="training heights per liquid")
    parser.add_argument("--duration", type=float, default=10.0, help="trial length [s]")
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    parser.add_argument("--save", type=Path, help="write the simulated features here (JSON)")
    parser.add_argument(
        "--load",
        type=Path,
        nargs="+",
        help="re-analyse features saved by --save; several runs (other --seed, same training "
        "set) are pooled into one test set",
    )
    parser.add_argument(
        "--as-streamed",
        action="store_true",
        help="with --load: keep the λ, ω std the models got in the stream (default: "
        "recompute it from the streaming fit's jackknife std with the current rule)",
    )
    parser.add_argument(
        "--model-std-scores",
        action="store_true",
        help="calibrate on scores of the model's std alone (before: the total std with the "
        "training rows' fit std, as `train` does from a features table)",
    )
    args = parser.parse_args()

    began = time.perf_counter()
    if args.load is not None:
        data = load_pooled(args.load)
    else:
        data = simulate_all(args)
        if args.save is not None:
            args.save.write_text(json.dumps(data))
    took = time.perf_counter() - began
    train, streams = data["train"], data["tests"]
    sugar = [r for r in train if r["liquid"] == "sugar-water"]
    for k, r in enumerate(sugar):  # files before the paper's sugar design: 3 concentrations
        r.setdefault("sugar_concentration", TRAIN_SUGAR[k * len(TRAIN_SUGAR) // len(sugar)])
    for test in streams:
        rows = np.asarray(test["rows"], float)
        test["rows"] = rows if rows.ndim == 2 else rows.reshape(0, len(ROW_COLUMNS))
        if test["rows"].shape[1] == len(ROW_COLUMNS):
            if not args.as_streamed:
                restream_std(test["rows"])
        elif data.get("row_std") != ROW_STD:
            strip_floors(test["rows"])
    # a stream whose ring-down check never passed has no fit at all: no answer (time inf)
    tests = [t for t in streams if len(t["rows"])]
    per_liquid = len(streams) // len(TEST_LIQUIDS)
    print(
        f"{len(train)} training trials, {len(streams)} test trials ({per_liquid} per liquid), "
        f"{data['duration']:g} s each, GelSight Mini; {took:.0f} s; streams without any fit: "
        + (", ".join(t["liquid"] for t in streams if not len(t["rows"])) or "none")
    )
    models = train_models(train, fit_std=not args.model_std_scores)
    for test in tests:
        test["pred"] = {kind: predictions(model, test["rows"]) for kind, model in models.items()}
    report_calibration(models)
    report_time_to_answer(streams)
    report_coverage(tests)
    report_sugar_only(tests, tuple(k for k in ("sugar-only", "sugar-paper") if k in models))
    report_latency(tests)
    args.out.mkdir(parents=True, exist_ok=True)
    print(f"figure: {plot(tests, args.out / 'time_to_answer.png')}")


def simulate_all(args) -> dict:
    from liquidtouch.extraction.pipeline import extract
    from liquidtouch.testing import progress_bar

    rng = np.random.default_rng(args.seed)
    n_train = len(TEST_LIQUIDS) - 1 + len(TRAIN_SUGAR) + len(TRAIN_CONCENTRATIONS)
    n_train *= args.train_heights
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        with progress_bar("training trials", n_train) as advance:
            train = training_set(root, args.train_heights, args.duration, advance)
        tests = []
        with progress_bar("test streams", len(TEST_LIQUIDS) * args.trials) as advance:
            for liquid in TEST_LIQUIDS:
                for r in range(args.trials):
                    conc = float(rng.uniform(20, 140)) if liquid == "sugar-water" else None
                    h, seed = float(rng.uniform(18.0, 38.0)), int(rng.integers(2**31))
                    directory, labels = simulate(
                        root, f"test_{liquid}_{r}", liquid, h, conc, seed, args.duration
                    )
                    streamed = stream_trial(directory)
                    offline = fit_record(extract(directory).fit)
                    tests.append(
                        {
                            "liquid": liquid,
                            "truth": labels_of(labels),
                            "truth_fit": {k: float(labels[k]) for k in TRUTH_COLUMNS},
                            "offline": offline,
                            **streamed,
                        }
                    )
                    advance()
    return {"duration": args.duration, "row_std": ROW_STD, "train": train, "tests": tests}


def load_pooled(paths: list[Path]) -> dict:
    """The runs saved at ``paths`` as one: the first run's data with every run's test streams
    (the training sets must be the same: the runs differ only by ``--seed`` or ``--trials``)."""
    data = json.loads(paths[0].read_text())
    for path in paths[1:]:
        other = json.loads(path.read_text())
        if other["train"] != data["train"] or other["duration"] != data["duration"]:
            print(f"error: {path} was not run on {paths[0]}'s training set", file=sys.stderr)
            raise SystemExit(2)
        data["tests"] += other["tests"]
    return data


def strip_floors(rows: np.ndarray) -> None:
    """Streamed rows saved with the floors in their std (all but the final): without them."""
    for col, floor in ((1, DECAY_REL_STD_FLOOR), (3, FREQ_REL_STD_FLOOR)):
        std = rows[:-1, col + 1]
        rows[:-1, col + 1] = np.sqrt(np.maximum(std**2 - (rows[:-1, col] * floor) ** 2, 0.0))


def restream_std(rows: np.ndarray) -> None:
    """The models' λ, ω std of every streamed row (all but the final) recomputed from the
    streaming fit's own jackknife std and window with the current rule
    (:func:`~liquidtouch.live.uncertainty.property_feature_std`), so one simulation is
    re-analysed under a changed rule; a row without a recorded fit keeps its std."""
    lam, win, s_lam, s_omega = rows[:-1, 1], rows[:-1, 5], rows[:-1, 8], rows[:-1, 9]
    omega = rows[:-1, 3]
    for i in np.flatnonzero(np.isfinite(win)):
        rows[i, 2], rows[i, 4] = property_feature_std(
            lam[i], s_lam[i], omega[i], s_omega[i], win[i]
        )


def train_models(train: list[dict], fit_std: bool = True) -> dict:
    """A GPR and a physics-GPR on every training trial of set ``all``, a GPR on its
    sugar-water trials (``sugar-only``) and one on the paper's sugar design
    (``sugar-paper``, when simulated); each calibrated as ``train`` does (10 folds, the
    default groups of a table of the trials' liquid, fill height and sugar concentration;
    ``fit_std``: scores normalised by the total std with the rows' own fit std)."""
    import pandas as pd

    from liquidtouch.models.conformal import default_groups
    from liquidtouch.models.training import train_regression

    def model(rows: list[dict], kind: str):
        columns = ("liquid", "height_mm", "sugar_concentration")
        table = pd.DataFrame({k: [r.get(k) for r in rows] for k in columns})
        X, y = train_matrix(rows)
        X_std = [(r["fit"]["decay_rate_std"], r["fit"]["angular_frequency_std"]) for r in rows]
        return train_regression(
            X,
            y,
            kind,
            calibration_folds=10,
            calibration_groups=default_groups(table),
            calibration_std=X_std if fit_std else None,
        )

    models = {kind: model(train_rows(train), kind) for kind in KINDS}
    models["sugar-only"] = model(train_rows(train, liquids=("sugar-water",)), "gpr")
    paper = train_rows(train, "sugar-paper")
    if paper:
        models["sugar-paper"] = model(paper, "gpr")
    return models


if __name__ == "__main__":
    main()
