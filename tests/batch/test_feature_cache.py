"""A features-cache entry is read like any input (issue 41, item 5).

An entry with the right fingerprint whose ``features`` was a list or a string killed the
whole ``features`` run (``AttributeError``); one whose numbers were strings went into
the table. A damaged entry is now computed again, and the table holds the trial's
numbers.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from liquidtouch.batch.features import CACHE_DIR, extract_features
from liquidtouch.io.dataset import write_manifest
from liquidtouch.sim.trial import simulate_trial
from liquidtouch.sim.trial_io import write_trial


@pytest.fixture(scope="module")
def dataset(tmp_path_factory) -> Path:
    """One trial with wrist F/T data only (fast; fitted best effort: the wrist is noisy)."""
    root = tmp_path_factory.mktemp("cache") / "data"
    write_trial(simulate_trial("water", height_mm=30.0, seed=1), root / "good", video=False)
    write_manifest(root, [{"trial": "good"}])
    return root


@pytest.mark.parametrize(
    "damage",
    [
        {"features": [1, 2]},
        {"features": "0.5"},
        {"features": {"decay_rate": "0.5", "angular_frequency": 14.0}},
        {"features": {"decay_rate": [0.5], "angular_frequency": 14.0}},
        {"features": {"angular_frequency": 14.0}, "error": None},
        {"error": 42},
        {"liquidtouch_version": {"x": 1}},
    ],
)
def test_a_damaged_cache_entry_is_computed_again(dataset, damage):
    first = extract_features(dataset, source="wrench-best-effort", progress=False, write=False)
    assert not first.loc[0, "error"]  # the trial extracts: its numbers are the reference
    cache = dataset / CACHE_DIR / "wrench-best-effort" / "good.json"
    entry = json.loads(cache.read_text())
    cache.write_text(json.dumps({**entry, **damage}))  # the right fingerprint, bad content
    again = extract_features(dataset, source="wrench-best-effort", progress=False, write=False)
    assert again.attrs["n_computed"] == 1 and again.attrs["n_cached"] == 0
    assert again.loc[0, "decay_rate"] == first.loc[0, "decay_rate"]
    assert again.loc[0, "angular_frequency"] == first.loc[0, "angular_frequency"]
    cached = extract_features(dataset, source="wrench-best-effort", progress=False, write=False)
    assert cached.attrs["n_cached"] == 1  # the entry written again is read next time
