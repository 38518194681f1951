"""A GP fitted with its rows' own feature std: each row's noise, and what it changes."""

from __future__ import annotations

import json

import numpy as np
import pytest

from liquidtouch.errors import ModelFileError
from liquidtouch.models.conformal import TotalStdRegressor
from liquidtouch.models.modelfile import load_model, model_to_dict, save_model
from liquidtouch.models.regressors import GPRegressor
from liquidtouch.models.training import train_regression


def height(X: np.ndarray) -> np.ndarray:
    """A smooth 'fill height' [mm] of (λ [1/s], ω [rad/s]): ω carries it, λ a little."""
    return 20.0 + 12.0 * np.sin((X[:, 1] - 10.0) / 4.0) + 1.5 * X[:, 0]


def table(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """60 rows over λ 0.2-3, ω 10-16; the 12 rows at λ > 2.4 (a heavily damped liquid)
    were fitted with ω std 0.3 rad/s and their ω is that far off, the others to 0.005.
    Returns the observed X, y (the truth at the true ω), X_std and the noisy rows' mask."""
    rng = np.random.default_rng(seed)
    lam = np.r_[rng.uniform(0.2, 2.2, 48), rng.uniform(2.4, 3.0, 12)]
    omega = rng.uniform(10.0, 16.0, 60)
    noisy = lam > 2.4
    omega_std = np.where(noisy, 0.3, 0.005)
    X_true = np.column_stack([lam, omega])
    X = np.column_stack([lam, omega + rng.normal(0.0, omega_std)])
    return X, height(X_true), np.column_stack([0.01 * lam, omega_std]), noisy


@pytest.mark.parametrize("seed", range(4))
def test_rows_with_an_uncertain_fit_pull_the_model_less(seed) -> None:
    """Where the rows' ω is 0.3 rad/s off (≈ 1 mm of height), the GP that knows their std
    predicts the truth better than the one that gives every row one noise level; the
    noisy rows get the larger noise, and the precise region stays as good."""
    X, y, X_std, noisy = table(seed)
    plain = GPRegressor(random_state=0).fit(X, y)
    knowing = GPRegressor(random_state=0).fit(X, y, X_std=X_std)
    assert plain.row_noise_ is None
    assert knowing.row_noise_.min() > 0
    assert np.median(knowing.row_noise_[noisy]) > 100 * np.median(knowing.row_noise_[~noisy])
    assert knowing.kernel_params_["noise_level"] >= plain.kernel_params_["noise_level"]
    assert "own noise" in knowing.describe() and "own noise" not in plain.describe()
    rng = np.random.default_rng(100 + seed)
    damped = np.column_stack([rng.uniform(2.45, 2.95, 200), rng.uniform(10.5, 15.5, 200)])
    clean = np.column_stack([rng.uniform(0.3, 2.1, 200), rng.uniform(10.5, 15.5, 200)])

    def rms(model, Xq):
        return float(np.sqrt(np.mean((model.predict(Xq) - height(Xq)) ** 2)))

    assert rms(knowing, damped) < 0.8 * rms(plain, damped)
    assert rms(knowing, clean) < 1.2 * rms(plain, clean) + 0.05


def test_the_calibration_folds_are_fitted_as_the_final_model_is() -> None:
    X, y, X_std, _ = table(0)
    wrapped = TotalStdRegressor(GPRegressor(random_state=0)).fit(np.column_stack([X, X_std]), y)
    assert wrapped.estimator_.row_noise_ is not None
    direct = GPRegressor(random_state=0).fit(X, y, X_std=X_std)
    np.testing.assert_array_equal(wrapped.estimator_.row_noise_, direct.row_noise_)


@pytest.fixture(scope="module")
def trained():
    X, y, X_std, _ = table(1)
    return train_regression(X, {"height_mm": y}, "gpr", calibration_std=X_std), X


def test_row_noise_survives_a_model_file_exactly(tmp_path, trained) -> None:
    model, X = trained
    again = load_model(save_model(model, tmp_path / "m.json"))
    Xq = X + 0.05
    X_std = np.full_like(Xq, 0.01)
    m1, s1 = model.predict(Xq, X_std)["height_mm"]
    m2, s2 = again.predict(Xq, X_std)["height_mm"]
    assert np.array_equal(m1, m2) and np.array_equal(s1, s2)
    doc = json.loads((tmp_path / "m.json").read_text())
    assert len(doc["regressors"]["height_mm"]["row_noise"]) == len(X)


@pytest.mark.parametrize(
    "edit, message",
    [
        (lambda d: d["regressors"]["height_mm"].update(row_noise=[0.1, 0.2]), "row_noise has 2"),
        (lambda d: d["regressors"]["height_mm"]["row_noise"].__setitem__(0, -1.0), "greater than"),
        (lambda d: d.update(format_version=6), "row_noise needs format version 7"),
    ],
)
def test_a_bad_row_noise_is_refused(tmp_path, trained, edit, message) -> None:
    doc = json.loads(json.dumps(model_to_dict(trained[0])))
    edit(doc)
    doc.pop("sha256")  # the edit is what is refused, not the checksum
    path = tmp_path / "m.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(ModelFileError, match=message):
        load_model(path)
