"""The start state (issue 41): a trial interrupted at any step leaves the bottle held where the
arm stopped; the next trial refuses to start from there (saying what and how to fix it), and
``recover`` puts the bottle down — never a release in the air (the rig's ``dropped``).

The gripper and the arm are the simulated rig's, over their real protocols (GCL, the rig's
arm protocol); the recorder is a stand-in (the cameras are not what is tested here).
"""

from __future__ import annotations

import os
import signal
import threading
from pathlib import Path
from types import SimpleNamespace

import pytest

from liquidtouch.acquire.arms import SimArm, open_arm
from liquidtouch.acquire.grippers import SimGripper, open_gripper
from liquidtouch.acquire.protocol import STEPS, run_trial
from liquidtouch.acquire.protocol_params import ProtocolParameters
from liquidtouch.acquire.start_state import (
    StartStateError,
    check_start_state,
    recover_start_state,
)
from liquidtouch.errors import DeviceError
from liquidtouch.protocols import gcl
from liquidtouch.sim.rig.rig import RigServer
from liquidtouch.sim.rig.state import HOME_POSE, Rig

#: a short protocol: 10 mm lift at 0.25 m/s, 2 s hold (the least hold_s allows)
FAST = ProtocolParameters(
    settle_s=0.0, pre_push_s=0.2, hold_s=2.0, log_interval_s=0.5,
    lift_mm=10.0, lift_speed_m_s=0.25, lift_acceleration_m_s2=5.0,
)  # fmt: skip


class StubRecorder:
    """What run_trial asks of a recorder, without cameras."""

    def __init__(self, sources, out_dir, *, names, params, labels, **_):
        self.out_dir = Path(out_dir)
        self.start_t = 0.0

    def open(self):
        pass

    def start(self):
        import time

        self.start_t = time.monotonic()

    def check(self):
        pass

    def stop(self):
        sensor = SimpleNamespace(start_t_s=self.start_t)
        return SimpleNamespace(start_t_s=self.start_t, sensors={"left": sensor})

    def finish(self, meta=None):
        return self.out_dir

    def abort(self):
        pass


def _trial(endpoints, out, *, on_step=None, recover=False):
    with open_gripper(endpoints["gripper"]) as gripper, open_arm(endpoints["arm"]) as arm:
        return run_trial(
            gripper, arm, ["0"], out, FAST, recorder_factory=StubRecorder, on_step=on_step,
            recover=recover,
        )  # fmt: skip


def _state(endpoints, action):
    with open_gripper(endpoints["gripper"]) as gripper, open_arm(endpoints["arm"]) as arm:
        return action(gripper, arm, FAST)


def test_a_clean_start_passes_and_a_held_bottle_is_refused_with_the_fix():
    gripper, arm = SimGripper(), SimArm()
    state = check_start_state(gripper, arm, FAST)
    assert state.at_start() and not state.holding
    gripper.grip(25.0, 59.0, 50.0)
    arm.move_linear([0.4, 0.0, 0.25, 0.0, 3.141592653589793, 0.0], 0.1, 1.0)
    with pytest.raises(StartStateError) as refused:
        check_start_state(gripper, arm, FAST)
    text = str(refused.value)
    assert "holding a part" in text and "in the air" in text and "50.0 mm +z" in text
    assert "--recover" in text and "nothing was moved" in text
    recovered = recover_start_state(gripper, arm, FAST)
    assert recovered.at_start() and not recovered.holding
    # the bottle came down first, then the fingers opened: RELEASE after the last move
    assert arm.pose == list(arm.home) and gripper.log[-1].startswith("RELEASE")


def test_a_fault_and_closed_fingers_are_refused():
    gripper, arm = SimGripper(), SimArm()
    gripper.state = gcl.ERROR
    with pytest.raises(StartStateError, match="fault"):
        check_start_state(gripper, arm, FAST)
    gripper.state, gripper.width_mm = gcl.NO_PART, 40.0
    with pytest.raises(StartStateError, match="narrower than the bottle"):
        check_start_state(gripper, arm, FAST)
    assert recover_start_state(gripper, arm, FAST).finger_mm == gcl.MAX_WIDTH_MM


@pytest.fixture(scope="module")
def rig():
    rig = Rig("water", height_mm=30.0, gripper_time_scale=0.05)
    with RigServer(rig, cameras=False) as server:
        yield rig, server.endpoints()


def _interrupt_at(target: str, delay_s: float | None):
    """An ``on_step`` that Ctrl-Cs at the start of step ``target`` (``delay_s`` None) or
    ``delay_s`` into it (a real SIGINT, so a wait for a device's reply is interrupted)."""

    def on_step(name: str) -> None:
        if name != target:
            return
        if delay_s is None:
            raise KeyboardInterrupt
        threading.Timer(delay_s, os.kill, (os.getpid(), signal.SIGINT)).start()

    return on_step


@pytest.fixture
def ctrl_c_raises():
    """Python's own Ctrl-C handler for the test, as in a terminal: pytest started in the
    background of a non-interactive shell inherits SIGINT ignored, and a real SIGINT then
    did nothing (every ``delay_s`` case failed with "DID NOT RAISE")."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


CASES = [(step, None) for step in STEPS] + [
    ("grasp", 0.01), ("lift", 0.03), ("push", 0.1), ("hold", 0.5), ("return", 0.05),
    ("lower", 0.03), ("release", 0.0),
]  # fmt: skip


@pytest.mark.slow(seconds=60, exclusive=True)  # the rig's arm in real time
@pytest.mark.timeout(300)
@pytest.mark.parametrize(("step", "delay_s"), CASES)
def test_ctrl_c_at_each_step_then_a_new_trial(rig, tmp_path, step, delay_s, ctrl_c_raises):
    rig, endpoints = rig
    out = tmp_path / "trial"
    with pytest.raises(KeyboardInterrupt):
        _trial(endpoints, out, on_step=_interrupt_at(step, delay_s))
        threading.Event().wait(2.0)  # the SIGINT of a step that ended first lands here
    assert not rig.dropped
    held = rig.status()["gripper"]["holding"]
    at_home = max(abs(a - b) for a, b in zip(rig.pose(), HOME_POSE, strict=True)) < 1e-3
    if held or not at_home:
        before = len(rig.commands)
        with pytest.raises(StartStateError) as refused:
            _trial(endpoints, tmp_path / "next")
        text = str(refused.value)
        assert ("holding a part" in text) == held and "--recover" in text
        moved = [c for c in rig.commands[before:] if not c.endswith(("?", "get_pose", "pose"))]
        assert moved in ([], ["gripper FSACK"]), moved  # queries only: nothing moved
    state = _state(endpoints, recover_start_state)
    assert state.at_start() and not state.holding
    assert not rig.dropped and not rig.status()["gripper"]["holding"]
    _state(endpoints, check_start_state)  # the next trial may start


@pytest.mark.slow(seconds=8, exclusive=True)
@pytest.mark.timeout(120)
def test_run_trial_refuses_a_held_bottle_and_recover_puts_it_down(rig, tmp_path, capsys):
    """The CLI: a bottle left lifted → error naming the state and --recover, exit 2; with
    --recover it is carried back, lowered and released before the trial goes on (here it
    then stops at a camera that is not there)."""
    from liquidtouch.cli import main

    rig, endpoints = rig
    with open_gripper(endpoints["gripper"]) as gripper, open_arm(endpoints["arm"]) as arm:
        gripper.grip(25.0, 59.0, 50.0)
        arm.move_linear([0.4, 0.0, 0.25, 0.0, 3.141592653589793, 0.0], 0.25, 5.0)
        arm.move_linear([0.415, 0.0, 0.25, 0.0, 3.141592653589793, 0.0], 0.25, 5.0)
    argv = ["run-trial", "--gripper", endpoints["gripper"], "--arm", endpoints["arm"]]
    argv += ["--camera", "http://127.0.0.1:9/a", "--out", str(tmp_path / "t")]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "holding a part" in err and "in the air" in err and "--recover" in err
    assert "15.0 mm +x" in err and "50.0 mm +z" in err
    assert rig.status()["gripper"]["holding"]
    assert main([*argv, "--recover"]) == 2
    assert "could not be opened" in capsys.readouterr().err  # the camera, after recovering
    assert not rig.dropped and not rig.status()["gripper"]["holding"]
    assert max(abs(a - b) for a, b in zip(rig.pose(), HOME_POSE, strict=True)) < 1e-6


def test_a_grip_that_finds_no_bottle_says_what_to_check(tmp_path):
    gripper, arm = SimGripper(part_width_mm=None), SimArm()
    with pytest.raises(DeviceError, match="is the bottle standing between the open fingers"):
        run_trial(gripper, arm, ["0"], tmp_path / "t", FAST, recorder_factory=StubRecorder)
    assert arm.moves == []  # nothing lifted
