"""Synthetic feature tables for all seven experiments (tests of the experiments and the report).

Built from the sloshing formulas of :mod:`liquidtouch.testing.synthetic_tables` (no video): the
``features`` mapping that :func:`liquidtouch.experiments.suite.run_experiments`
takes, with one classification test trial that gave no features and a wrist
F/T table where no trial did. A report from these tables takes seconds.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from liquidtouch.testing.synthetic_tables import (
    CONTAINER_A,
    CONTAINER_B,
    PAPER_HEIGHTS_MM,
    liquid_table,
    paper_split,
    sugar_table,
)

FAILED = "the free decay after the push lasts only 1.2 s"
NO_OSCILLATION = "no oscillation above the noise"


def with_split(train: pd.DataFrame, test: pd.DataFrame) -> pd.DataFrame:
    """``train`` and ``test`` in one table with a ``split`` column and no errors."""
    table = pd.concat([train.assign(split="train"), test.assign(split="test")], ignore_index=True)
    return table.assign(error="")


def classification_table() -> pd.DataFrame:
    """Water / olive oil / detergent, 8 train + 10 test each; the last test trial failed."""
    liquids = ["water", "olive-oil", "detergent"]
    train = liquid_table(liquids, np.linspace(20, 40, 8), repeats=1, seed=1)
    test = liquid_table(liquids, np.random.default_rng(2).uniform(20, 40, 10), repeats=1, seed=3)
    table = with_split(train, test)
    # one test trial gave no features: it must count as wrong, not vanish
    table.loc[len(table) - 1, ["decay_rate", "angular_frequency", "error"]] = [
        np.nan,
        np.nan,
        FAILED,
    ]
    return table


def containers_table() -> pd.DataFrame:
    """Sugar water in the cylinder, cuboid and glass containers (54 train trials each)."""
    heights = np.linspace(15, 38, 6)
    parts = []
    for name, geometry in (("cylinder", CONTAINER_B), ("cuboid", CONTAINER_B), ("glass", None)):
        geometry = geometry or {**CONTAINER_A, "wall": 1.3}
        train = sugar_table(heights, np.linspace(0, 160, 9), seed=5, container=geometry, name=name)
        test = sugar_table(heights, np.linspace(10, 150, 8), seed=6, container=geometry, name=name)
        parts.append(with_split(train, test))
    return pd.concat(parts, ignore_index=True)


def experiment_features() -> dict[str, dict[str, pd.DataFrame]]:
    """``features[preset]["gelsight" | "wrench" | "wrench-best-effort"]`` for the experiments."""
    classes = classification_table()
    wrench = classes.assign(decay_rate=np.nan, angular_frequency=np.nan, error=NO_OSCILLATION)
    # the best-effort wrist fit: numbers that describe the noise, not the liquid
    noise = np.random.default_rng(11)
    best_effort = classes.assign(
        decay_rate=noise.uniform(0.1, 4.0, len(classes)),
        angular_frequency=noise.uniform(6.0, 20.0, len(classes)),
        error="",
    )
    sugar = with_split(*paper_split(seed=4)).assign(
        liquid="sugar-water", container="grooved-cuboid"
    )
    others = liquid_table(["olive-oil", "corn-oil", "mirin"], PAPER_HEIGHTS_MM, 2, seed=7)
    viscosity = {"olive-oil": 64.0, "corn-oil": 52.0, "mirin": 22.0}
    others["log10_viscosity_cst"] = np.log10(others["liquid"].map(viscosity))
    return {
        "classification": {
            "gelsight": classes,
            "wrench": wrench,
            "wrench-best-effort": best_effort,
        },
        "sugar": {"gelsight": sugar},
        "other-liquids": {"gelsight": others.assign(split="test", error="")},
        "containers": {"gelsight": containers_table()},
    }
