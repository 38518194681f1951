"""run-trial checks every option before a robot moves (issue 41): a bad one is ``error:`` and
exit 2, and the simulated rig's command log stays empty — nothing reached the gripper or
the arm, not even a query."""

from __future__ import annotations

import numpy as np
import pytest

from liquidtouch.cli import main
from liquidtouch.sim.rig.rig import RigServer
from liquidtouch.sim.rig.state import Rig


@pytest.fixture(scope="module")
def rig():
    """The rig's gripper and arm on loopback (no cameras: nothing may get that far)."""
    rig = Rig("water", height_mm=30.0, gripper_time_scale=0.05)
    with RigServer(rig, cameras=False) as server:
        yield rig, server.endpoints()


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    """A regression model of height_mm (quadratic, exact) and a liquid classifier."""
    from liquidtouch.models.modelfile import save_model
    from liquidtouch.models.training import train_classifier, train_regression

    where = tmp_path_factory.mktemp("models")
    lam, omega = np.meshgrid(np.linspace(0.05, 0.6, 6), np.linspace(8.0, 20.0, 6))
    X = np.column_stack([lam.ravel(), omega.ravel()])
    height = save_model(
        train_regression(X, {"height_mm": 2.0 * X[:, 1] - 3.0}, model="quadratic"),
        where / "height.json",
    )
    labels = np.where(X[:, 0] < 0.3, "thin", "thick")
    classifier = save_model(train_classifier(X, labels), where / "liquid.json")
    return {"height": height, "liquid": classifier}


def _bad_options(tmp_path, models):
    protocol = tmp_path / "typo.toml"
    protocol.write_text("hieght_mm = 1\n")
    full = tmp_path / "full"
    full.mkdir()
    (full / "x").write_text("x")
    return {
        "until-std typo": (["--model", models["height"], "--until-std", "hieght_mm=0.5"], "hieght"),
        "until-std not a number": (["--until-std", "decay_rate=abc"], "number"),
        "until-std without a model": (["--until-std", "height_mm=0.5"], "give --model"),
        "classifier with a regression target": (
            ["--model", models["liquid"], "--until-std", "height_mm=0.5"],
            "classifier",
        ),
        "model file missing": (["--model", tmp_path / "none.json"], "no such model file"),
        "model file not a model": (["--model", protocol], "model"),
        "protocol key typo": (["--protocol", protocol], "hieght_mm"),
        "seconds below the protocol's": (["--seconds", "1"], "hold_s"),
        "seconds nan": (["--seconds", "nan"], "finite"),
        "sensor": (["--sensor", "gelsight9"], "gelsight9"),
        "serve address": (["--serve", "nowhere"], "HOST:PORT"),
        "names": (["--name", "a"], "--name"),
        "label": (["--label", "novalue"], "KEY=VALUE"),
        "timeout": (["--open-timeout", "-1"], "timeout"),
        "out not empty": (["--out", full], "not empty"),
        "camera typo": (["--camera", tmp_path / "nocam.mp4"], "camera source"),
        "one camera twice": (["--camera", "0", "--camera", "0"], "same camera"),
        "tracking without a live estimate": (["--tracking", "flow"], "--live"),
        "tracking typo": (["--live", "--tracking", "dots"], "dots"),
        "markers without a live estimate": (["--markers", "100"], "--live"),
        "markers below one": (["--live", "--markers", "0"], "n_markers"),
    }


def test_a_bad_option_moves_nothing(rig, models, tmp_path, capsys):
    rig, endpoints = rig
    base = ["run-trial", "--gripper", endpoints["gripper"], "--arm", endpoints["arm"]]
    cameras = ["--camera", "http://127.0.0.1:9/a", "--camera", "http://127.0.0.1:9/b"]
    for case, (extra, said) in _bad_options(tmp_path, models).items():
        out = [] if "--out" in extra else ["--out", str(tmp_path / "trial")]
        own = [] if "--camera" in extra else cameras
        status = main([*base, *own, *out, *map(str, extra)])
        err = capsys.readouterr().err
        assert status == 2, (case, err)
        assert err.startswith("error:") or "Error" in err, (case, err)
        assert said.lower() in err.lower(), (case, err)
        assert "Traceback" not in err, case
        assert rig.commands == [], (case, rig.commands)
        assert not (tmp_path / "trial").exists() and not (tmp_path / "trial.failed").exists()


def test_the_live_line_is_rounded_and_has_the_height():
    from liquidtouch.cli.rig import live_line

    final = {
        "decay_rate": 0.71234567890123, "decay_rate_std": 0.0123456789,
        "angular_frequency": 13.3456789012345, "angular_frequency_std": 0.00456789,
        "predicted_height_mm": 25.123456789, "predicted_height_mm_std": 0.8765432,
        "segment": 1, "message": "",
    }  # fmt: skip
    line = live_line(final)
    assert "λ = 0.712 ± 0.012 1/s" in line and "ω = 13.3457 ± 0.0046 rad/s" in line
    assert "height_mm = 25.12 ± 0.88" in line and "456789" not in line
    assert live_line({"error": "no frames"}) == "live: the estimate failed: no frames"


def test_live_with_a_classifier_and_a_property_target_says_why(models, capsys):
    status = main(["live", "0", "--model", str(models["liquid"]), "--until-std", "height_mm=1"])
    err = capsys.readouterr().err
    assert status == 2 and "is a classifier" in err and "without --model" not in err


def test_markers_reach_the_live_estimate(monkeypatch):
    import liquidtouch.live as live
    from liquidtouch.cli.live_trial import LiveTrial
    from liquidtouch.signal.tactile import DEFAULT_N_MARKERS

    seen = {}

    def fake_updates(frames, **options):
        seen.update(options)
        return iter(())

    monkeypatch.setattr(live, "live_updates", fake_updates)
    trial = LiveTrial(["left", "right"], n_markers=40)
    trial._run()
    assert seen["n_markers"] == 40 and seen["tracking"] == trial.tracking
    assert LiveTrial(["left", "right"]).n_markers == DEFAULT_N_MARKERS  # as extract's
