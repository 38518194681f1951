"""The trial protocol: parameters (TOML), the step order, and the safety rules on failure.

Devices are the in-process stand-ins (``SimGripper``, ``SimArm``) and a fake recorder
that records what was asked of it; the real recorder and the simulated rig are in
``test_rig.py``.
"""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace
from typing import ClassVar

import pytest

from liquidtouch.acquire.arms import SimArm
from liquidtouch.acquire.grippers import SimGripper
from liquidtouch.acquire.protocol import run_trial
from liquidtouch.acquire.protocol_params import (
    ProtocolParameters,
    load_protocol,
    protocol_from_mapping,
)
from liquidtouch.errors import DeviceError, LiquidTouchError

FAST = ProtocolParameters(settle_s=0.0, pre_push_s=0.2, hold_s=2.0, log_interval_s=0.5)


class FakeRecorder:
    """Records the calls a trial makes; ``fail_check`` makes ``check()`` raise it."""

    instances: ClassVar[list[FakeRecorder]] = []

    def __init__(self, sources, out_dir, *, names, params, labels):
        self.sources, self.out_dir, self.names = sources, Path(out_dir), names
        self.params, self.labels = params, labels
        self.calls: list[str] = []
        self.meta: dict | None = None
        self.fail_check: BaseException | None = None
        self.start_t = None
        FakeRecorder.instances.append(self)

    def open(self):
        self.calls.append("open")

    def start(self):
        import time

        self.calls.append("start")
        self.start_t = time.monotonic()

    def check(self):
        if self.fail_check is not None:
            raise self.fail_check

    def stop(self):
        self.calls.append("stop")
        sensor = SimpleNamespace(start_t_s=self.start_t + 0.01)
        return SimpleNamespace(start_t_s=self.start_t, sensors={"left": sensor, "right": sensor})

    def finish(self, extra_meta=None):
        self.calls.append("finish")
        self.meta = extra_meta
        return self.out_dir

    def abort(self):
        self.calls.append("abort")


@pytest.fixture(autouse=True)
def _fresh_recorders():
    FakeRecorder.instances.clear()


def test_defaults_are_the_papers():
    params = ProtocolParameters()
    assert params.grasp_force_n == 25.0
    assert params.hold_s == 13.0
    assert params.push_duration_s == pytest.approx(0.25)
    assert params.recording_s == pytest.approx(1.0 + 0.25 + 13.0)


def test_protocol_toml(tmp_path):
    path = tmp_path / "protocol.toml"
    path.write_text("grasp_force_n = 20.0\npush_distance_mm = -12\nhold_s = 10\n")
    params = load_protocol(path)
    assert (params.grasp_force_n, params.push_distance_mm, params.hold_s) == (20.0, -12.0, 10.0)
    for text, match in (
        ("grasp_forse_n = 20\n", "grasp_forse_n"),
        ("grasp_force_n = 200\n", "grasp_force_n"),
        ("push_distance_mm = 0.5\n", "at least 1 mm"),
        ("hold_s = nan\n", "hold_s"),
        ("hold_s = \n", "not valid TOML"),
        ("push_axis = 'z'\n", "push_axis"),
    ):
        path.write_text(text)
        with pytest.raises(LiquidTouchError, match=match):
            load_protocol(path)
    with pytest.raises(LiquidTouchError, match="not found"):
        load_protocol(tmp_path / "missing.toml")
    with pytest.raises(LiquidTouchError, match="--seconds: hold_s"):
        protocol_from_mapping({"hold_s": -1}, "--seconds")


def trial(gripper, arm, tmp_path, params=FAST, **kwargs):
    return run_trial(
        gripper,
        arm,
        ["http://cam/left", "http://cam/right"],
        tmp_path / "trial",
        params,
        {"liquid": "water"},
        recorder_factory=FakeRecorder,
        **kwargs,
    )


def test_a_trial_runs_the_steps_in_order(tmp_path):
    gripper, arm = SimGripper(), SimArm()
    steps: list[str] = []
    run = trial(gripper, arm, tmp_path, on_step=steps.append)
    recorder = FakeRecorder.instances[0]
    assert steps == [
        "check", "cameras", "grasp", "lift", "record", "push", "hold", "stop", "return",
        "lower", "release", "write",
    ]  # fmt: skip
    assert recorder.calls == ["open", "start", "stop", "finish"]
    assert recorder.labels == {"liquid": "water"}
    assert gripper.log == ["GRIP 25 59 50", "RELEASE 10 20"]
    start = [0.4, 0.0, 0.2, 0.0, math.pi, 0.0]
    lifted = [0.4, 0.0, 0.25, 0.0, math.pi, 0.0]
    pushed = [0.415, 0.0, 0.25, 0.0, math.pi, 0.0]
    # the bottle is carried back over its start, then put down where it was picked up
    assert len(arm.moves) == 4
    for move, expected in zip(arm.moves, (lifted, pushed, lifted, start), strict=True):
        assert move == pytest.approx(expected)
    meta = recorder.meta
    assert meta["protocol"]["grasp_force_n"] == 25.0
    poses = meta["acquisition"]["poses"]
    assert poses["start"] == pytest.approx(start) and poses["pushed"] == pytest.approx(pushed)
    readings = meta["acquisition"]["gripper_readings"]
    assert readings[0]["when"] == "grasped" and readings[0]["force_n"] == 25.0
    assert sum(r["when"] == "holding" for r in readings) >= 4  # every 0.5 s over 2 s
    assert readings[-1]["when"] == "released"
    # the push starts ~pre_push_s after the first frame (0.01 s after the start here)
    assert 0.15 < meta["push_start_s"] < 0.6
    assert meta["push_end_s"] >= meta["push_start_s"]
    assert run.trial_dir == tmp_path / "trial"


class FailingArm(SimArm):
    """Fails (or is interrupted) on the move numbered ``fail_on`` (0: lift, 1: push)."""

    def __init__(self, fail_on: int, error: BaseException):
        super().__init__()
        self.fail_on, self.error = fail_on, error
        self.calls = 0

    def move_linear(self, pose, speed_m_s, acceleration_m_s2):
        self.calls += 1
        if self.calls - 1 == self.fail_on:
            raise self.error
        return super().move_linear(pose, speed_m_s, acceleration_m_s2)


@pytest.mark.parametrize(
    "error", [DeviceError("the arm hit something"), KeyboardInterrupt()], ids=["error", "ctrl-c"]
)
def test_a_failure_mid_push_stops_the_arm_keeps_the_grip_and_aborts(tmp_path, error):
    gripper, arm = SimGripper(), FailingArm(1, error)
    with pytest.raises(type(error)):
        trial(gripper, arm, tmp_path)
    recorder = FakeRecorder.instances[0]
    assert arm.stops == 1
    assert recorder.calls == ["open", "start", "abort"]
    assert gripper.log == ["GRIP 25 59 50"]  # never released, never stopped
    assert gripper.grip_state() == 4 and gripper.force_n() == 25.0
    assert not (tmp_path / "trial").exists()


def test_ctrl_c_during_the_hold(tmp_path):
    gripper, arm = SimGripper(), SimArm()

    class Interrupting(FakeRecorder):
        def check(self):
            if "start" in self.calls and len(arm.moves) == 2:  # lifted and pushed
                raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_trial(gripper, arm, ["c"], tmp_path / "t", FAST, recorder_factory=Interrupting)
    assert arm.stops == 1 and gripper.log == ["GRIP 25 59 50"]
    assert FakeRecorder.instances[0].calls == ["open", "start", "abort"]


def test_a_bottle_slipping_out_during_the_hold(tmp_path):
    class Slipping(SimGripper):
        reads = 0

        def grip_state(self):
            self.reads += 1
            return 3 if self.reads > 3 else super().grip_state()  # PART LOST

    gripper, arm = Slipping(), SimArm()
    with pytest.raises(DeviceError, match="PART LOST"):
        trial(gripper, arm, tmp_path)
    assert FakeRecorder.instances[0].calls[-1] == "abort" and arm.stops == 1


def test_a_failed_grasp_never_lifts(tmp_path):
    gripper, arm = SimGripper(part_width_mm=None), SimArm()
    with pytest.raises(DeviceError, match="no part"):
        trial(gripper, arm, tmp_path)
    assert arm.moves == [] and FakeRecorder.instances[0].calls == ["open", "abort"]


def test_a_camera_failure_before_moving(tmp_path):
    class NoCamera(FakeRecorder):
        def open(self):
            raise DeviceError("camera 0 delivers no frames")

    gripper, arm = SimGripper(), SimArm()
    with pytest.raises(DeviceError, match="no frames"):
        run_trial(gripper, arm, ["0"], tmp_path / "t", FAST, recorder_factory=NoCamera)
    assert gripper.log == [] and arm.moves == []


def test_clean_up_goes_on_when_stopping_the_arm_fails(tmp_path, caplog):
    class BrokenStop(FailingArm):
        def stop(self, deceleration_m_s2: float = 2.0):
            raise DeviceError("connection lost")

    with pytest.raises(DeviceError, match="hit"):
        trial(SimGripper(), BrokenStop(1, DeviceError("hit")), tmp_path)
    assert FakeRecorder.instances[0].calls[-1] == "abort"
    assert any(
        r.levelname == "WARNING" and "stopping the arm: DeviceError: connection lost" in r.message
        for r in caplog.records
    )
