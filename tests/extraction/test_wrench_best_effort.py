"""The wrist F/T baseline: refused honestly, or fitted anyway as the paper did."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from liquidtouch.batch.features import extract_features
from liquidtouch.errors import NoOscillationError
from liquidtouch.extraction.wrench import wrench_features
from liquidtouch.io.dataset import write_manifest


@pytest.fixture(scope="module")
def wrist_trials(tmp_path_factory) -> Path:
    """Three simulated trials with wrist F/T data only (no video: fast)."""
    from liquidtouch.sim.trial import simulate_trial
    from liquidtouch.sim.trial_io import write_trial

    root = tmp_path_factory.mktemp("wrist")
    names = []
    for liquid, seed in (("water", 1), ("olive-oil", 2), ("detergent", 3)):
        name = f"{liquid}_{seed}"
        write_trial(simulate_trial(liquid, height_mm=30.0, seed=seed), root / name, video=False)
        names.append(name)
    write_manifest(root, [{"trial": name} for name in names])
    return root


def test_the_honest_fit_refuses_and_the_best_effort_fit_answers(wrist_trials: Path) -> None:
    trial = wrist_trials / "water_1"
    with pytest.raises(NoOscillationError):
        wrench_features(trial)
    row = wrench_features(trial, best_effort=True)
    assert math.isfinite(row["decay_rate"]) and row["decay_rate"] >= 0
    assert 2 * math.pi * 0.3 <= row["angular_frequency"] <= 2 * math.pi * 5.0
    assert row["n_markers"] == 0 and row["frames"] > 300


def test_the_best_effort_source_fills_every_row(wrist_trials: Path) -> None:
    honest = extract_features(wrist_trials, source="wrench", write=False, progress=False)
    forced = extract_features(
        wrist_trials, source="wrench-best-effort", write=False, progress=False
    )
    assert (honest["error"] != "").all() and honest["decay_rate"].isna().all()
    assert (forced["error"] == "").all() and forced["decay_rate"].notna().all()
    # the two sources are cached apart: the honest table is not overwritten
    again = extract_features(wrist_trials, source="wrench", write=False, progress=False)
    assert again.attrs["n_cached"] == 3 and again["decay_rate"].isna().all()
