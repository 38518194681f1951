"""The streaming estimator (``liquidtouch.live``) on a replayed simulated trial.

At the end of the stream it gives the offline ``extract`` result on the same
videos; before the end it reports ω first, then λ, converging on the final
values; ``until_std`` stops early; a real-time replay takes the recording's time.
"""

from __future__ import annotations

import json
import math
import time

import numpy as np
import pytest
from helpers import RecordingModel

from liquidtouch.errors import ModelFileError, SignalError, VideoError
from liquidtouch.live import LiveEstimator, live_updates, parse_until_std, stop_reached
from liquidtouch.live.properties import predict_with_fit_std
from liquidtouch.live.uncertainty import window_rel_std


@pytest.fixture(scope="module")
def trial(tmp_path_factory: pytest.TempPathFactory):
    """A simulated water trial (8 s, GelSight Mini videos), its offline extraction and truth."""
    from liquidtouch.extraction.pipeline import extract
    from liquidtouch.sim.trial import simulate_trial
    from liquidtouch.sim.trial_io import write_trial

    simulated = simulate_trial("water", height_mm=25.0, seed=2, duration_s=8.0)
    directory = write_trial(simulated, tmp_path_factory.mktemp("live") / "trial", sensor="mini")
    return directory, extract(directory), simulated


@pytest.fixture(scope="module")
def streamed(trial):
    """Every update of the whole stream (read as fast as possible, refreshes in the loop)."""
    return list(live_updates(trial[0]))


def test_end_of_stream_matches_offline(trial, streamed) -> None:
    _, offline, _ = trial
    final = streamed[-1]
    assert final.final and final.phase == "done" and final.stopped_because == "end_of_stream"
    assert sum(u.final for u in streamed) == 1
    assert final.decay_rate == pytest.approx(offline.fit.decay_rate, rel=0.02)
    assert final.angular_frequency == pytest.approx(offline.fit.angular_frequency, rel=0.002)
    assert final.frames == sum(len(tr.t) for tr in offline.tracks)


def test_estimates_come_before_the_end_and_converge(trial, streamed) -> None:
    _, _, simulated = trial
    final = streamed[-1]
    early = [u for u in streamed[:-1] if math.isfinite(u.angular_frequency)]
    assert early, "no ω before the end of the stream"
    first = early[0]
    # ω is known within 1 % of the truth less than 2 s into the free decay
    assert first.t_s < 2.0
    assert first.angular_frequency == pytest.approx(simulated.true_angular_frequency, rel=0.01)
    # λ is reported only once its std (fit and window length) is below 10 % of λ, and that
    # std then covers the final λ (water's λ0 ≈ 0.1/s: 8 s show < 1 e-folding, so maybe never)
    with_lam = [u for u in streamed[:-1] if math.isfinite(u.decay_rate)]
    assert not with_lam or with_lam[0].t_s >= first.t_s  # λ needs more decay than ω
    for update in with_lam:
        assert update.decay_rate_std < 0.10 * update.decay_rate
        assert abs(update.decay_rate - final.decay_rate) < 2 * update.decay_rate_std
    # phases move forward only, times since the decay start grow
    order = {"waiting": 0, "push": 1, "decay": 2, "done": 3}
    ranks = [order[u.phase] for u in streamed]
    assert ranks == sorted(ranks)
    times = [u.t_s for u in streamed if u.phase == "decay"]
    assert np.all(np.diff(times) > 0)
    # the free decay's start stays put (within a frame) once found: it used to creep by a
    # sample per refresh as the resampled grid moved, ~0.4 s over a stream
    starts = [u.elapsed_s - u.t_s for u in streamed[:-1] if u.phase == "decay"]
    assert np.ptp(starts) < 0.06


def test_until_std_stops_early(trial, streamed) -> None:
    _, _, simulated = trial
    # ω's streamed std is ≥ 0.6 % of ω on the first 0.8 s of decay (uncertainty.py); 0.04
    # rad/s comes after ~2 s, enough for the final refit (fit_oscillation's 2 s minimum)
    updates = list(live_updates(trial[0], until_std=["angular_frequency=0.04"]))
    final = updates[-1]
    assert final.stopped_because == "until_std"
    assert final.frames < 0.6 * streamed[-1].frames
    assert updates[-2].angular_frequency_std < 0.04
    assert final.angular_frequency == pytest.approx(simulated.true_angular_frequency, rel=0.005)


def test_stopped_before_the_final_fit_keeps_the_last_estimate(trial) -> None:
    # ω's std is below 0.08 rad/s after ~1.2 s of decay: the final update is the estimate that
    # met the threshold (a refit of 1.5 s, edge included, gave λ = 0.004 ± 0.1 here)
    updates = list(live_updates(trial[0], until_std=["angular_frequency=0.08"]))
    final = updates[-1]
    assert final.stopped_because == "until_std" and final.t_s < 2.0
    assert final.angular_frequency == updates[-2].angular_frequency
    assert final.angular_frequency_std == updates[-2].angular_frequency_std < 0.08
    assert "the last streamed estimate is kept" in final.message


def test_max_duration_stops(trial) -> None:
    final = list(live_updates(trial[0], max_duration_s=1.0))[-1]
    assert final.stopped_because == "max_duration"
    assert final.elapsed_s <= 1.0


def test_replay_paces_by_timestamps(trial) -> None:
    began = time.monotonic()
    updates = list(live_updates(trial[0], realtime=True, max_duration_s=1.5))
    took = time.monotonic() - began
    assert 1.4 <= took < 4.0
    timing = updates[-1].timing
    assert timing["frames"] > 0 and timing["frame_lag_s_median"] < 0.5


def test_update_json_has_numbers_only(streamed) -> None:
    for update in (streamed[0], streamed[len(streamed) // 2], streamed[-1]):
        out = update.to_dict(include_signal=True)
        text = json.dumps(out, allow_nan=False)  # NaN would raise
        back = json.loads(text)
        for key in ("t_s", "decay_rate", "decay_rate_std", "angular_frequency"):
            assert key in back
        assert len(back["signal"]["t_s"]) == len(back["signal"]["u"]) == len(back["signal"]["fit"])
    assert streamed[-1].to_dict()["stopped_because"] == "end_of_stream"
    assert streamed[0].to_dict()["decay_rate"] is None


class _LinearModel:
    """A duck-typed regression model (refused by the estimator's until_std check only)."""

    kind = "regression"
    targets = ("height_mm",)


def test_property_std_adds_the_fit_std() -> None:
    """A model of f = 2 λ + 0.5 ω: std² = model std² + (2 σλ)² + (0.5 σω)² (delta method)."""
    from liquidtouch.models.training import train_regression

    rng = np.random.default_rng(0)
    X = np.column_stack([rng.uniform(0.1, 0.4, 40), rng.uniform(12.0, 16.0, 40)])
    model = train_regression(X, {"height_mm": 2.0 * X[:, 0] + 0.5 * X[:, 1]}, "quadratic")
    ((_, model_std),) = model.predict([[0.2, 14.0]]).values()
    out = predict_with_fit_std(model, 0.2, 0.03, 14.0, 0.2)
    mean, std = out["height_mm"]
    assert mean == pytest.approx(2 * 0.2 + 0.5 * 14.0)
    expected = math.sqrt(model_std[0] ** 2 + (2 * 0.03) ** 2 + (0.5 * 0.2) ** 2)
    assert std == pytest.approx(expected, rel=1e-6)
    assert predict_with_fit_std(model, 0.2, math.nan, 14.0, 0.0)["height_mm"][1] == pytest.approx(
        model_std[0]
    )


def test_a_property_model_gets_the_streamed_std_without_its_floors(trial) -> None:
    """The floors stand for the final fit's own scatter, which a model's calibration (on
    final fits) holds already: the shown λ, ω std is the model's input std plus the floor."""
    from liquidtouch.live.uncertainty import DECAY_REL_STD_FLOOR, FREQ_REL_STD_FLOOR

    model = RecordingModel()
    checked = 0
    for u in live_updates(trial[0], model=model):
        if u.final or "call" not in u.predicted:
            continue
        _, (lam_std, omega_std) = model.calls[int(u.predicted["call"][0])]
        if math.isfinite(u.decay_rate):  # water: λ is rarely shown before the end
            shown = math.hypot(lam_std, u.decay_rate * DECAY_REL_STD_FLOOR)
            assert u.decay_rate_std == pytest.approx(shown, rel=1e-9)
        if math.isfinite(u.angular_frequency):
            shown = math.hypot(omega_std, u.angular_frequency * FREQ_REL_STD_FLOOR)
            assert u.angular_frequency_std == pytest.approx(shown, rel=1e-9)
            assert omega_std < u.angular_frequency_std
            checked += 1
    assert checked >= 3


def test_window_std_falls_with_the_efoldings_seen() -> None:
    # beyond the first seconds, the same number of e-foldings (λ · window) gives the same
    # relative std, any liquid
    assert window_rel_std(0.2, 15.0) == pytest.approx(window_rel_std(1.0, 3.0), rel=1e-3)
    assert window_rel_std(0.2, 0.5) > window_rel_std(0.2, 5.0) > window_rel_std(0.2, 50.0)
    assert window_rel_std(0.2, 0.0) == pytest.approx(math.sqrt(0.5**2 + 1.0 + 0.025**2))
    assert window_rel_std(0.2, 50.0) == pytest.approx(0.025)  # the floor
    # the first second of any liquid is uncertain: a viscous liquid's 0.5 s shows 1.5
    # e-foldings, yet its λ is less certain than water's after the same e-foldings in 7.5 s
    assert window_rel_std(3.0, 0.5) > 1.5 * window_rel_std(0.2, 7.5)


def test_until_std_parsing_and_rule() -> None:
    assert parse_until_std(["height_mm=0.5", "decay_rate = 0.01"]) == {
        "height_mm": 0.5,
        "decay_rate": 0.01,
    }
    for bad in (["height_mm"], ["height_mm=-1"], ["=0.5"], ["height_mm=x"], ["a=1", "a=2"]):
        with pytest.raises(SignalError):
            parse_until_std(bad)
    assert stop_reached({"decay_rate": 0.01}, {"decay_rate": 0.005})
    assert not stop_reached({"decay_rate": 0.01}, {"decay_rate": math.nan})
    assert not stop_reached({}, {"decay_rate": 0.0})


def test_estimator_refuses_bad_input() -> None:
    with pytest.raises(ModelFileError, match="height_mm"):
        LiveEstimator(["left"], until_std={"height_mm": 0.5})  # no model
    with pytest.raises(ModelFileError, match="viscosity"):
        LiveEstimator(["left"], model=_LinearModel(), until_std={"viscosity_cst": 0.5})
    estimator = LiveEstimator(["left"])
    with pytest.raises(VideoError, match="unknown sensor"):
        estimator.add_frame("right", 0.0, np.zeros((40, 40), np.uint8))


def test_camera_frames_from_a_replayed_file(trial) -> None:
    """The camera path (a capture thread per source) on a video replayed as a camera."""
    from liquidtouch.live import camera_frames

    frames = camera_frames([str(trial[0] / "left.mp4")], names=["left"])
    got = []
    for frame in frames:
        got.append(frame)
        if len(got) == 8:
            break
    frames.close()  # stops the capture thread and closes the camera
    assert [f.sensor for f in got] == ["left"] * 8
    times = np.array([f.t_s for f in got])
    assert np.all(np.diff(times) > 0) and np.all(np.isfinite([f.due_s for f in got]))


@pytest.fixture(scope="module")
def classifier():
    """A liquid classifier on made-up features: water λ ≈ 0.1-0.3/s, oil λ ≈ 0.9-1.5/s."""
    from liquidtouch.models.training import train_classifier

    rng = np.random.default_rng(0)
    lam = np.concatenate([rng.uniform(0.08, 0.3, 30), rng.uniform(0.9, 1.5, 30)])
    omega = rng.uniform(13.0, 15.0, 60)
    labels = ["water"] * 30 + ["oil"] * 30
    return train_classifier(np.column_stack([lam, omega]), labels)


def test_classifier_probabilities_spread_with_the_std(classifier) -> None:
    from liquidtouch.live.properties import classify_with_fit_std

    ((label, (name, proba)),) = classify_with_fit_std(classifier, 0.15, 0.01, 14.0, 0.01).items()
    assert label == "liquid" and name == "water" and proba["water"] > 0.8
    assert sum(proba.values()) == pytest.approx(1.0)
    # a λ std reaching the other class moves probability to it (0.96 → 0.81 here)
    _, tight = classify_with_fit_std(classifier, 0.3, 0.0, 14.0, 0.01)["liquid"]
    _, loose = classify_with_fit_std(classifier, 0.3, 0.6, 14.0, 0.01)["liquid"]
    assert tight["water"] > 0.9 and loose["water"] < tight["water"] - 0.1


def test_stream_with_a_classifier(trial, classifier) -> None:
    with pytest.raises(ModelFileError, match="liquid"):
        LiveEstimator(["left"], model=classifier, until_std={"liquid": 0.1})  # no std to stop on
    updates = list(live_updates(trial[0], model=classifier))
    final = updates[-1]
    name, proba = final.classified["liquid"]
    assert name == "water" and proba["water"] > 0.5
    out = final.to_dict()
    assert out["predicted_liquid"] == "water"
    shares = [v for k, v in out.items() if k.startswith("probability_")]
    assert len(shares) == len(proba) and sum(shares) == pytest.approx(1.0)
    assert not final.predicted  # a classifier predicts no property
    for update in updates[:-1]:  # a class only once λ and ω are both reported
        assert bool(update.classified) == (
            math.isfinite(update.decay_rate) and math.isfinite(update.angular_frequency)
        )
