"""Several pushes in one trial (issue 40): back and forth, each hold judged by ``decide``,
and every fail-safe of a single push kept at every push — the gripper never opens in the
air, the arm stops on an error or Ctrl-C during any push, hold or decision.

Devices are the in-process stand-ins (``SimGripper``, ``SimArm``) and a fake recorder.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import pytest

from liquidtouch.acquire.arms import SimArm
from liquidtouch.acquire.grippers import SimGripper
from liquidtouch.acquire.protocol import run_trial
from liquidtouch.acquire.protocol_params import ProtocolParameters, protocol_from_mapping
from liquidtouch.errors import DeviceError, LiquidTouchError

FAST = ProtocolParameters(settle_s=0.0, pre_push_s=0.2, hold_s=2.0, log_interval_s=0.5,
                          max_pushes=3)  # fmt: skip


class Recorder:
    """Records the calls a trial makes; ``check`` runs ``on_check`` (to fail on cue)."""

    def __init__(self, sources, out_dir, *, names, params, labels):
        self.out_dir, self.calls, self.meta, self.on_check = out_dir, [], None, None

    def open(self):
        self.calls.append("open")

    def start(self):
        import time

        self.calls.append("start")
        self.t0 = time.monotonic()

    def check(self):
        if self.on_check is not None:
            self.on_check()

    def stop(self):
        self.calls.append("stop")
        sensor = SimpleNamespace(start_t_s=self.t0)
        return SimpleNamespace(start_t_s=self.t0, sensors={"left": sensor})

    def finish(self, meta=None):
        self.calls.append("finish")
        self.meta = meta
        return self.out_dir

    def abort(self):
        self.calls.append("abort")


def _trial(tmp_path, arm, gripper=None, decide=None, params=FAST, recorders=None):
    made = [] if recorders is None else recorders

    def factory(*args, **kwargs):
        made.append(Recorder(*args, **kwargs))
        return made[-1]

    gripper = SimGripper() if gripper is None else gripper
    run = run_trial(gripper, arm, ["c"], tmp_path / "t", params, recorder_factory=factory,
                    decide=decide)  # fmt: skip
    return run, made[0], gripper


def test_three_pushes_back_and_forth_every_push_kept(tmp_path):
    arm = SimArm()
    asked = []

    def decide(k):
        asked.append(k)
        return True

    run, recorder, gripper = _trial(tmp_path, arm, decide=decide)
    assert asked == [1, 2]  # after the third push: max_pushes, nobody asked
    lifted = [0.4, 0.0, 0.25, 0.0, math.pi, 0.0]
    out = [0.415, 0.0, 0.25, 0.0, math.pi, 0.0]
    # lift, out, back, out, then over the start and down: never beyond one push
    for move, expected in zip(arm.moves[:4], (lifted, out, lifted, out), strict=True):
        assert move == pytest.approx(expected)
    assert [p["distance_mm"] for p in run.pushes] == [15.0, -15.0, 15.0]
    starts = [p["push_start_s"] for p in run.pushes]
    assert starts == sorted(starts) and starts[1] - starts[0] >= FAST.hold_s
    meta = recorder.meta
    assert meta["pushes"] == run.pushes and meta["push_start_s"] == starts[0]
    names = [e["event"] for e in meta["acquisition"]["events"]]
    assert names.count("push") == 3 and names.count("hold_end") == 2
    assert names.count("decided") == 2 and names[-1] == "released"
    assert gripper.log == ["GRIP 25 59 50", "RELEASE 10 20"]


def test_decide_ends_the_trial_and_waits_while_it_cannot_tell(tmp_path):
    answers = iter([None, None, False])  # not judged yet, then: every target met
    run, recorder, _ = _trial(tmp_path, SimArm(), decide=lambda k: next(answers))
    assert len(run.pushes) == 1 and recorder.calls[-1] == "finish"
    events = recorder.meta["acquisition"]["events"]
    decided = [e for e in events if e["event"] == "decided"]
    assert len(decided) == 1 and decided[0]["push_again"] is False
    assert decided[0]["timed_out"] is False


def test_max_pushes_is_checked_before_anything_moves():
    for bad in (0, 11, 2.5):
        with pytest.raises(LiquidTouchError, match="max_pushes"):
            protocol_from_mapping({"max_pushes": bad}, "--max-pushes")
    with pytest.raises(LiquidTouchError, match="container"):
        protocol_from_mapping({"container": "bucket"})


class FailingArm(SimArm):
    """Fails (or is interrupted) on move ``fail_on`` (0 lift, 1 first push, 2 second, ...)."""

    def __init__(self, fail_on: int, error: BaseException):
        super().__init__()
        self.fail_on, self.error, self.calls = fail_on, error, 0

    def move_linear(self, pose, speed_m_s, acceleration_m_s2):
        self.calls += 1
        if self.calls - 1 == self.fail_on:
            raise self.error
        return super().move_linear(pose, speed_m_s, acceleration_m_s2)


def _kept_holding(arm, recorder, gripper, tmp_path):
    assert arm.stops == 1
    assert recorder.calls == ["open", "start", "abort"]
    assert gripper.log == ["GRIP 25 59 50"]  # never released: the bottle is not dropped
    assert gripper.grip_state() == 4
    assert not (tmp_path / "t").exists() and (tmp_path / "t.failed" / "run.json").exists()


@pytest.mark.parametrize("push", [2, 3])
@pytest.mark.parametrize("error", [DeviceError("the arm hit something"), KeyboardInterrupt()],
                         ids=["error", "ctrl-c"])  # fmt: skip
def test_an_error_or_ctrl_c_at_a_later_push(tmp_path, push, error):
    arm, gripper, made = FailingArm(push, error), SimGripper(), []
    with pytest.raises(type(error)):
        _trial(tmp_path, arm, gripper=gripper, decide=lambda k: True, recorders=made)
    _kept_holding(arm, made[0], gripper, tmp_path)


@pytest.mark.parametrize("where", ["second hold", "decision"])
def test_ctrl_c_or_a_slip_in_a_later_hold_or_while_deciding(tmp_path, where):
    arm, gripper, made = SimArm(), SimGripper(), []
    state = {"decisions": 0}

    def decide(k):
        state["decisions"] += 1
        if where == "decision" and k == 1 and state["decisions"] > 3:
            raise KeyboardInterrupt  # Ctrl-C while the live estimate judges the ring-down
        return None if where == "decision" else True

    def check():
        if where == "second hold" and len(arm.moves) == 3:  # lifted, pushed, pushed back
            raise KeyboardInterrupt

    real_factory = Recorder

    def factory(*args, **kwargs):
        made.append(real_factory(*args, **kwargs))
        made[-1].on_check = check
        return made[-1]

    with pytest.raises(KeyboardInterrupt):
        run_trial(gripper, arm, ["c"], tmp_path / "t", FAST, recorder_factory=factory,
                  decide=decide)  # fmt: skip
    _kept_holding(arm, made[0], gripper, tmp_path)


def test_the_bottle_slipping_while_the_estimate_decides(tmp_path):
    class Slipping(SimGripper):
        reads = 0

        def grip_state(self):
            self.reads += 1
            return 3 if self.reads > 8 else super().grip_state()  # PART LOST

    arm, gripper, made = SimArm(), Slipping(), []
    with pytest.raises(DeviceError, match="PART LOST"):
        _trial(tmp_path, arm, gripper=gripper, decide=lambda k: None, recorders=made)
    assert arm.stops == 1 and made[0].calls[-1] == "abort"
    assert gripper.log == ["GRIP 25 59 50"]
