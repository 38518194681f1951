"""run-trial --max-pushes on the simulated rig (issue 40): rig serve (subprocess) → run-trial
in process with a live model → several pushes, each ring-down final and kept, combined;
the bottle put back down and released. Real time (~30 s): one run."""

from __future__ import annotations

import json

import numpy as np
import pytest

from liquidtouch.cli import main
from liquidtouch.testing.rig_runs import rig_serving


@pytest.mark.slow(seconds=60, exclusive=True)  # a rig in real time
@pytest.mark.timeout(300)
def test_several_pushes_on_the_rig(tmp_path, capsys):
    from liquidtouch.models.modelfile import save_model
    from liquidtouch.models.training import train_regression

    # an exact height model (2ω − 3 mm); the target is λ's std: water's ±0.015 1/s from one
    # 3 s hold (λ ≈ 0.13 1/s) must come down to 0.009, which takes about three pushes
    lam, omega = np.meshgrid(np.linspace(0.05, 0.6, 6), np.linspace(8.0, 20.0, 6))
    X = np.column_stack([lam.ravel(), omega.ravel()])
    model = save_model(
        train_regression(X, {"height_mm": 2.0 * X[:, 1] - 3.0}, model="quadratic"),
        tmp_path / "height.json",
    )
    protocol = tmp_path / "fast.toml"
    protocol.write_text("settle_s = 0.0\npre_push_s = 0.5\nhold_s = 3.0\nlog_interval_s = 0.5\n")
    out = tmp_path / "trial"
    with rig_serving(liquid="water", height_mm=30.0, seed=1) as endpoints:
        argv = ["run-trial", "--gripper", endpoints["gripper"], "--arm", endpoints["arm"]]
        for url in endpoints["cameras"].values():
            argv += ["--camera", url]
        argv += ["--out", str(out), "--protocol", str(protocol), "--model", str(model),
                 "--until-std", "decay_rate=0.009", "--max-pushes", "3", "--json"]  # fmt: skip
        assert main(argv) == 0
        result = json.loads(capsys.readouterr().out)
    truth = endpoints["truth"]
    live = json.loads((out / "live.json").read_text())
    pushes = result["pushes"]
    decisions = live["decisions"]
    print(f"rig pushes: {len(pushes)}; decisions {decisions}; combined {live['combined']}")
    assert (
        1 <= len(pushes) <= 3 and [p["distance_mm"] for p in pushes] == [15, -15, 15][: len(pushes)]
    )
    assert len(decisions) == len(pushes) - (len(pushes) == 3)  # none after the last allowed
    assert all(d["push_again"] for d in decisions[:-1])
    # every push's ring-down final and kept, and all of them combined
    assert [s["segment"] for s in live["segments"]] == list(range(1, len(pushes) + 1))
    combined = live["combined"]
    assert combined["ring_downs"] == len(pushes)
    omega = truth["true_angular_frequency"]
    assert abs(combined["angular_frequency"] / omega - 1) < 0.003
    height = combined["predicted"]["height_mm"]
    assert abs(height[0] - (2 * combined["angular_frequency"] - 3)) < 1e-6
    meta = json.loads((out / "meta.json").read_text())
    assert meta["pushes"] == pushes
    events = [e["event"] for e in meta["acquisition"]["events"]]
    assert events.count("push") == len(pushes) and events[-1] == "released"
