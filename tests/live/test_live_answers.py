"""Why an answer is missing, said (issue 41): an ``--until-std`` target below the model's
calibrated std floor, a classifier too small to say "unknown"; one definition of
``out_of_domain`` and one set of field names in ``predict`` and ``live``; a stream's
repeated estimate printed once; ``--level`` outside what the calibration resolves refused.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from liquidtouch.cli import main
from liquidtouch.errors import ModelFileError, TableError
from liquidtouch.live.stopping import std_floors, unreachable_targets
from liquidtouch.models.classifier import unknown_rows_needed
from liquidtouch.models.modelfile import load_model, save_model
from liquidtouch.models.training import train_classifier, train_regression


def _run(capsys, *argv: object) -> tuple[int, str, str]:
    status = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


@pytest.fixture(scope="module")
def trial(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, object]:
    """A short simulated mirin trial (6 s, GelSight Mini videos): λ ≈ 0.7/s decays in time."""
    from liquidtouch.sim.trial import simulate_trial
    from liquidtouch.sim.trial_io import write_trial

    simulated = simulate_trial("mirin", height_mm=25.0, seed=4, duration_s=6.0)
    directory = write_trial(simulated, tmp_path_factory.mktemp("answers") / "trial", sensor="mini")
    return directory, simulated


def _classes(truth, n: int, rng) -> tuple[np.ndarray, list[str]]:
    """Two made-up liquids either side of the trial's (λ, ω), ``n`` rows each: the trial lies
    inside their (λ, ω) box (in the training domain) but far from both (unknown)."""
    lam, omega = truth.true_decay_rate, truth.true_angular_frequency
    rows, labels = [], []
    for name, (f_lam, f_omega) in {"thin": (0.3, 0.85), "thick": (2.5, 1.2)}.items():
        rows.append(
            np.column_stack([
                lam * f_lam * np.exp(0.03 * rng.standard_normal(n)),
                omega * f_omega * (1 + 0.003 * rng.standard_normal(n)),
            ])
        )  # fmt: skip
        labels += [name] * n
    return np.vstack(rows), labels


def test_the_unknown_rule_needs_enough_rows_per_class(trial, tmp_path, capsys):
    """classify on 4 rows per class warns; the model file and every prediction say so."""
    rng = np.random.default_rng(0)
    X, labels = _classes(trial[1], 4, rng)
    csv = tmp_path / "few.csv"
    rows = ["decay_rate,angular_frequency,liquid"]
    rows += [f"{a},{b},{c}" for (a, b), c in zip(X, labels, strict=True)]
    csv.write_text("\n".join(rows) + "\n")
    needed = unknown_rows_needed()
    assert needed == 15  # the T² limit within twice its large-sample value (classifier.py)
    status, _, err = _run(capsys, "classify", csv, "--label", "liquid", "-o", tmp_path / "c.json")
    assert status == 0, err
    rule = f"unavailable, needs {needed} rows per class"
    assert f"cannot flag unknown liquids (unknown_rule: {rule}" in err
    doc = json.loads((tmp_path / "c.json").read_text())
    assert doc["classifier"]["unknown"]["status"] == rule
    status, out, err = _run(capsys, "predict", tmp_path / "c.json", csv, "--json")
    assert status == 0, err
    result = json.loads(out)
    assert result["unknown_rule"] == rule and {r["unknown_rule"] for r in result["rows"]} == {rule}
    # a stored status that does not match the rows is refused
    doc["classifier"]["unknown"]["status"] = "available"
    from liquidtouch.models.modelfile import document_sha256

    del doc["sha256"]
    doc["sha256"] = document_sha256(doc)
    (tmp_path / "forged.json").write_text(json.dumps(doc))
    with pytest.raises(ModelFileError, match=r"unknown\.status"):
        load_model(tmp_path / "forged.json")


@pytest.mark.slow(seconds=40)
def test_predict_and_live_say_the_same_for_the_same_trial(trial, tmp_path, capsys):
    """The trial lies inside the classifier's training box but far from both its classes:
    "unknown", out_of_domain true in both, with the same field names."""
    rng = np.random.default_rng(1)
    X, labels = _classes(trial[1], 20, rng)
    model = save_model(train_classifier(X, labels), tmp_path / "c.json")
    status, out, err = _run(capsys, "predict", model, trial[0], "--json")
    assert status == 0, err
    row = json.loads(out)["rows"][0]
    status, out, err = _run(capsys, "live", trial[0], "--json", "--model", model)
    assert status == 0, err
    final = json.loads(out.splitlines()[-1])
    assert row["predicted_liquid"] == final["predicted_liquid"] == "unknown"
    assert row["out_of_domain"] is True and final["out_of_domain"] is True
    assert row["unknown_rule"] == final["unknown_rule"] == "available"
    names = {k for k in row if k.startswith(("predicted_", "probability_"))}
    assert names == {k for k in final if k.startswith(("predicted_", "probability_"))}
    assert names == {"predicted_liquid", "probability_thin", "probability_thick"}
    # the same fit: the same λ, ω
    assert final["decay_rate"] == pytest.approx(row["decay_rate"], rel=1e-9)


@pytest.fixture(scope="module")
def noisy_height_model(tmp_path_factory):
    """height_mm = 2 ω − 3 + noise of 0.5 mm (quadratic, calibrated): its std cannot fall
    below ~0.5 mm anywhere."""
    rng = np.random.default_rng(2)
    lam, omega = np.meshgrid(np.linspace(0.05, 1.5, 8), np.linspace(8.0, 20.0, 8))
    X = np.column_stack([lam.ravel(), omega.ravel()])
    y = 2.0 * X[:, 1] - 3.0 + 0.5 * rng.standard_normal(len(X))
    model = train_regression(X, {"height_mm": y}, model="quadratic", calibration_folds=5)
    return save_model(model, tmp_path_factory.mktemp("floor") / "height.json")


def test_the_calibrated_floor(noisy_height_model):
    model = load_model(noisy_height_model)
    floor = std_floors(model, ["height_mm"])["height_mm"]
    assert 0.3 < floor < 1.0  # the noise is 0.5 mm
    grid = np.column_stack([np.linspace(0.1, 1.4, 50), np.linspace(9.0, 19.0, 50)])
    assert model.predict(grid)["height_mm"][1].min() >= floor * (1 - 1e-9)
    assert unreachable_targets(model, {"height_mm": floor / 2}) == {"height_mm": floor}
    assert unreachable_targets(model, {"height_mm": floor * 2}) == {}


@pytest.mark.slow(seconds=20)
def test_an_unreachable_until_std_is_said_and_hides_nothing(trial, noisy_height_model, capsys):
    status, out, err = _run(
        capsys, "live", trial[0], "--json", "--model", noisy_height_model,
        "--until-std", "height_mm=0.05",
    )  # fmt: skip
    assert status == 0, err
    assert "--until-std height_mm=0.05 cannot be met" in err and err.count("cannot be met") == 1
    lines = [json.loads(line) for line in out.splitlines()]
    assert all("height_mm" in u["until_std_unreachable"] for u in lines)
    assert all("cannot be met" in u["message"] for u in lines)
    shown = [u for u in lines if not u["final"] and u.get("predicted_height_mm") is not None]
    assert shown  # the height is shown while streaming, not hidden behind the threshold
    truth = 2.0 * trial[1].true_angular_frequency - 3.0
    final = lines[-1]
    assert final["stopped_because"] == "end_of_stream"
    assert abs(final["predicted_height_mm"] - truth) < 3 * final["predicted_height_mm_std"]


def test_a_level_below_what_the_calibration_resolves_is_refused(noisy_height_model):
    from liquidtouch.models.predictions import check_level

    model = load_model(noisy_height_model)
    for level in (1e-11, 0.0, 1.0, float("nan")):
        with pytest.raises(TableError):
            check_level(model, level)
    assert check_level(model, 0.9) is None


def test_a_repeated_estimate_is_printed_once(capsys):
    """A stream that goes on after its ring-down ended repeats the estimate every refresh;
    live prints each estimate once, and the final update once."""
    from liquidtouch.cli.live import _show_all
    from liquidtouch.live import LiveUpdate

    def stream():
        for frames in range(10):
            yield LiveUpdate(phase="ended", decay_rate=0.3, decay_rate_std=0.01, frames=frames)
        yield LiveUpdate(phase="done", decay_rate=0.3, final=True, frames=11)

    _show_all(stream(), None, as_json=True)
    lines = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [u["phase"] for u in lines] == ["ended", "done"]
    assert sum(u["final"] for u in lines) == 1


def test_a_threshold_below_the_models_std_here_is_found_where_the_trial_is():
    """A GP on few, spread rows: small std at its rows, large between them. A threshold the
    model meets near its rows is unreachable between them (the README tour's height.json:
    0.11 mm at its rows, 0.86 mm at the tour's 25 mm trial)."""
    from liquidtouch.live.stopping import unreachable_here

    omega = np.array([12.2, 13.4, 14.6, 15.8] * 2)
    lam = np.repeat([0.15, 1.2], 4)
    height = 18.0 + 2.0 * (omega - 12.2) ** 2
    model = train_regression(np.column_stack([lam, omega]), {"height_mm": height})
    floor = std_floors(model, ["height_mm"])["height_mm"]
    middle = model.predict(np.array([[0.15, 14.0]]))["height_mm"][1][0]
    assert middle > 2 * floor  # between rows the GP knows less
    threshold = (floor + middle) / 2
    assert unreachable_targets(model, {"height_mm": threshold}) == {}  # met near its rows
    here = unreachable_here(model, 0.15, 14.0, {"height_mm": threshold})
    assert here == pytest.approx({"height_mm": middle})
    assert unreachable_here(model, 0.15, 13.4, {"height_mm": threshold}) == {}
