"""Model files: exact round trip of every model kind; refusal of foreign, newer or corrupt files."""

from __future__ import annotations

import json

import numpy as np
import pytest

from liquidtouch.errors import ModelFileError
from liquidtouch.io.tables import FEATURE_COLUMNS
from liquidtouch.models.feature_space import FeatureMap
from liquidtouch.models.modelfile import load_model, model_to_dict, save_model
from liquidtouch.models.modelfile_checks import document_sha256
from liquidtouch.models.property_model import PropertyModel
from liquidtouch.models.training import train_classifier, train_regression
from liquidtouch.testing.synthetic_tables import (
    PAPER_CONCENTRATIONS,
    PAPER_HEIGHTS_MM,
    liquid_table,
    sugar_table,
)

FEATURES = list(FEATURE_COLUMNS)


@pytest.fixture(scope="module")
def tables():
    train = sugar_table(PAPER_HEIGHTS_MM[::2], PAPER_CONCENTRATIONS[::2], seed=20)
    test = sugar_table(PAPER_HEIGHTS_MM[1::2], PAPER_CONCENTRATIONS, seed=21)
    return train, test


@pytest.mark.parametrize("kind", ["gpr", "quadratic", "physics-gpr"])
def test_regression_round_trip_is_exact(tmp_path, tables, kind: str) -> None:
    train, test = tables
    targets = {t: train[t].to_numpy() for t in ("height_mm", "sugar_concentration")}
    model = train_regression(train[FEATURES].to_numpy(), targets, kind)
    model.feature_map = FeatureMap((0.9, 0.01), (1.05, -0.3))
    path = save_model(model, tmp_path / "model.json")
    again = load_model(path)
    Xt = test[FEATURES].to_numpy()
    before, after = model.predict(Xt), again.predict(Xt)
    for target in targets:
        assert np.array_equal(before[target][0], after[target][0])
        assert np.array_equal(before[target][1], after[target][1])
    assert again.feature_map == model.feature_map and again.targets == model.targets
    doc = json.loads(path.read_text())
    assert doc["format"] == "liquidtouch-model" and doc["format_version"] == 8
    assert set(doc["provenance"]) == {
        "liquidtouch",
        "scikit_learn",
        "numpy",
        "python",
        "training_sha256",
    }
    assert len(doc["sha256"]) == 64 and doc["domain"]["margin"] == 0.1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["model.json"]  # atomic: no temp left


def test_classifier_round_trip_is_exact(tmp_path) -> None:
    table = liquid_table(["water", "mirin", "corn-oil", "detergent"], np.linspace(16, 40, 6), 3)
    model = train_classifier(table[FEATURES].to_numpy(), table["liquid"].to_numpy())
    again = load_model(save_model(model, tmp_path / "clf.json"))
    grid = np.column_stack([np.linspace(0.05, 3.0, 200), np.linspace(9.5, 14.5, 200)])
    (c1, p1), (c2, p2) = model.predict_proba(grid), again.predict_proba(grid)
    assert np.array_equal(c1, c2) and np.array_equal(p1, p2)
    assert again.classifier.C_ == model.classifier.C_


@pytest.fixture(scope="module")
def saved_doc(tables):
    train, _ = tables
    model = train_regression(train[FEATURES].to_numpy(), {"height_mm": train["height_mm"]}, "gpr")
    return model_to_dict(model)


def _write(tmp_path, doc) -> str:
    path = tmp_path / "m.json"
    path.write_text(doc if isinstance(doc, str) else json.dumps(doc))
    return str(path)


@pytest.mark.parametrize(
    "mutate, message",
    [
        (lambda d: "not json {", "not a liquidtouch model file"),
        (lambda d: {"hello": 1}, "not a liquidtouch model file"),
        (lambda d: [1, 2], "not a liquidtouch model file"),
        (lambda d: {**d, "format_version": 99}, "version 99.*upgrade"),
        (lambda d: {**d, "kind": "magic"}, "corrupt.*kind"),
        (lambda d: {**d, "features": ["a", "b"]}, "corrupt"),
        (lambda d: {**d, "targets": ["other"]}, "corrupt.*one regressor per target"),
        (lambda d: {**d, "extra_code": "import os"}, "corrupt.*extra_code"),
    ],
)
def test_foreign_newer_and_corrupt_files_are_refused(tmp_path, saved_doc, mutate, message) -> None:
    with pytest.raises(ModelFileError, match=message):
        load_model(_write(tmp_path, mutate(json.loads(json.dumps(saved_doc)))))


@pytest.mark.parametrize(
    "field, value, message",
    [
        ("y_train", [1.0, 2.0], "y_train has 2 values"),
        ("kernel", {"constant": -1, "length_scale": [1, 1], "noise_level": 0.1}, "greater than or"),
        ("model", "forest", "corrupt"),
        ("X_train", [[1.0, 2.0, 3.0]], "corrupt"),
        ("prior", {"kind": "height", "wavenumber": 26.0, "coef": [0, 1]}, "must not have one"),
    ],
)
def test_corrupt_estimator_state_is_refused(tmp_path, saved_doc, field, value, message) -> None:
    doc = json.loads(json.dumps(saved_doc))
    doc["regressors"]["height_mm"][field] = value
    with pytest.raises(ModelFileError, match=message):
        load_model(_write(tmp_path, doc))


def test_nan_and_edited_quadratic_are_refused(tmp_path, saved_doc, tables) -> None:
    text = json.dumps(saved_doc).replace('"y_mean": ', '"y_mean": NaN, "_": ', 1)
    with pytest.raises(ModelFileError, match="corrupt"):
        load_model(_write(tmp_path, text))
    train, _ = tables
    quad = model_to_dict(
        train_regression(train[FEATURES].to_numpy(), {"height_mm": train["height_mm"]}, "quadratic")
    )
    quad["regressors"]["height_mm"]["coef"][0] += 1.0
    with pytest.raises(ModelFileError, match="does not match its sha256 checksum"):
        load_model(_write(tmp_path, quad))
    quad["sha256"] = document_sha256(quad)  # an editor who also fixes the checksum
    with pytest.raises(ModelFileError, match="do not match its training data"):
        load_model(_write(tmp_path, quad))


def test_missing_file_and_model_invariants(tmp_path) -> None:
    with pytest.raises(ModelFileError, match="no such model file"):
        load_model(tmp_path / "absent.json")
    with pytest.raises(ValueError, match="either regressors or a classifier"):
        PropertyModel()
