"""Notebook-friendly results: short reprs (values ± std, no arrays) and PropertyModel params."""

from __future__ import annotations

import numpy as np
import pytest

import liquidtouch as lt
from liquidtouch._core.numbers import with_uncertainty
from liquidtouch.cli import format as cli_format
from liquidtouch.errors import TableError
from liquidtouch.io.tables import FEATURE_COLUMNS
from liquidtouch.live.updates import LiveUpdate
from liquidtouch.models.feature_space import FeatureMap, TrainingDomain
from liquidtouch.testing.synthetic_tables import paper_split


def short(text: str) -> str:
    assert len(text) < 200 and "array(" not in text and "\n" not in text, text
    return text


@pytest.fixture(scope="module")
def fit() -> lt.OscillationFit:
    t, u = lt.example_signal()
    return lt.fit_oscillation(t, u, model="two-mode")


@pytest.fixture(scope="module")
def tracks() -> lt.MarkerTracks:
    t = np.arange(390) / 30.0
    reference = np.stack(np.meshgrid(np.arange(9.0), np.arange(7.0)), -1).reshape(-1, 2) * 20
    positions = np.repeat(reference[None], len(t), axis=0)
    valid = np.ones(positions.shape[:2], dtype=bool)
    valid[:, :5] = False  # 5 of 63 markers lost throughout: 92 % valid
    return lt.MarkerTracks(t, positions, valid, reference, sensor="left")


@pytest.fixture(scope="module")
def signal() -> lt.TactileSignal:
    t = np.arange(1235) / 30.0
    return lt.TactileSignal(
        t=t,
        u=np.sin(t),
        explained_variance=0.95,
        markers=[("left", i) for i in range(16)],
        weights=np.ones((16, 2)) / np.sqrt(32),
        fps=30.0,
        motion=np.zeros((len(t), 16, 2)),
    )


def test_fit_repr_is_values_with_their_std(fit: lt.OscillationFit) -> None:
    text = short(repr(fit))
    decay = with_uncertainty(fit.decay_rate, fit.decay_rate_std)
    omega = with_uncertainty(fit.angular_frequency, fit.angular_frequency_std)
    assert text == (
        f"OscillationFit(decay_rate={decay} 1/s, angular_frequency={omega} rad/s, "
        f"model='two-mode', r2={fit.r2:.4f})"
    )
    assert " ± " in decay and str(fit) == text
    assert fit.to_dict()["model"] == "two-mode"  # the dict is unchanged


def test_tracks_signal_and_extraction_reprs(
    tracks: lt.MarkerTracks, signal: lt.TactileSignal, fit: lt.OscillationFit
) -> None:
    assert short(repr(tracks)) == "MarkerTracks(sensor='left', 390 frames × 63 markers, 92 % valid)"
    assert short(repr(signal)) == (
        "TactileSignal(1235 samples, 30.0 fps, 41.1 s, 16 markers, explained_variance=0.950)"
    )
    extraction = lt.Extraction(tracks=[tracks], signal=signal, fit=fit)
    text = short(repr(extraction))
    assert text.startswith("Extraction(sensors=['left'], 1235 samples at 30.0 fps, 16 markers, ")
    assert with_uncertainty(fit.decay_rate, fit.decay_rate_std) in text
    assert repr(lt.Extraction(tracks=[tracks], signal=signal, fit=None)).endswith("not fitted)")
    empty = lt.MarkerTracks(
        np.zeros(0), np.zeros((0, 0, 2)), np.zeros((0, 0), bool), np.zeros((0, 2))
    )
    assert repr(empty) == "MarkerTracks(sensor='sensor', 0 frames × 0 markers, — valid)"


def test_live_update_repr() -> None:
    update = LiveUpdate(
        t_s=3.21,
        phase="decay",
        decay_rate=np.float64(0.1547),
        decay_rate_std=0.0015,
        angular_frequency=14.18,
        angular_frequency_std=0.0004,
        predicted={"height_mm": (np.float64(25.13), 0.41)},
        classified={"liquid": ("water", {"water": 0.9, "oil": 0.1})},
        signal_u=np.arange(500.0),
    )
    assert short(repr(update)) == (
        "LiveUpdate(phase='decay', t_s=3.21, decay_rate=0.1547 ± 0.0015 1/s, "
        "angular_frequency=14.18000 ± 0.00040 rad/s, height_mm=25.13 ± 0.41, liquid='water')"
    )
    assert short(repr(LiveUpdate())).startswith("LiveUpdate(phase='waiting'")


def test_cli_and_reprs_share_one_formatter() -> None:
    assert cli_format.with_uncertainty is with_uncertainty


@pytest.fixture(scope="module")
def sugar():
    train, _ = paper_split(seed=0)
    return train[list(FEATURE_COLUMNS)].to_numpy(), train


def test_property_model_params_round_trip_and_repr(sugar) -> None:
    X, train = sugar
    targets = {"height_mm": train["height_mm"], "sugar_concentration": train["sugar_concentration"]}
    model = lt.train_regression(X, targets, "quadratic")
    params = model.get_params()
    assert list(params) == [
        "regressors",
        "classifier",
        "label",
        "feature_map",
        "domain",
        "calibration",
    ]
    assert params == model.get_params(deep=False)
    again = lt.PropertyModel(**params)
    assert again.get_params() == params
    for target, (mean, _) in again.predict(X).items():
        np.testing.assert_array_equal(mean, model.predict(X)[target][0])
    text = short(repr(model))
    assert text.startswith(
        "PropertyModel(regression, targets=['height_mm', 'sugar_concentration'], "
        f"model='quadratic', {len(X)} training rows, λ in ["
    )
    assert model.describe_domain() in text

    model.provenance = {"liquidtouch": lt.__version__}
    shifted = FeatureMap((1.1, 0.0), (1.0, 0.2))
    assert model.set_params(feature_map=shifted) is model
    assert model.feature_map == shifted and model.provenance == {"liquidtouch": lt.__version__}
    assert repr(model).endswith(", container transfer)")
    model.set_params(domain=TrainingDomain((0.0, 5.0), (2.0, 20.0)))
    assert model.domain == TrainingDomain((0.0, 5.0), (2.0, 20.0))
    with pytest.raises(TableError, match="no parameter 'kernel'"):
        model.set_params(kernel=None)
    with pytest.raises(TableError, match="either regressors or a classifier"):
        model.set_params(regressors={})
    assert model.targets == ["height_mm", "sugar_concentration"]  # a refused change changes nothing

    labels = np.where(train["sugar_concentration"] > 40, "sweet", "plain")
    classifier = lt.train_classifier(X, labels, label="taste")
    assert short(repr(classifier)).startswith(
        f"PropertyModel(classification, targets=['taste'], model='svm', {len(X)} training rows"
    )
    assert lt.PropertyModel(**classifier.get_params()).targets == ["taste"]
