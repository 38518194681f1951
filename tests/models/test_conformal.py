"""Calibrated intervals (cross-conformal) and the fit's std propagated through a model."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest

from liquidtouch.errors import ModelFileError, TableError
from liquidtouch.models.conformal import TargetCalibration, min_rows_for_level
from liquidtouch.models.modelfile import load_model, model_from_dict, model_to_dict, save_model
from liquidtouch.models.training import train_regression


def _table(n: int, noise: float, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(λ, ω) features, the noise-free truth and noisy observations of a smooth property."""
    rng = np.random.default_rng(seed)
    X = np.column_stack([rng.uniform(0.1, 1.3, n), rng.uniform(10.0, 14.0, n)])
    truth = 20 + 5 * np.sin(2.5 * X[:, 0]) + 3 * (X[:, 1] - 12.0)
    return X, truth, truth + noise * rng.standard_normal(n)


@pytest.mark.parametrize(("model", "noise"), [("gpr", 0.3), ("quadratic", 0.5)])
def test_conformal_intervals_cover_new_rows_at_their_level(model: str, noise: float) -> None:
    """Known Gaussian noise: the calibrated ±1σ, ±2σ and 90 % interval cover held-out rows."""
    X, _, y = _table(300, noise, seed=1)
    fitted = train_regression(X, {"h": y}, model, calibration_folds=10)
    assert fitted.calibrated and fitted.calibration["h"].n == 300
    Xt, _, yt = _table(3000, noise, seed=2)
    mean, std = fitted.predict(Xt)["h"]
    z = np.abs(mean - yt) / std
    # 3000 test rows: binomial std ≈ 0.9 %; the calibration itself (300 rows) moves ~2.7 %
    assert np.mean(z <= 1) == pytest.approx(0.683, abs=0.07)
    assert np.mean(z <= 2) == pytest.approx(0.954, abs=0.035)
    assert math.sqrt(np.mean(z**2)) == pytest.approx(1.0, abs=0.15)
    lower, upper = fitted.predict_interval(Xt, 0.9)["h"]
    assert np.mean((yt >= lower) & (yt <= upper)) == pytest.approx(0.9, abs=0.04)
    assert np.all(upper > lower)


def test_scores_of_the_total_std_count_the_features_noise_once(tmp_path) -> None:
    """Features observed with known noise (ω ± 0.3 rad/s, as a fit's std says): scores of
    the model's std alone already hold that noise, so adding the propagated fit std on top
    counted it twice (over-cautious); scores of the total std count it once."""
    rng = np.random.default_rng(11)

    def rows(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        X = np.column_stack([rng.uniform(0.1, 1.3, n), rng.uniform(10.0, 14.0, n)])
        y = 20 + 3 * (X[:, 1] - 12.0) + 0.05 * rng.standard_normal(n)
        X_std = np.column_stack([np.full(n, 0.01), np.full(n, 0.3)])
        return X + X_std * rng.standard_normal((n, 2)), X_std, y

    X, X_std, y = rows(200)
    total = train_regression(X, {"h": y}, "gpr", calibration_folds=10, calibration_std=X_std)
    alone = train_regression(X, {"h": y}, "gpr", calibration_folds=10)
    assert total.calibration["h"].normalised_by == "total-std"
    assert alone.calibration["h"].normalised_by == "model-std"
    Xt, Xt_std, yt = rows(2000)
    z = {}
    for name, fitted in (("total", total), ("alone", alone)):
        mean, std = fitted.predict(Xt, Xt_std)["h"]
        z[name] = np.abs(mean - yt) / std
    assert math.sqrt(np.mean(z["total"] ** 2)) == pytest.approx(1.0, abs=0.15)
    assert np.mean(z["total"] <= 1) == pytest.approx(0.683, abs=0.07)
    assert math.sqrt(np.mean(z["alone"] ** 2)) < 0.8  # the noise counted twice
    back = load_model(save_model(total, tmp_path / "m.json"))
    assert back.calibration == total.calibration
    assert json.loads((tmp_path / "m.json").read_text())["calibration"]["h"]["normalised_by"] == (
        "total-std"
    )


def test_calibration_corrects_a_wrong_model_std() -> None:
    """A quadratic fitted to a sine: its OLS std is too small; calibration widens it to cover."""
    rng = np.random.default_rng(3)
    X = np.column_stack([rng.uniform(0.1, 1.3, 200), rng.uniform(10.0, 14.0, 200)])
    y = 20 + 8 * np.sin(4 * X[:, 0]) + 0.05 * rng.standard_normal(200)  # not quadratic
    raw = train_regression(X, {"h": y}, "quadratic")
    cal = train_regression(X, {"h": y}, "quadratic", calibration_folds=10)
    Xt = np.column_stack([rng.uniform(0.1, 1.3, 2000), rng.uniform(10.0, 14.0, 2000)])
    yt = 20 + 8 * np.sin(4 * Xt[:, 0])
    for fitted, lo, hi in ((raw, 0.0, 0.62), (cal, 0.63, 0.74)):
        mean, std = fitted.predict(Xt)["h"]
        assert lo <= np.mean(np.abs(mean - yt) <= std) <= hi


def test_a_level_needs_enough_rows_and_says_how_many() -> None:
    assert [min_rows_for_level(v) for v in (0.5, 0.8, 0.9, 0.95, 0.99)] == [1, 4, 9, 19, 99]
    X, _, y = _table(8, 0.1, seed=4)
    fitted = train_regression(X, {"h": y}, "gpr", calibration_folds=10)
    assert fitted.calibration["h"].n == 8 and fitted.calibration["h"].n_folds == 8
    fitted.predict_interval(X, 0.8)  # 8 rows: up to 8/9
    with pytest.raises(TableError, match=r"at least 9 training rows; this one has 8"):
        fitted.predict_interval(X, 0.9)
    with pytest.raises(TableError, match="in \\(0, 1\\)"):
        fitted.predict_interval(X, 1.5)
    uncalibrated = train_regression(X, {"h": y}, "gpr")
    with pytest.raises(TableError, match="no interval calibration"):
        uncalibrated.predict_interval(X, 0.8)


def test_predict_level_on_the_command_line(tmp_path, capsys) -> None:
    from liquidtouch.cli import main

    X, _, y = _table(12, 0.1, seed=5)
    table = pd.DataFrame({"decay_rate": X[:, 0], "angular_frequency": X[:, 1], "height_mm": y})
    table.to_csv(tmp_path / "f.csv", index=False)
    model = tmp_path / "m.json"
    assert main(["train", str(tmp_path / "f.csv"), "-t", "height_mm", "-o", str(model)]) == 0
    capsys.readouterr()
    status = main(["predict", str(model), str(tmp_path / "f.csv"), "--level", "0.9", "--json"])
    out = json.loads(capsys.readouterr().out)
    assert status == 0 and out["calibrated"] and out["level"] == 0.9
    row = out["rows"][0]
    assert row["predicted_height_mm_lower"] < row["predicted_height_mm"]
    assert row["predicted_height_mm"] < row["predicted_height_mm_upper"]
    status = main(["predict", str(model), str(tmp_path / "f.csv"), "--level", "0.95"])
    err = capsys.readouterr().err
    assert status == 2 and err.startswith("error: ") and "at least 19 training rows" in err


def test_a_larger_decay_rate_std_gives_a_larger_property_std() -> None:
    X, _, y = _table(60, 0.1, seed=6)
    fitted = train_regression(X, {"h": y}, "gpr", calibration_folds=5)
    at = np.array([[0.6, 12.0]] * 4)
    lam_std = np.array([0.0, 0.01, 0.05, 0.2])
    _, std = fitted.predict(at, X_std=np.column_stack([lam_std, np.zeros(4)]))["h"]
    assert np.all(np.diff(std) > 0)
    # the model's own (calibrated) std is the floor, the propagated one is added in quadrature
    _, exact = fitted.predict(at[:1])["h"]
    assert std[0] == pytest.approx(exact[0])
    # a feature table's std columns go the same way into predict_table
    table = pd.DataFrame(
        {"decay_rate": at[:, 0], "angular_frequency": at[:, 1], "decay_rate_std": lam_std,
         "angular_frequency_std": [np.nan] * 4}
    )  # fmt: skip
    assert np.allclose(fitted.predict_table(table)["predicted_h_std"], std)


def test_the_calibration_is_stored_in_the_model_file(tmp_path) -> None:
    X, _, y = _table(30, 0.1, seed=7)
    fitted = train_regression(X, {"h": y}, "gpr", calibration_folds=5)
    path = save_model(fitted, tmp_path / "m.json")
    back = load_model(path)
    assert back.calibration == fitted.calibration
    lo, hi = back.predict_interval(X, 0.9)["h"]
    lo0, hi0 = fitted.predict_interval(X, 0.9)["h"]
    assert np.array_equal(lo, lo0) and np.array_equal(hi, hi0)
    doc = json.loads(path.read_text())
    assert doc["format_version"] == 8 and doc["calibration"]["h"]["n_folds"] == 5
    # a version-2 file (no calibration) still loads, uncalibrated
    from liquidtouch.models.modelfile_checks import document_sha256

    old = model_to_dict(train_regression(X, {"h": y}, "gpr"))
    old["format_version"] = 2
    del old["calibration"]
    old["sha256"] = document_sha256(old)
    assert not model_from_dict(old).calibrated
    # scores that do not match the training rows are refused
    bad = json.loads(path.read_text())
    bad["calibration"]["h"]["scores"] = bad["calibration"]["h"]["scores"][:-1]
    bad["sha256"] = document_sha256(bad)
    with pytest.raises(ModelFileError, match="29 scores for 30 training rows"):
        model_from_dict(bad)


def test_target_calibration_quantiles() -> None:
    cal = TargetCalibration(tuple(float(v) for v in range(1, 20)), n_folds=5)  # 1..19
    assert cal.quantile(0.5) == 10.0  # ⌈20 · 0.5⌉ = 10th smallest
    assert cal.quantile(0.95) == 19.0
    assert cal.std_scale == 14.0  # ⌈20 · 0.6827⌉ = 14th
    assert cal.half_width(0.95) == pytest.approx(19 / 14)
    with pytest.raises(TableError):
        TargetCalibration((1.0,), n_folds=2)


def test_grouped_folds_hold_a_height_out_whole_and_still_cover() -> None:
    """5 liquids × 9 heights × 2 trials: folds grouped by height predict each row at an
    unseen height (its twins and the other liquids at that height are held out with it)."""
    from liquidtouch.models.conformal import calibration_folds
    from liquidtouch.testing.synthetic_tables import liquid_table

    liquids = ["water", "mirin", "corn-oil", "olive-oil", "detergent"]
    train = liquid_table(liquids, np.linspace(16, 40, 9), repeats=2, seed=1)
    X, y = train[["decay_rate", "angular_frequency"]].to_numpy(), train["height_mm"].to_numpy()
    folds = calibration_folds(len(y), 10, groups=y)
    assert len(folds) == 9  # one fold per height: fewer groups than folds
    for fit_rows, held_out in folds:
        assert not set(y[fit_rows]) & set(y[held_out])
    test = liquid_table(liquids, np.random.default_rng(2).uniform(16, 40, 300), 1, seed=3)
    Xt, yt = test[["decay_rate", "angular_frequency"]].to_numpy(), test["height_mm"].to_numpy()
    model = train_regression(X, {"h": y}, "gpr", calibration_folds=10, calibration_groups=y)
    mean, std = model.predict(Xt)["h"]
    assert np.mean(np.abs(mean - yt) <= 2 * std) >= 0.9
    with pytest.raises(TableError, match="at least 2 groups"):
        calibration_folds(len(y), 10, groups=np.zeros(len(y)))


def test_a_local_factor_calibrates_each_region_of_uneven_noise(tmp_path) -> None:
    """Noise 0.2 below λ = 0.7, 1.0 above (one liquid measured worse than the others): one
    scale would be too wide in the first region and too narrow in the second."""
    rng = np.random.default_rng(11)

    def rows(n: int) -> tuple[np.ndarray, np.ndarray]:
        X = np.column_stack([rng.uniform(0.1, 1.3, n), rng.uniform(10.0, 14.0, n)])
        noise = np.where(X[:, 0] < 0.7, 0.2, 1.0)
        return X, 20 + 3 * X[:, 0] + (X[:, 1] - 12.0) + noise * rng.standard_normal(n)

    X, y = rows(300)
    fitted = train_regression(X, {"h": y}, "gpr", calibration_folds=10)
    cal = fitted.calibration["h"]
    assert cal.local is not None  # chosen over one scale by cross-validation
    Xt, yt = rows(3000)
    mean, std = fitted.predict(Xt)["h"]
    z = np.abs(mean - yt) / std
    for region in (Xt[:, 0] < 0.65, Xt[:, 0] > 0.75):
        assert np.mean(z[region] <= 1) == pytest.approx(0.683, abs=0.08)
        assert math.sqrt(np.mean(z[region] ** 2)) == pytest.approx(1.0, abs=0.2)
    rho = cal.local_factor(np.array([[0.3, 12.0], [1.1, 12.0]]))
    assert rho[1] > 2.5 * rho[0]  # the true ratio is 5
    back = load_model(save_model(fitted, tmp_path / "m.json"))
    assert back.calibration == fitted.calibration
    assert np.array_equal(back.predict(Xt[:50])["h"][1], fitted.predict(Xt[:50])["h"][1])


def test_default_groups_hold_out_a_height_on_sparse_designs_and_repeats_on_dense() -> None:
    from liquidtouch.models.conformal import DENSE_HEIGHTS, default_groups

    def table(n_heights: int) -> pd.DataFrame:
        h = np.repeat(np.linspace(16, 40, n_heights), 2)  # two trials per height
        return pd.DataFrame(
            {"liquid": ["water"] * h.size + ["mirin"] * h.size, "height_mm": np.tile(h, 2),
             "sugar_concentration": np.nan, "decay_rate": 0.1}
        )  # fmt: skip

    sparse = default_groups(table(DENSE_HEIGHTS - 2))
    assert len(set(sparse)) == DENSE_HEIGHTS - 2  # one group per height, both liquids in it
    dense_table = table(DENSE_HEIGHTS)
    dense = default_groups(dense_table)
    assert len(set(dense)) == 2 * DENSE_HEIGHTS  # a (liquid, height): its two repeats
    assert dense[0] == dense[1] and dense[0] != dense[2 * DENSE_HEIGHTS]
    assert default_groups(dense_table[["decay_rate"]]) is None


def test_an_omega_std_larger_than_omega_is_propagated_without_failing() -> None:
    # a failed final fit reported ω = 1.9 ± 100 rad/s; the physics GP refuses ω <= 0, so the
    # step below ω must stop above 0
    X, _, y = _table(40, 0.1, seed=8)
    fitted = train_regression(X, {"height_mm": y}, "physics-gpr")
    _, std = fitted.predict([[0.6, 1.9]], X_std=[[0.1, 100.0]])["height_mm"]
    assert np.isfinite(std[0]) and std[0] > 0
