"""A model keeps the settings its training features were extracted with, and features
extracted otherwise are named (``models.extraction_match``; model format version 8)."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from liquidtouch.batch.features import settings_text
from liquidtouch.cli import main
from liquidtouch.cli.live import live_model
from liquidtouch.errors import ModelFileError, TableError
from liquidtouch.extraction.fit_settings import FitSettings
from liquidtouch.live.properties import settings_warning
from liquidtouch.models.extraction_match import settings_differences, table_settings
from liquidtouch.models.modelfile import load_model, model_from_dict, model_to_dict, save_model
from liquidtouch.models.modelfile_checks import document_sha256
from liquidtouch.models.predictions import predict_rows
from liquidtouch.models.table_training import (
    classify_on_table,
    train_on_table,
    transfer_on_table,
)
from liquidtouch.testing.synthetic_tables import (
    CONTAINER_B,
    PAPER_CONCENTRATIONS,
    PAPER_HEIGHTS_MM,
    liquid_table,
    sugar_table,
)

FIT = FitSettings().to_dict()  # extract's, as the live estimate fits


def _settings(**changed) -> dict:
    return {"source": "gelsight", "lowpass_hz": 4.0, "n_markers": 16, "sensors": None,
            "fit": FIT, **changed}  # fmt: skip


def _table(seed: int, **changed) -> pd.DataFrame:
    table = sugar_table(PAPER_HEIGHTS_MM[::2], PAPER_CONCENTRATIONS[::3], seed=seed)
    return table.assign(extraction_settings=settings_text(_settings(**changed)))


def test_differences_are_named_setting_by_setting():
    assert settings_differences(_settings(), _settings()) == []
    assert settings_differences(_settings(), _settings(lowpass_hz=4)) == []  # 4 is 4.0
    assert settings_differences(_settings(), _settings(n_markers=1000, lowpass_hz=None)) == [
        "lowpass_hz: 4.0 -> null",
        "n_markers: 16 -> 1000",
    ]
    other_fit = _settings(fit={**FIT, "model": "single", "band_hz": [0.5, 6.0]})
    assert settings_differences(_settings(), other_fit) == [
        f"fit.band_hz: {json.dumps(FIT['band_hz'], separators=(',', ':'))} -> [0.5,6.0]",
        f'fit.model: "{FIT["model"]}" -> "single"',
    ]
    # a setting only one side holds (a newer version's, at its default) is not compared
    assert settings_differences(_settings(), {**_settings(), "tracking": "dense"}) == []


def test_a_training_table_has_one_set_of_settings_or_none():
    assert table_settings(_table(1)) == _settings()
    assert table_settings(_table(1).drop(columns="extraction_settings")) is None
    assert table_settings(_table(1).assign(extraction_settings=np.nan)) is None
    mixed = pd.concat([_table(1), _table(2, n_markers=1000)], ignore_index=True)
    with pytest.raises(TableError, match=r"different settings \(n_markers: 16 -> 1000\)"):
        table_settings(mixed)
    with pytest.raises(TableError, match="row 1: `extraction_settings` is not a JSON object"):
        table_settings(_table(1).assign(extraction_settings="[1, 2]"))


def test_the_model_file_keeps_them_and_predictions_name_other_rows(tmp_path):
    trained = train_on_table(_table(3), ["height_mm"], model="quadratic", calibration_folds=0)
    assert trained.model.extraction_settings == _settings()
    path = save_model(trained.model, tmp_path / "m.json")
    doc = json.loads(path.read_text())
    assert doc["format_version"] == 8 and doc["extraction_settings"] == _settings()
    model = load_model(path)
    assert model.extraction_settings == _settings()

    same = predict_rows(model, _table(4))
    assert not same.other_settings.any() and same.settings_differences == []
    test = pd.concat([_table(4), _table(5, n_markers=1000)], ignore_index=True)
    other = predict_rows(model, test)
    n = len(_table(4))
    assert other.other_settings.tolist() == [False] * n + [True] * (len(test) - n)
    assert other.settings_differences == ["n_markers: 16 -> 1000"]
    # rows without settings (a hand-made table) and a model without them: nothing said
    assert not predict_rows(model, test.drop(columns="extraction_settings")).other_settings.any()
    model.extraction_settings = None
    assert not predict_rows(model, test).other_settings.any()


def test_a_transferred_model_keeps_its_own():
    """The transfer maps container B's (λ, ω) onto the model's own features: the model's
    std is still the one calibrated on them."""
    base = train_on_table(_table(3), ["height_mm"], model="quadratic", calibration_folds=0)
    tune = sugar_table(PAPER_HEIGHTS_MM, PAPER_CONCENTRATIONS[::2], seed=7, container=CONTAINER_B)
    tuned = transfer_on_table(base.model, tune)
    assert tuned.model.extraction_settings == _settings()


def test_a_classifier_keeps_them_and_older_files_may_not_hold_them():
    table = liquid_table(["water", "mirin"], np.linspace(16, 40, 4), 3, seed=6)
    fitted = classify_on_table(table.assign(extraction_settings=settings_text(_settings()))).model
    doc = model_to_dict(fitted)
    assert model_from_dict(doc).extraction_settings == _settings()
    with pytest.raises(ModelFileError, match="extraction_settings need format version 8"):
        model_from_dict(_signed({**doc, "format_version": 7}))
    older = model_from_dict(_signed({**doc, "format_version": 7, "extraction_settings": None}))
    assert older.extraction_settings is None
    doc.pop("extraction_settings")
    assert model_from_dict(_signed(doc)).extraction_settings is None


def _signed(doc: dict) -> dict:
    """``doc`` with its checksum made again: the edit is what is refused or read."""
    return {**doc, "sha256": document_sha256(doc)}


def test_the_live_signal_is_compared_with_the_models_features():
    trained = train_on_table(_table(3), ["height_mm"], model="quadratic", calibration_folds=0)
    assert settings_warning(trained.model, lowpass_hz=4, n_markers=16) is None
    said = settings_warning(trained.model, lowpass_hz=4.0, n_markers=1000)
    assert said == (
        "the live signal is made otherwise than the model's training features "
        "(n_markers: 16 -> 1000): its std may not hold"
    )
    # the live fit is extract's unless told: other fit options are named too
    single = FitSettings(model="single-mode")
    said = settings_warning(trained.model, lowpass_hz=4.0, n_markers=16, fit_settings=single)
    assert f'(fit.model: "{FIT["model"]}" -> "single-mode")' in said
    trained.model.extraction_settings = None
    assert settings_warning(trained.model, lowpass_hz=4.0, n_markers=1000) is None


def test_predict_warns_once_and_counts_them_in_json(tmp_path, capsys):
    _table(3).to_csv(tmp_path / "train.csv", index=False)
    test = pd.concat([_table(4), _table(5, n_markers=1000)], ignore_index=True)
    test.to_csv(tmp_path / "test.csv", index=False)
    model = tmp_path / "m.json"
    assert main(["train", str(tmp_path / "train.csv"), "-t", "height_mm", "--model",
                 "quadratic", "--out", str(model), "--json"]) == 0  # fmt: skip
    assert json.loads(capsys.readouterr().out)["extraction_settings"] == _settings()
    assert main(["predict", str(model), str(tmp_path / "test.csv"), "--json"]) == 0
    captured = capsys.readouterr()
    doc = json.loads(captured.out)
    n_other = len(test) - len(_table(4))
    assert doc["n_other_settings"] == n_other
    assert doc["settings_differences"] == ["n_markers: 16 -> 1000"]
    said = [line for line in captured.err.splitlines() if "extracted otherwise" in line]
    assert len(said) == 1 and said[0].startswith(f"warning: {n_other} row(s) extracted")
    assert "(n_markers: 16 -> 1000): their std may not hold" in said[0]


def test_live_and_run_trial_say_it_before_any_frame(tmp_path, capsys):
    """``live_model`` is what ``live`` and ``run-trial`` load their --model with."""
    trained = train_on_table(_table(3), ["height_mm"], model="quadratic", calibration_folds=0)
    path = save_model(trained.model, tmp_path / "m.json")
    live_model(path, {}, 4.0, 16)
    assert capsys.readouterr().err == ""
    live_model(path, {}, 4.0, 1000)
    assert capsys.readouterr().err.strip() == (
        "warning: the live signal is made otherwise than the model's training features "
        "(n_markers: 16 -> 1000): its std may not hold"
    )
