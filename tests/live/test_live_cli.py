"""``liquidtouch live``: JSON lines, early stopping on a model target, refused options."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from liquidtouch.cli import main


def _run(capsys: pytest.CaptureFixture[str], *argv: object) -> tuple[int, str, str]:
    status = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


@pytest.fixture(scope="module")
def trial(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, object]:
    """A short simulated mirin trial (6 s, GelSight Mini videos) and its truth.

    Mirin decays in ~1.4 s (λ ≈ 0.7/s), so λ — and with it a model's prediction — is
    reported while streaming; water's λ0 ≈ 0.1/s needs more than 6 s.
    """
    from liquidtouch.sim.trial import simulate_trial
    from liquidtouch.sim.trial_io import write_trial

    simulated = simulate_trial("mirin", height_mm=25.0, seed=4, duration_s=6.0)
    directory = write_trial(simulated, tmp_path_factory.mktemp("live") / "trial", sensor="mini")
    return directory, simulated


@pytest.fixture(scope="module")
def model_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A quadratic model of a made-up target height_mm = 2 ω − 3 [mm] (exact on its grid)."""
    from liquidtouch.models.modelfile import save_model
    from liquidtouch.models.training import train_regression

    lam, omega = np.meshgrid(np.linspace(0.05, 0.6, 8), np.linspace(8.0, 20.0, 8))
    X = np.column_stack([lam.ravel(), omega.ravel()])
    model = train_regression(X, {"height_mm": 2.0 * X[:, 1] - 3.0}, model="quadratic")
    return save_model(model, tmp_path_factory.mktemp("model") / "model.json")


def test_json_lines_and_final(capsys, trial) -> None:
    directory, simulated = trial
    status, out, err = _run(capsys, "live", directory, "--json")
    assert status == 0, err
    lines = [json.loads(line) for line in out.splitlines()]
    assert len(lines) > 5 and lines[-1]["final"] is True
    assert not any(line["final"] for line in lines[:-1])
    for key in (
        "t_s",
        "decay_rate",
        "decay_rate_std",
        "angular_frequency",
        "angular_frequency_std",
    ):
        assert all(key in line for line in lines)
    final = lines[-1]
    assert final["stopped_because"] == "end_of_stream"
    assert final["angular_frequency"] == pytest.approx(simulated.true_angular_frequency, rel=0.005)


def test_until_std_on_a_model_target(capsys, trial, model_file) -> None:
    directory = trial[0]
    status, out, err = _run(
        capsys, "live", directory, "--json", "--model", model_file, "--until-std", "height_mm=0.05"
    )
    assert status == 0, err
    lines = [json.loads(line) for line in out.splitlines()]
    final = lines[-1]
    assert final["stopped_because"] == "until_std"
    last = lines[-2]
    assert last["predicted_height_mm_std"] < 0.05
    # the model is exact, so the prediction is 2 ω − 3 of the streamed ω
    assert last["predicted_height_mm"] == pytest.approx(2 * last["angular_frequency"] - 3, abs=0.01)
    full = _run(capsys, "live", directory, "--json")[1].splitlines()
    assert final["frames"] < json.loads(full[-1])["frames"]
    with_prediction = [line for line in lines if line.get("predicted_height_mm") is not None]
    assert all(math.isfinite(line["predicted_height_mm_std"]) for line in with_prediction)


def test_text_output(capsys, trial) -> None:
    status, out, err = _run(capsys, "live", trial[0], "--until-std", "angular_frequency=0.03")
    assert status == 0, err
    assert "ω =" in out and "stopped: until std" in out.splitlines()[-1]


@pytest.mark.parametrize(
    ("option", "message"),
    [
        ("viscosity_cst=0.5", "unknown target"),
        ("height_mm=-1", "number > 0"),
        ("height_mm", "TARGET=STD"),
    ],
)
def test_bad_until_std(capsys, trial, option, message) -> None:
    status, out, err = _run(capsys, "live", trial[0], "--until-std", option)
    assert status == 2 and out == ""
    assert err.startswith("error:") and message in err


def test_model_without_the_target(capsys, trial, model_file) -> None:
    status, out, err = _run(
        capsys, "live", trial[0], "--model", model_file, "--until-std", "log10_viscosity_cst=0.05"
    )
    assert status == 2 and out == ""
    assert err.startswith("error:") and "height_mm" in err  # names what the model predicts


def test_bad_serve_address(capsys, trial) -> None:
    status, _, err = _run(capsys, "live", trial[0], "--serve", "nowhere")
    assert status == 2 and "HOST:PORT" in err


def test_serve_publishes_updates_and_frames(capsys, trial, monkeypatch) -> None:
    from liquidtouch.live import hub as hub_module

    published: list[dict] = []
    frames: list[tuple[str, tuple, int]] = []

    class RecordingHub(hub_module.LiveHub):
        def publish(self, update: dict) -> None:
            published.append(update)
            super().publish(update)

        def publish_frame(self, sensor, image, reference_px=None, positions_px=None) -> None:
            frames.append((sensor, image.shape, len(positions_px)))
            super().publish_frame(sensor, image, reference_px, positions_px)

    monkeypatch.setattr(hub_module, "LiveHub", RecordingHub)
    status, _, err = _run(
        capsys, "live", trial[0], "--serve", "127.0.0.1:0", "--until-std", "angular_frequency=0.01"
    )
    assert status == 0, err
    assert "http://127.0.0.1:" in err
    assert published and published[-1]["final"] is True
    signal = published[-1]["signal"]
    assert len(signal["t_s"]) == len(signal["u"]) == len(signal["fit"]) > 10
    assert {sensor for sensor, _, _ in frames} == {"left", "right"}
    assert all(n > 0 for _, _, n in frames)  # the tracked markers come with each frame


def test_classifier_model_names_the_liquid(capsys, trial, tmp_path) -> None:
    from liquidtouch.models.modelfile import save_model
    from liquidtouch.models.training import train_classifier

    # made-up features: "thin" λ 0.05-0.3/s, "thick" λ 0.5-1.5/s (mirin's λ ≈ 0.7/s)
    rng = np.random.default_rng(1)
    lam = np.concatenate([rng.uniform(0.05, 0.3, 20), rng.uniform(0.5, 1.5, 20)])
    X = np.column_stack([lam, rng.uniform(10.0, 18.0, 40)])
    model = save_model(train_classifier(X, ["thin"] * 20 + ["thick"] * 20), tmp_path / "c.json")
    status, out, err = _run(capsys, "live", trial[0], "--json", "--model", model)
    assert status == 0, err
    final = json.loads(out.splitlines()[-1])
    assert final["predicted_liquid"] == "thick"
    assert final["probability_thick"] > 0.5
    assert final["probability_thick"] + final["probability_thin"] == pytest.approx(1.0)


def test_linger_keeps_the_final_page_served(capsys, trial, monkeypatch) -> None:
    """--linger: after the stream, the page and its whole history are still served."""
    import urllib.request

    from liquidtouch.cli import live as live_cli

    seen: dict[str, object] = {}
    real_sleep = live_cli.time.sleep

    def fake_sleep(seconds: float) -> None:  # fetch the page while the CLI lingers
        if seconds != 30.0:  # another wait (the server starting)
            return real_sleep(seconds)
        url = seen["url"] = capsys.readouterr().err.split("stays at ")[1].split(" ")[0]
        with urllib.request.urlopen(url, timeout=5) as page:
            seen["page"] = page.status
        with urllib.request.urlopen(url + "stream", timeout=5) as events:
            seen["stream"] = events.read().decode()  # history, then the end: it closes
        seen["seconds"] = seconds

    monkeypatch.setattr(live_cli.time, "sleep", fake_sleep)
    status, _, err = _run(
        capsys, "live", trial[0], "--serve", "127.0.0.1:0", "--linger", "30", "--json"
    )
    assert status == 0, err
    assert seen["seconds"] == 30.0 and seen["page"] == 200
    events = str(seen["stream"])
    assert "event: end" in events and '"final":true' in events  # the whole history, then the end


@pytest.fixture(scope="module")
def plain_trial(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, object]:
    """The same mirin slosh on a markerless gel (``mini-plain``: no printed markers)."""
    from liquidtouch.sim.trial import simulate_trial
    from liquidtouch.sim.trial_io import write_trial

    simulated = simulate_trial("mirin", height_mm=25.0, seed=4, duration_s=6.0)
    out = tmp_path_factory.mktemp("live-plain") / "trial"
    return write_trial(simulated, out, sensor="mini-plain"), simulated


def test_tracking_found_or_forced(capsys, trial, plain_trial) -> None:
    directory, simulated = plain_trial
    status, out, err = _run(capsys, "live", directory, "--json")  # auto: flow on a plain gel
    assert status == 0, err
    final = json.loads(out.splitlines()[-1])
    assert final["angular_frequency"] == pytest.approx(simulated.true_angular_frequency, rel=0.01)
    forced = _run(capsys, "live", directory, "--json", "--tracking", "flow")
    assert forced[0] == 0
    again = json.loads(forced[1].splitlines()[-1])
    assert (again["decay_rate"], again["angular_frequency"]) == (
        final["decay_rate"],
        final["angular_frequency"],
    )
    # markers forced on a gel without any: the marker tracker's refusal, not a number
    status, out, err = _run(capsys, "live", directory, "--tracking", "markers")
    assert status == 2 and out == "" and err.startswith("error:") and "marker" in err
    status, _, err = _run(capsys, "live", trial[0], "--tracking", "dots")
    assert status == 2 and "dots" in err
