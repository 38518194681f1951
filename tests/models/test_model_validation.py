"""The models layer validates its arguments at the API edge and raises typed errors."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.exceptions import NotFittedError

from liquidtouch.errors import ModelFileError, TableError
from liquidtouch.models import (
    GPRegressor,
    LiquidClassifier,
    PhysicsGPRegressor,
    PropertyModel,
    QuadraticRegressor,
    fit_transfer,
    save_model,
    train_classifier,
    train_regression,
)
from liquidtouch.models.feature_space import FeatureMap
from liquidtouch.models.physics_prior import dispersion_height_mm, fit_wavenumber

RNG = np.random.default_rng(0)
X = np.column_stack([RNG.uniform(0.1, 1.3, 30), RNG.uniform(10.0, 14.0, 30)])
Y = 20 + 10 * np.sin(X[:, 0]) + (X[:, 1] - 12) ** 2


@pytest.fixture(scope="module")
def quad() -> QuadraticRegressor:
    return QuadraticRegressor().fit(X, Y)


@pytest.mark.parametrize(
    "estimator, message",
    [
        (GPRegressor(n_restarts=-1), r"n_restarts must be an integer >= 0; got -1"),
        (GPRegressor(n_restarts=1.5), r"n_restarts must be an integer"),
        (GPRegressor(random_state="seed"), r"random_state must be None, an integer"),
        (PhysicsGPRegressor(prior="colour"), r"unknown physics prior 'colour'"),
        (LiquidClassifier(C=-1.0), r"C must be a finite number > 0"),
        (LiquidClassifier(gamma=float("nan")), r"gamma must be a finite number > 0"),
    ],
)
def test_bad_hyperparameters_are_refused_in_fit(estimator, message) -> None:
    labels = np.repeat(["water", "oil", "honey"], 10)
    with pytest.raises(TableError, match=message):
        estimator.fit(X, labels if isinstance(estimator, LiquidClassifier) else Y)


@pytest.mark.parametrize(
    "bad, message",
    [
        (np.where(np.arange(60).reshape(30, 2) == 7, np.nan, X), r"NaN or infinite.*row\(s\) 3"),
        (np.column_stack([X, X[:, 0]]), r"X has 3 features, but QuadraticRegressor is expecting 2"),
        (X[0], r"Reshape your data"),
        ([["fast", "slow"]], r"could not convert|numeric"),
    ],
)
def test_bad_prediction_input(quad, bad, message) -> None:
    with pytest.raises(TableError, match=message):
        quad.predict(bad)


def test_bad_training_input() -> None:
    with pytest.raises(TableError, match="30 feature rows but 29 target values"):
        GPRegressor().fit(X, Y[:-1])
    with pytest.raises(TableError, match="at least 7 training rows; got n_samples=6"):
        QuadraticRegressor().fit(X[:6], Y[:6])
    with pytest.raises(TableError, match="Unknown label type"):
        LiquidClassifier().fit(X, Y)  # continuous labels are not classes
    with pytest.raises(TableError, match="at least 2 classes; got 1 class"):
        LiquidClassifier().fit(X, ["water"] * 30)
    with pytest.raises(TableError, match="Negative values"):
        PhysicsGPRegressor().fit(X * [1, -1], Y)


def test_unfitted_estimators_say_so() -> None:
    for estimator in (GPRegressor(), QuadraticRegressor(), PhysicsGPRegressor()):
        with pytest.raises(NotFittedError):
            estimator.predict(X)
    with pytest.raises(NotFittedError):
        LiquidClassifier().predict_proba(X)


def test_project_edge_requires_the_two_features_and_matching_targets() -> None:
    with pytest.raises(TableError, match=r"\(n, 2\).*decay_rate, angular_frequency"):
        train_regression(np.column_stack([X, X]), {"height_mm": Y})
    with pytest.raises(TableError, match="at least one target"):
        train_regression(X, {})
    with pytest.raises(TableError, match="target height_mm: 30 feature rows but 5 values"):
        train_regression(X, {"height_mm": Y[:5]})
    with pytest.raises(TableError, match="no physics prior"):
        train_regression(X, {"colour": Y}, "physics-gpr")
    with pytest.raises(TableError, match="unknown model 'forest'; choose one of gpr, quadratic"):
        train_regression(X, {"height_mm": Y}, "forest")
    with pytest.raises(TableError, match="progress must be a callable"):
        train_regression(X, {"height_mm": Y}, "quadratic", progress="yes")
    with pytest.raises(TableError, match="30 feature rows but labels of shape"):
        train_classifier(X, ["water"] * 29)


def test_property_model_and_feature_map_invariants(quad) -> None:
    with pytest.raises(TableError, match="fitted on the 2 features"):
        PropertyModel(regressors={"height_mm": QuadraticRegressor()})
    wide = QuadraticRegressor().fit(np.column_stack([X, X[:, 0] * X[:, 1]]), Y)
    with pytest.raises(TableError, match="fitted on the 2 features"):
        PropertyModel(regressors={"height_mm": wide})
    with pytest.raises(TableError, match="alpha must be two finite numbers"):
        FeatureMap(alpha=(1.0, np.inf))
    with pytest.raises(TableError, match=r"\(n, 2\)"):
        FeatureMap().apply(X[:, :1])
    model = PropertyModel(regressors={"height_mm": quad})
    with pytest.raises(TableError, match="f_scale must be a finite number > 0"):
        fit_transfer(model, X, {"height_mm": Y}, f_scale=0.0)
    with pytest.raises(TableError, match="identity_weight must be a finite number >= 0"):
        fit_transfer(model, X, {"height_mm": Y}, identity_weight=-1.0)
    with pytest.raises(TableError, match="needs a PropertyModel"):
        fit_transfer(quad, X, {"height_mm": Y})


def test_saving_refuses_what_a_model_file_cannot_hold(tmp_path, quad) -> None:
    with pytest.raises(ModelFileError, match="only a PropertyModel can be saved"):
        save_model(quad, tmp_path / "m.json")
    unseeded = GPRegressor(n_restarts=0, random_state=None).fit(X, Y)
    with pytest.raises(ModelFileError, match="integer random_state"):
        save_model(PropertyModel(regressors={"height_mm": unseeded}), tmp_path / "m.json")
    numbered = LiquidClassifier().fit(X, np.repeat([1, 2, 3], 10))
    with pytest.raises(ModelFileError, match="class names as strings"):
        save_model(PropertyModel(classifier=numbered), tmp_path / "m.json")
    assert not (tmp_path / "m.json").exists()


def test_physics_helpers_validate() -> None:
    with pytest.raises(TableError, match="wavenumber must be a finite number > 0"):
        dispersion_height_mm(X[:, 0], X[:, 1], 0.0)
    with pytest.raises(TableError, match="equally many values"):
        fit_wavenumber(X[:, 0], X[:, 1], Y[:3])
    with pytest.raises(TableError, match="height_mm contains NaN"):
        fit_wavenumber(X[:, 0], X[:, 1], np.full(30, np.nan))
