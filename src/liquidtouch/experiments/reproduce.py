"""Run every experiment of the paper on simulated trials, end to end, and write the report.

Each dataset is simulated once (videos and all) into
``DATA/<quick|full>-seed<N>/<preset>``, its features extracted through the
whole pipeline (videos → markers → signal → fit; cached per trial), then the
paper's seven experiments and our two (8: calibration, 9: time to answer) run on the
feature tables. Re-running reuses what is there.
``DATA`` defaults to ``<OUT>-data`` beside the report directory ``OUT``, so the
report (a few MB) can be shared without the simulated data (a GB and more).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from pathlib import Path

import numpy as np
import pandas as pd

from liquidtouch.batch.features import cache_trial_features, extract_features
from liquidtouch.experiments.provenance import provenance
from liquidtouch.experiments.report import summary_table, write_report
from liquidtouch.experiments.suite import STREAMED_TRIALS, STREAMED_TRIALS_QUICK, run_experiments
from liquidtouch.io.dataset import MANIFEST_NAME
from liquidtouch.sim.presets import get_preset, simulate_dataset
from liquidtouch.sim.realism import NUISANCES, get_realism
from liquidtouch.sim.sensors import get_sensor_profile

__all__ = [
    "DATASETS",
    "DEFAULT_SENSOR",
    "WRENCH_TABLES",
    "Reproduction",
    "default_data_dir",
    "failure_note",
    "prepare_dataset",
    "reproduce",
    "seeded_specs",
    "unsuffixed_sensor",
]

DATASETS = ("classification", "sugar", "other-liquids", "containers")
#: the classification dataset's wrist feature tables: feature source -> file name
WRENCH_TABLES = {
    "wrench": "features_wrench.csv",
    "wrench-best-effort": "features_wrench_best_effort.csv",
}


@dataclass
class Reproduction:
    """Where the report and the data went, its headline numbers and how long each part took [s]."""

    report_md: Path
    report_html: Path
    summary: pd.DataFrame
    seconds: dict[str, float]
    data_dir: Path | None = None
    seed: int = 0
    realism: str = "clean"

    @property
    def summary_csv(self) -> Path:
        """The headline numbers as CSV, beside the report."""
        return self.report_html.parent / "summary.csv"


def default_data_dir(out_dir: str | Path) -> Path:
    """``<OUT>-data``: beside the report directory, not inside it."""
    out = Path(out_dir).resolve()
    return out.with_name(f"{out.name}-data")


#: the GelSight profile the datasets are simulated with unless asked otherwise: the Mini
#: (320 x 240 at 25 fps) costs 0.46x the 640 x 480 profile's time, and the full reproduction's
#: numbers differ between the two by a sixth of what two seeds' do (median; README)
DEFAULT_SENSOR = "mini"


def unsuffixed_sensor(quick: bool) -> str:
    """The profile of the datasets under a data folder named without a sensor (``full-seed0``):
    the Mini for the quick size, 640 x 480 (``default``) for the full one, as earlier versions
    simulated them, so that their data are never reused for another profile."""
    return "mini" if quick else "default"


def seeded_specs(preset: str, *, quick: bool, seed: int = 0) -> list:
    """The trial specs of ``preset``, their simulation seeds mixed with the base ``seed``.

    Seed 0 keeps each trial's own seed (the datasets of earlier runs); another
    base seed gives every trial a different, still deterministic, seed (the same
    trials and labels, other noise and variability).
    """

    specs = get_preset(preset, quick=quick)
    if seed == 0:
        return specs
    return [
        dataclasses.replace(
            spec, seed=int(np.random.SeedSequence([seed, spec.seed]).generate_state(1)[0] >> 1)
        )
        for spec in specs
    ]


def prepare_dataset(
    preset: str,
    root: Path,
    *,
    quick: bool,
    jobs: int,
    dask_address: str | None,
    progress: bool,
    seed: int = 0,
    realism: str = "clean",
    sensor: str | None = None,
) -> dict[str, pd.DataFrame]:
    """Simulate ``preset`` into ``root`` unless it is there; return its feature tables.

    ``realism`` is the simulated world (``clean`` or ``lab``: :mod:`liquidtouch.sim.realism`);
    ``sensor`` the GelSight profile (default: :data:`DEFAULT_SENSOR`).
    """

    if not (root / MANIFEST_NAME).is_file():
        specs = seeded_specs(preset, quick=quick, seed=seed)
        sources = ("gelsight", *WRENCH_TABLES) if preset == "classification" else ("gelsight",)
        simulate_dataset(
            specs,
            root,
            jobs=jobs,
            progress=progress,
            sensor=sensor or DEFAULT_SENSOR,
            realism=realism,
            # each worker extracts a trial as soon as it has written it: no separate
            # extraction pass (extract_features below reads the cache; without Dask)
            after_trial=None if dask_address else partial(cache_trial_features, sources=sources),
        )
    tables = {
        "gelsight": extract_features(root, jobs=jobs, dask_address=dask_address, progress=progress)
    }
    if preset == "classification":
        for source, name in WRENCH_TABLES.items():
            tables[source] = extract_features(
                root,
                out=root / name,
                jobs=jobs,
                dask_address=dask_address,
                source=source,
                progress=progress,
            )
    return tables


def failure_note(features: dict[str, dict[str, pd.DataFrame]]) -> str:
    """One sentence: trials per dataset and how many gave no GelSight features (one reason)."""
    parts = []
    for preset, tables in features.items():
        table = tables["gelsight"]
        errors = table["error"].fillna("").astype(str) if "error" in table else pd.Series([], str)
        failed = errors[errors != ""]
        text = f"{preset} {len(table)} trials"
        if len(failed):
            text += f" ({len(failed)} without features, e.g. “{failed.iloc[0][:100]}”)"
        parts.append(text)
    return "Trials: " + "; ".join(parts) + "."


def reproduce(
    out_dir: str | Path,
    *,
    quick: bool = False,
    jobs: int = 1,
    dask_address: str | None = None,
    progress: bool = True,
    data_dir: str | Path | None = None,
    seed: int = 0,
    realism: str = "clean",
    sensor: str | None = None,
    on_stage: Callable[[str], None] | None = None,
) -> Reproduction:
    """Simulate, extract, run the experiments and write ``report.md`` / ``report.html``.

    ``on_stage(text)`` is called as each stage begins (one line of text: e.g. for a log
    when no progress bar is shown).

    The simulated datasets go to ``data_dir`` (default :func:`default_data_dir`:
    ``<out_dir>-data``), under ``quick-seed<seed>`` or ``full-seed<seed>``, and are
    reused by the next run with the same data directory, size and seed. ``seed``
    is the base seed of the simulated trials and of the experiments' random draws.
    ``realism`` ``"lab"`` simulates a real bench's nuisances on top of the clean
    world (:mod:`liquidtouch.sim.realism`); its data go to ``...-seed<seed>-lab``
    and the report says which world it ran in. ``sensor`` is the GelSight profile of the
    simulated videos (default: :data:`DEFAULT_SENSOR`, the Mini); another than
    :func:`unsuffixed_sensor` the size (the Mini for ``quick``, 640 x 480 for the full size) puts
    the data under ``...-seed<seed>-<sensor>``.
    """

    world = get_realism(realism)
    profile = get_sensor_profile(sensor or DEFAULT_SENSOR)  # an unknown name fails here
    out = Path(out_dir)
    data = Path(data_dir) if data_dir is not None else default_data_dir(out)
    suffix = "" if world.is_clean else f"-{world.world}"
    if profile.name != unsuffixed_sensor(quick):
        suffix += f"-{profile.name}"
    data_root = data / f"{'quick' if quick else 'full'}-seed{seed}{suffix}"
    seconds: dict[str, float] = {}
    features: dict[str, dict[str, pd.DataFrame]] = {}
    reused: list[str] = []
    stage = on_stage or (lambda _text: None)
    for number, preset in enumerate(DATASETS, 1):
        if (data_root / preset / MANIFEST_NAME).is_file():
            reused.append(preset)
        stage(
            f"dataset {number}/{len(DATASETS)}: {preset} "
            f"({'reusing the simulated trials' if preset in reused else 'simulating'}, "
            "then extracting features)"
        )
        start = time.perf_counter()
        features[preset] = prepare_dataset(
            preset,
            data_root / preset,
            quick=quick,
            jobs=jobs,
            dask_address=dask_address,
            progress=progress,
            seed=seed,
            realism=world.world,
            sensor=profile.name,
        )
        seconds[f"data: {preset}"] = time.perf_counter() - start

    stage("the experiments")
    start = time.perf_counter()
    roots = {preset: data_root / preset for preset in DATASETS}
    results = run_experiments(
        features, out, seed=seed, dataset_roots=roots,
        streamed_trials=STREAMED_TRIALS_QUICK if quick else STREAMED_TRIALS, jobs=jobs,
    )  # fmt: skip
    seconds["experiments"] = time.perf_counter() - start

    timing = ", ".join(f"{k} {v:.0f} s" for k, v in seconds.items())
    if reused:  # their simulation (and cached features) came from an earlier run
        timing += f" (simulated in an earlier run, not timed here: {', '.join(reused)})"
    sensor_text = (
        f"{'GelSight Mini, ' if profile.name == 'mini' else ''}profile `{profile.name}`: "
        f"{profile.width_px}×{profile.height_px} px, {profile.fps:g} fps"
    )
    world_text = (
        "the clean simulated world (no bench nuisances)"
        if world.is_clean
        else f"the simulated **{world.world}** world: a real bench's nuisances on top of the "
        f"clean simulator ({', '.join(n.replace('_', ' ') for n in NUISANCES)}; their "
        "strengths and sources: `liquidtouch.sim.realism`, docs/formats.md; what each costs: "
        'benchmarks/RESULTS.md, "Nuisances")'
    )
    preamble = (
        f"{'Quick' if quick else 'Full'} reproduction of Huang, Guo, Yuan (RSS 2022) on "
        f"simulated trials in {world_text}, each through the whole pipeline "
        f"(rendered GelSight videos ("
        f"{sensor_text}) → marker tracking → tactile signal → oscillation fit → "
        f"models). {failure_note(features)} "
        f"Time: {timing}; total {sum(seconds.values()):.0f} s with {jobs} worker(s)."
    )

    info = provenance(
        **{
            "base seed": (
                f"{seed} (trial seeds derive from it, the preset and the trial's index; "
                f"experiments 6 and 7 draw their random training subsets with it)"
            ),
            "sensor profile": sensor_text,
            "world": world.world,
            "datasets": f"{'quick' if quick else 'full'} ({', '.join(DATASETS)})",
            "data directory": str(data_root.resolve()),
            "workers": f"{jobs}" + (f" (dask {dask_address})" if dask_address else ""),
        }
    )
    stage(f"writing the report to {out}")
    md, html = write_report(
        results,
        out,
        title="liquidtouch: reproduction of the paper",
        preamble=preamble,
        provenance=info,
    )
    return Reproduction(
        md, html, summary_table(results), seconds, data_root, seed, realism=world.world
    )
