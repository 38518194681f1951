"""run-trial --max-pushes and --plan (issue 40): checked before anything moves (the rig's
command log stays empty), and --plan proposes a push without connecting to anything."""

from __future__ import annotations

import json

import numpy as np
import pytest

from liquidtouch.cli import main
from liquidtouch.sim.rig.rig import RigServer
from liquidtouch.sim.rig.state import Rig


@pytest.fixture(scope="module")
def rig():
    rig = Rig("water", height_mm=30.0, gripper_time_scale=0.05)
    with RigServer(rig, cameras=False) as server:
        yield rig, server.endpoints()


@pytest.fixture(scope="module")
def height_model(tmp_path_factory):
    from liquidtouch.models.modelfile import save_model
    from liquidtouch.models.training import train_regression

    lam, omega = np.meshgrid(np.linspace(0.05, 0.6, 6), np.linspace(8.0, 20.0, 6))
    X = np.column_stack([lam.ravel(), omega.ravel()])
    model = train_regression(X, {"height_mm": 2.0 * X[:, 1] - 3.0}, model="quadratic")
    return save_model(model, tmp_path_factory.mktemp("m") / "height.json")


def test_bad_max_pushes_moves_nothing(rig, height_model, tmp_path, capsys):
    rig, endpoints = rig
    base = ["run-trial", "--gripper", endpoints["gripper"], "--arm", endpoints["arm"],
            "--camera", "http://127.0.0.1:9/a", "--out", str(tmp_path / "trial")]  # fmt: skip
    cases = {
        "zero": (["--max-pushes", "0"], "max_pushes"),
        "too many": (["--max-pushes", "11"], "max_pushes"),
        "without a model": (["--max-pushes", "3"], "needs --model"),
        "without a target": (["--max-pushes", "3", "--model", height_model], "--until-std"),
        "plan without container": (["--plan", "--until-std", "height_mm=0.5"], "container"),
        "plan without target": (["--plan", "--label", "container=cuboid"], "--until-std"),
        "plan, unknown container": (
            ["--plan", "--label", "container=bucket", "--until-std", "height_mm=0.5"],
            "bucket",
        ),
    }
    for case, (extra, said) in cases.items():
        status = main([*base, *map(str, extra)])
        err = capsys.readouterr().err
        assert status == 2 and said.lower() in err.lower() and "Traceback" not in err, (case, err)
        assert rig.commands == [], (case, rig.commands)
        assert not (tmp_path / "trial").exists()


def test_plan_proposes_a_push_without_connecting(rig, tmp_path, capsys):
    rig, endpoints = rig
    protocol = tmp_path / "p.toml"
    protocol.write_text('container = "upright-bottle"\n')
    argv = ["run-trial", "--gripper", endpoints["gripper"], "--arm", endpoints["arm"],
            "--camera", "0", "--out", str(tmp_path / "trial"), "--protocol", str(protocol),
            "--until-std", "height_mm=0.5", "--plan"]  # fmt: skip
    assert main([*argv, "--json"]) == 0
    plan = json.loads(capsys.readouterr().out)
    assert plan["container"] == "upright-bottle" and not plan["reachable"]
    assert "no push of this container's kind" in plan["reason"]
    assert {a["axis"] for a in plan["axes"]} == {"x", "y"}
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "proposed: push along x" in text and 'push_axis = "x"' in text
    assert rig.commands == [] and not (tmp_path / "trial").exists()
