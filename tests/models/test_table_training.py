"""Training and transfer on the chosen rows of a features table (``models.table_training``),
what ``train`` and ``transfer`` run, called as a notebook would."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from liquidtouch.errors import TableError
from liquidtouch.models.table_training import train_on_table, transfer_on_table
from liquidtouch.testing.synthetic_tables import (
    CONTAINER_B,
    PAPER_CONCENTRATIONS,
    PAPER_HEIGHTS_MM,
    paper_split,
    sugar_table,
)


@pytest.fixture(scope="module")
def table():
    train, test = paper_split(seed=5)
    return pd.concat([train.assign(split="train"), test.assign(split="test")], ignore_index=True)


def test_train_on_the_split_and_evaluate_the_rest(table) -> None:
    """The paper's split: the quadratic model on the 9 training heights predicts the 8
    others' fill height within 1 mm (the tables' noise: 4 % on λ, 0.3 % on ω)."""
    trained = train_on_table(
        table, ["height_mm"], model="quadratic", split="train", calibration_folds=0
    )
    assert trained.n_rows == 9 * 12 and trained.n_held_out == 8 * 12
    assert trained.selection["n_selected"] == 9 * 12
    assert trained.held_out["height_mm"]["n_rows"] == 8 * 12
    assert 0 < trained.held_out["height_mm"]["mae"] < 1.0
    truth = table[table["split"] == "test"]
    mean, _ = trained.model.predict(truth[["decay_rate", "angular_frequency"]].to_numpy())[
        "height_mm"
    ]
    mae = np.mean(np.abs(mean - truth["height_mm"].to_numpy()))
    assert trained.held_out["height_mm"]["mae"] == pytest.approx(mae)


def test_a_bad_calibration_group_names_the_parameter(table) -> None:
    with pytest.raises(TableError, match=r"^`calibration_group` 'colour': no such column"):
        train_on_table(table, ["height_mm"], model="quadratic", calibration_group="colour")


def test_transfer_to_another_container_lowers_the_held_out_error(table) -> None:
    base = train_on_table(table, ["height_mm"], model="quadratic", calibration_folds=0).model
    tune = sugar_table(
        PAPER_HEIGHTS_MM, PAPER_CONCENTRATIONS[::2], seed=7, container=CONTAINER_B
    ).assign(split=lambda t: np.where(t.index % 4 == 0, "tune", "test"))
    tuned = transfer_on_table(base, tune, split="tune")
    errors = tuned.held_out["height_mm"]
    assert tuned.transfer is not None and tuned.model is tuned.transfer.model
    assert errors["n_rows"] == tuned.n_held_out == int((tune["split"] == "test").sum())
    assert errors["mae_after"] < 0.5 * errors["mae_before"]
    with pytest.raises(TableError, match="no column of the model's targets"):
        transfer_on_table(base, tune.drop(columns="height_mm"))
