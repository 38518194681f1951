"""The train / classify / predict / transfer commands, and their one-line errors."""

from __future__ import annotations

import io
import json
import re

import numpy as np
import pandas as pd
import pytest

from liquidtouch.cli import main
from liquidtouch.io.tables import FEATURE_COLUMNS
from liquidtouch.models.modelfile_schema import FORMAT_VERSION
from liquidtouch.testing.synthetic_tables import (
    CONTAINER_B,
    PAPER_CONCENTRATIONS,
    PAPER_HEIGHTS_MM,
    liquid_table,
    sugar_table,
)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("models")
    sugar_table(PAPER_HEIGHTS_MM[::2], PAPER_CONCENTRATIONS[::2], seed=30).to_csv(
        d / "train.csv", index=False
    )
    sugar_table(PAPER_HEIGHTS_MM[1::2], PAPER_CONCENTRATIONS[1::2], seed=31).to_csv(
        d / "test.csv", index=False
    )
    sugar_table(
        PAPER_HEIGHTS_MM[::4], PAPER_CONCENTRATIONS[::4], seed=32, container=CONTAINER_B
    ).to_csv(d / "tune.csv", index=False)
    liquid_table(["water", "mirin", "detergent"], np.linspace(16, 40, 5), 3, seed=33).to_csv(
        d / "liquids.csv", index=False
    )
    return d


def _one_error_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: "), err
    return err[0]


def test_train_predict_round_trip(files, capsys) -> None:
    model = files / "m.json"
    rc = main(
        [
            "train",
            str(files / "train.csv"),
            "-t",
            "height_mm",
            "-t",
            "log10_viscosity_cst",
            "--out",
            str(model),
        ]
    )
    out = capsys.readouterr().out
    assert rc == 0 and "training MAE" in out and "RBF" in out and f"wrote {model}" in out
    rc = main(["predict", str(model), str(files / "test.csv"), "--out", str(files / "p.csv")])
    assert rc == 0
    pred = pd.read_csv(files / "p.csv")
    test = pd.read_csv(files / "test.csv")
    assert list(pred.columns[: len(test.columns)]) == list(test.columns)
    for t in ("height_mm", "log10_viscosity_cst"):
        assert {f"predicted_{t}", f"predicted_{t}_std"} <= set(pred.columns)
    assert np.mean(np.abs(pred["predicted_height_mm"] - pred["height_mm"])) < 0.5
    assert (
        np.mean(np.abs(pred["predicted_log10_viscosity_cst"] - pred["log10_viscosity_cst"])) < 0.06
    )
    assert (pred["predicted_height_mm_std"] > 0).all()


def test_train_json_quadratic_and_physics(files, capsys) -> None:
    for kind in ("quadratic", "physics-gpr"):
        rc = main(
            [
                "train",
                str(files / "train.csv"),
                "-t",
                "height_mm",
                "--model",
                kind,
                "--out",
                str(files / f"{kind}.json"),
                "--json",
            ]
        )
        doc = json.loads(capsys.readouterr().out)
        assert rc == 0 and doc["model"] == kind and doc["targets"] == ["height_mm"]
        assert doc["training_mae"]["height_mm"] < 0.5


def test_classify_and_predict_probabilities(files, capsys) -> None:
    model = files / "c.json"
    rc = main(
        ["classify", str(files / "liquids.csv"), "--label", "liquid", "--out", str(model), "--json"]
    )
    doc = json.loads(capsys.readouterr().out)
    assert rc == 0 and doc["classes"] == ["detergent", "mirin", "water"]
    assert doc["training_accuracy"] == 1.0
    assert main(["predict", str(model), str(files / "liquids.csv")]) == 0
    pred = pd.read_csv(__import__("io").StringIO(capsys.readouterr().out))
    assert (pred["predicted_liquid"] == pred["liquid"]).all()
    proba = pred[["probability_detergent", "probability_mirin", "probability_water"]]
    assert np.allclose(proba.sum(axis=1), 1.0)


def test_predict_prints_a_readable_table_on_a_terminal(files, capsys, monkeypatch) -> None:
    """Campaign: `predict` on a terminal printed a 36-column CSV; now a table (the CSV when
    piped, with -o or in --json)."""
    import liquidtouch.cli.predict as predict_cli

    model = files / "h.json"
    assert main(["train", str(files / "train.csv"), "-t", "height_mm", "-o", str(model)]) == 0
    capsys.readouterr()
    monkeypatch.setattr(predict_cli, "stdout_is_terminal", lambda: True)
    assert main(["predict", str(model), str(files / "test.csv")]) == 0
    out = capsys.readouterr().out
    assert "predictions" in out and "height_mm" in out and "±" in out
    assert "predicted_height_mm_std" not in out and "," not in out.splitlines()[0]


def test_transfer_command(files, capsys) -> None:
    base = files / "base.json"
    assert (
        main(
            [
                "train",
                str(files / "train.csv"),
                "-t",
                "height_mm",
                "-t",
                "log10_viscosity_cst",
                "--out",
                str(base),
            ]
        )
        == 0
    )
    capsys.readouterr()
    rc = main(
        ["transfer", str(base), str(files / "tune.csv"), "--out", str(files / "b.json"), "--json"]
    )
    doc = json.loads(capsys.readouterr().out)
    assert rc == 0 and doc["n_points"] == 15 and len(doc["alpha"]) == 2
    for t in ("height_mm", "log10_viscosity_cst"):
        assert doc["tune_mae_after"][t] < 0.2 * doc["tune_mae_before"][t]
    rc = main(["transfer", str(base), str(files / "tune.csv"), "--out", str(files / "b2.json")])
    assert rc == 0 and "β1" in capsys.readouterr().out


def _bad_tables(d):
    good = pd.read_csv(d / "train.csv")
    (d / "no_lambda.csv").write_text(good.drop(columns="decay_rate").to_csv(index=False))
    text = good.astype({"decay_rate": object})
    text.loc[2, "decay_rate"] = "fast"
    (d / "text.csv").write_text(text.to_csv(index=False))
    nan = good.copy()
    nan.loc[4, "height_mm"] = np.nan
    (d / "nan.csv").write_text(nan.to_csv(index=False))
    (d / "few.csv").write_text(good.head(3).to_csv(index=False))
    unlabelled = good[list(FEATURE_COLUMNS)]
    (d / "unlabelled.csv").write_text(unlabelled.to_csv(index=False))
    (d / "empty.csv").write_text("")
    (d / "foreign.json").write_text('{"weights": [1, 2]}')
    newer = json.loads((d / "m.json").read_text()) if (d / "m.json").exists() else {}
    newer.update({"format": "liquidtouch-model", "format_version": FORMAT_VERSION + 1})
    (d / "newer.json").write_text(json.dumps(newer))


@pytest.mark.parametrize(
    "args, message",
    [
        (["train", "{d}/no_lambda.csv", "-t", "height_mm", "--out", "{d}/x.json"], "decay_rate"),
        (["train", "{d}/text.csv", "-t", "height_mm", "--out", "{d}/x.json"], "numeric.*'fast'"),
        (["train", "{d}/nan.csv", "-t", "height_mm", "--out", "{d}/x.json"], "height_mm.*row"),
        (["train", "{d}/few.csv", "-t", "height_mm", "--out", "{d}/x.json"], "at least 5"),
        (["train", "{d}/empty.csv", "-t", "height_mm", "--out", "{d}/x.json"], "empty"),
        (["train", "{d}/absent.csv", "-t", "height_mm", "--out", "{d}/x.json"], "no such file"),
        (["train", "{d}/train.csv", "-t", "colour", "--out", "{d}/x.json"], "colour"),
        (
            [
                "train",
                "{d}/train.csv",
                "-t",
                "height_mm",
                "--calibration-group",
                "colour",
                "--out",
                "{d}/x.json",
            ],
            "^error: --calibration-group 'colour': no such column in the training table$",
        ),
        (
            ["train", "{d}/nan.csv", "-t", "log10_viscosity_cst", "--out", "{d}/x.json"],
            "^error: --calibration-group height_mm: the column has empty values$",
        ),
        (
            ["train", "{d}/train.csv", "-t", "height_mm", "-m", "forest", "--out", "{d}/x.json"],
            "'forest' is not one of 'gpr', 'quadratic', 'physics-gpr'",
        ),
        (["classify", "{d}/train.csv", "--out", "{d}/x.json"], "missing column.*liquid"),
        (["predict", "{d}/foreign.json", "{d}/test.csv"], "not a liquidtouch model"),
        (["predict", "{d}/newer.json", "{d}/test.csv"], f"version {FORMAT_VERSION + 1}"),
        (["predict", "{d}/absent.json", "{d}/test.csv"], "no such model file"),
        (["predict", "{d}/c.json", "{d}/no_lambda.csv"], "decay_rate"),
        (["predict", "{d}/c.json", "{d}"], "directory"),
        (["transfer", "{d}/c.json", "{d}/tune.csv", "--out", "{d}/x.json"], "regression model"),
        (
            ["transfer", "{d}/base.json", "{d}/unlabelled.csv", "--out", "{d}/x.json"],
            "no column of the model's targets",
        ),
        (["transfer", "{d}/base.json", "{d}/few.csv", "--out", "{d}/x.json"], "at least 4"),
    ],
)
def test_bad_input_is_one_error_line(files, capsys, args, message) -> None:
    if not (files / "c.json").exists():
        main(["classify", str(files / "liquids.csv"), "--out", str(files / "c.json")])
    if not (files / "base.json").exists():
        main(
            [
                "train",
                str(files / "train.csv"),
                "-t",
                "height_mm",
                "--out",
                str(files / "base.json"),
            ]
        )
    _bad_tables(files)
    (files / "x.json").unlink(missing_ok=True)
    capsys.readouterr()
    assert main([a.format(d=files) for a in args]) == 2
    assert re.search(message, _one_error_line(capsys))
    assert not (files / "x.json").exists()


def test_help_of_every_command(capsys) -> None:
    for command in ("train", "classify", "predict", "transfer"):
        assert main([command, "--help"]) == 0
        assert "--out" in capsys.readouterr().out


# -- --split / --where: train on the selected rows, evaluate on the others --------------------


@pytest.fixture(scope="module")
def split_files(files):
    train, test = pd.read_csv(files / "train.csv"), pd.read_csv(files / "test.csv")
    both = pd.concat([train.assign(split="train"), test.assign(split="test")], ignore_index=True)
    both["error"] = ""
    both.loc[0, ["decay_rate", "error"]] = [np.nan, "no push found"]  # a failed trial: skipped
    both.iloc[1:].to_csv(files / "split_clean.csv", index=False)
    both.to_csv(files / "split.csv", index=False)
    liquids = pd.read_csv(files / "liquids.csv")
    liquids["split"] = np.where(np.arange(len(liquids)) % 3 == 0, "test", "train")
    liquids.to_csv(files / "liquids_split.csv", index=False)
    return files


def test_train_split_trains_on_the_selection_and_evaluates_the_rest(split_files, capsys) -> None:
    d = split_files
    n_test = len(pd.read_csv(d / "test.csv"))
    args = ["train", d / "split.csv", "-t", "height_mm", "-m", "quadratic", "-o", d / "s.json"]
    assert main([str(a) for a in [*args, "--split", "train", "--json"]]) == 0
    doc = json.loads(capsys.readouterr().out)
    n_train = len(pd.read_csv(d / "train.csv")) - 1  # the failed row is skipped
    assert doc["n_rows"] == n_train and doc["n_skipped"] == 1
    assert doc["selection"] == {
        "split": "train",
        "where": [],
        "n_selected": n_train,
        "n_not_selected": n_test,
    }
    held = doc["held_out"]["height_mm"]
    assert held["n_rows"] == n_test and 0 < held["mae"] < 1.0
    # the same as training on train.csv and measuring on test.csv by hand
    pred = pd.read_csv(io.StringIO(_predict_csv(capsys, d / "s.json", d / "test.csv")))
    by_hand = np.mean(np.abs(pred["predicted_height_mm"] - pred["height_mm"]))
    assert held["mae"] == pytest.approx(by_hand, rel=1e-9)

    # human output: the summary on stdout, the evaluation table on stderr
    assert main([str(a) for a in [*args, "--split", "train"]]) == 0
    captured = capsys.readouterr()
    assert "training MAE" in captured.out and "held-out MAE" in captured.err
    assert f"{n_test} rows not selected" in captured.err

    # --where on a numeric column, combined with --split
    where = ["--where", "split=train", "--where", "sugar_concentration=0"]
    assert main([str(a) for a in [*args, *where, "--json"]]) == 0
    doc = json.loads(capsys.readouterr().out)
    table = pd.read_csv(d / "split.csv").iloc[1:]
    expected = int(((table["split"] == "train") & (table["sugar_concentration"] == 0)).sum())
    assert doc["selection"]["n_selected"] == expected == doc["n_rows"]


def _predict_csv(capsys, model, table) -> str:
    assert main(["predict", str(model), str(table)]) == 0
    return capsys.readouterr().out


def test_classify_and_transfer_split(split_files, capsys) -> None:
    d = split_files
    classify = ["classify", str(d / "liquids_split.csv"), "-o", str(d / "cs.json")]
    rc = main([*classify, "--split", "train", "--json"])
    doc = json.loads(capsys.readouterr().out)
    n = len(pd.read_csv(d / "liquids_split.csv"))
    assert rc == 0 and doc["n_rows"] == n - n // 3 - (n % 3 > 0)
    assert doc["held_out"]["n_rows"] == n - doc["n_rows"] and doc["held_out"]["accuracy"] > 0.8

    base = d / "base_split.json"
    assert main(["train", str(d / "train.csv"), "-t", "height_mm", "-o", str(base)]) == 0
    tune = pd.read_csv(d / "tune.csv")
    tune["split"] = np.where(np.arange(len(tune)) < 8, "tune", "test")
    tune.to_csv(d / "tune_split.csv", index=False)
    capsys.readouterr()
    transfer = ["transfer", str(base), str(d / "tune_split.csv"), "-o", str(d / "ts.json")]
    rc = main([*transfer, "--split", "tune", "--json"])
    doc = json.loads(capsys.readouterr().out)
    assert rc == 0 and doc["n_points"] == 8
    held = doc["held_out"]["height_mm"]
    assert held["n_rows"] == len(tune) - 8 and held["mae_after"] < held["mae_before"]


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (
            ["--split", "validation"],
            r"no row .* has split = validation \(split values: test, train",
        ),
        (["--where", "colour=red"], "has no column 'colour'"),
        (["--where", "height_mm=tall"], "height_mm .* is numeric, but 'tall' is not a number"),
        (["--where", "height_mm=17"], r"no row .* has height_mm = 17 \(height_mm values: 16"),
        (["--where", "height_mm"], "--where takes COLUMN=VALUE"),
        (["--split", "test", "--where", "container=B"], "no row .* has container = B"),
        (["--split", "test", "--where", "height_mm=16"], "no row .* matches --split test --where"),
    ],
)
def test_selection_errors(split_files, capsys, extra, message) -> None:
    d = split_files
    out = d / "never.json"
    args = ["train", str(d / "split_clean.csv"), "-t", "height_mm", "-o", str(out), *extra]
    assert main(args) == 2
    assert re.search(message, _one_error_line(capsys))
    assert not out.exists()
