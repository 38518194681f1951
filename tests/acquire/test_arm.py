"""The arm clients: UR (against a FAKE of ur_rtde's interface, not the real package or a
robot), the rig's JSON endpoint (against its server on 127.0.0.1) and the sim stand-in."""

from __future__ import annotations

import math
import socket
import threading
import time
import types

import pytest

from liquidtouch.acquire.arms import (
    RigArm,
    SimArm,
    URArm,
    check_move,
    linear_move_duration,
    open_arm,
)
from liquidtouch.errors import DeviceError
from liquidtouch.protocols.arm import ArmError
from liquidtouch.sim.rig.arm_server import ArmServer
from liquidtouch.sim.rig.interfaces import ArmMove

START = [0.4, 0.0, 0.2, 0.0, math.pi, 0.0]


# --- a fake of ur_rtde's RTDEControlInterface / RTDEReceiveInterface ----------------------


class FakeRobot:
    """The state both fake interfaces share: a tool that moves linearly in real time."""

    def __init__(self, *, speed_factor: float = 1.0, stall: bool = False):
        self.pose = list(START)
        self.move = None  # (start, target, t0, duration)
        self.speed_factor, self.stall = speed_factor, stall
        self.calls: list[tuple] = []
        self.protective_stop = False
        self.refuse = False

    def current(self) -> list[float]:
        if self.move is None:
            return list(self.pose)
        start, target, t0, duration = self.move
        f = 1.0 if duration <= 0 else min((time.monotonic() - t0) / duration, 1.0)
        if self.stall:
            f = min(f, 0.5)
        pose = [a + f * (b - a) for a, b in zip(start, target, strict=True)]
        if f >= 1.0:
            self.pose, self.move = pose, None
        return pose


def fake_modules(robot: FakeRobot):
    class Control:
        def __init__(self, host):
            robot.calls.append(("connect", host))

        def moveL(self, pose, speed, acceleration, asynchronous=False):
            robot.calls.append(("moveL", list(pose), speed, acceleration, asynchronous))
            if robot.refuse:
                return False
            start = robot.current()
            duration = linear_move_duration(math.dist(start[:3], pose[:3]), speed, acceleration)
            robot.move = (start, list(pose), time.monotonic(), duration * robot.speed_factor)
            return True

        def getAsyncOperationProgress(self):
            robot.current()
            return -1 if robot.move is None or (robot.stall and self._stalled()) else 0

        def _stalled(self):
            _, _, t0, duration = robot.move
            return time.monotonic() - t0 > duration

        def stopL(self, a=10.0):
            robot.calls.append(("stopL", a))
            robot.pose, robot.move = robot.current(), None

        def stopScript(self):
            robot.calls.append(("stopScript",))

        def disconnect(self):
            robot.calls.append(("disconnect",))

    class Receive:
        def __init__(self, host):
            pass

        def getActualTCPPose(self):
            return robot.current()

        def isProtectiveStopped(self):
            return robot.protective_stop

        def disconnect(self):
            pass

    return (
        types.SimpleNamespace(RTDEControlInterface=Control),
        types.SimpleNamespace(RTDEReceiveInterface=Receive),
    )


def ur_arm(robot: FakeRobot, **options) -> URArm:
    return URArm("192.0.2.1", modules=fake_modules(robot), **options)


def test_linear_move_duration():
    assert linear_move_duration(0.015, 0.1, 1.0) == pytest.approx(0.25)  # 0.15 s cruise + 0.1
    assert linear_move_duration(0.004, 0.1, 1.0) == pytest.approx(2 * math.sqrt(0.004))
    assert linear_move_duration(0.0, 0.1, 1.0) == 0.0


def test_moves_are_checked():
    for target, speed, accel, match in (
        ([0.4, 0, 0.6, 0, 0, 0], 0.1, 1.0, "more than 300 mm"),
        (START, 2.0, 1.0, "speed"),
        (START, 0.1, 0.0, "acceleration"),
        ([0.4, 0, float("nan"), 0, 0, 0], 0.1, 1.0, "finite"),
        ([0.4, 0, 0.2], 0.1, 1.0, "6"),
    ):
        with pytest.raises(DeviceError, match=match):
            check_move(START, target, speed, accel)


def test_ur_move_runs_async_and_waits_for_arrival():
    robot = FakeRobot()
    arm = ur_arm(robot)
    target = [0.415, 0.0, 0.2, 0.0, math.pi, 0.0]
    start = time.monotonic()
    pose = arm.move_linear(target, 0.1, 1.0)
    assert time.monotonic() - start >= 0.24
    assert pose == pytest.approx(target)
    assert robot.calls[1] == ("moveL", target, 0.1, 1.0, True)
    assert arm.get_pose() == pytest.approx(target)
    arm.close()
    assert ("stopScript",) in robot.calls and ("disconnect",) in robot.calls


def test_ur_move_that_never_arrives_is_stopped():
    robot = FakeRobot(stall=True)
    arm = ur_arm(robot, move_margin_s=2.0)
    with pytest.raises(DeviceError, match="short of the target"):
        arm.move_linear([0.405, 0.0, 0.2, 0.0, math.pi, 0.0], 0.1, 1.0)
    assert robot.calls[-1][0] == "stopL"


def test_ur_move_past_its_time_limit_is_stopped():
    robot = FakeRobot(speed_factor=20.0)
    arm = ur_arm(robot, move_margin_s=0.2)
    with pytest.raises(DeviceError, match="did not finish"):
        arm.move_linear([0.405, 0.0, 0.2, 0.0, math.pi, 0.0], 0.1, 1.0)
    assert robot.calls[-1][0] == "stopL"


def test_ur_interrupted_move_is_stopped():
    robot = FakeRobot()
    arm = ur_arm(robot)
    modules = fake_modules(robot)

    def interrupt(self):
        raise KeyboardInterrupt

    arm._control.getAsyncOperationProgress = types.MethodType(interrupt, arm._control)
    with pytest.raises(KeyboardInterrupt):
        arm.move_linear([0.405, 0.0, 0.2, 0.0, math.pi, 0.0], 0.1, 1.0)
    assert robot.calls[-1][0] == "stopL"
    assert modules  # the fake, not ur_rtde, was used


def test_ur_refusals():
    robot = FakeRobot()
    arm = ur_arm(robot)
    robot.protective_stop = True
    with pytest.raises(DeviceError, match="protective stop"):
        arm.move_linear([0.405, 0.0, 0.2, 0.0, math.pi, 0.0], 0.1, 1.0)
    robot.protective_stop, robot.refuse = False, True
    with pytest.raises(DeviceError, match="refused the moveL"):
        arm.move_linear([0.405, 0.0, 0.2, 0.0, math.pi, 0.0], 0.1, 1.0)


def test_ur_rtde_urls(monkeypatch):
    import builtins

    real_import = builtins.__import__

    def no_ur_rtde(name, *args, **kwargs):
        if name in ("rtde_control", "rtde_receive"):
            raise ImportError(name)
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_ur_rtde)
    with pytest.raises(DeviceError, match=r"liquidtouch\[robot\]"):
        open_arm("ur-rtde://192.0.2.1")
    with pytest.raises(DeviceError, match="without a port"):
        open_arm("ur-rtde://192.0.2.1:30004")
    with pytest.raises(DeviceError, match="sim://HOST:PORT"):
        open_arm("sim://127.0.0.1")
    assert isinstance(open_arm("sim://"), SimArm)


# --- the rig's arm endpoint -------------------------------------------------------------


class FakeArmModel:
    """A minimal ``ArmModel``: moves take ``duration`` seconds, targets with x > 1 fail."""

    def __init__(self, duration: float = 0.05):
        self.duration = duration
        self._pose = list(START)

    def begin_move(self, pose, speed, acceleration):
        if pose[0] > 1.0:
            raise ArmError("out of reach")

        def run(cancelled: threading.Event):
            if not cancelled.wait(self.duration):
                self._pose = list(pose)
            return list(self._pose)

        return ArmMove(run=run, cancel=lambda: None)

    def pose(self):
        return list(self._pose)

    def truth(self):
        return {"true_decay_rate": 0.5, "true_angular_frequency": 14.0}

    def status(self):
        return {"ok": True}


@pytest.fixture
def arm_server():
    servers = []

    def start(model):
        server = ArmServer(model).start()
        servers.append(server)
        return server

    yield start
    for server in servers:
        server.stop()


def test_rig_arm_moves_and_answers(arm_server):
    server = arm_server(FakeArmModel())
    with open_arm(server.url) as arm:
        assert isinstance(arm, RigArm)
        target = [0.41, 0.0, 0.2, 0.0, math.pi, 0.0]
        assert arm.move_linear(target, 0.1, 1.0) == pytest.approx(target)
        assert arm.get_pose() == pytest.approx(target)
        assert arm.truth()["true_decay_rate"] == 0.5
        assert arm.status() == {"ok": True}


def test_rig_arm_refusal_and_stop(arm_server):
    model = FakeArmModel(duration=30.0)
    server = arm_server(model)
    with RigArm("127.0.0.1", server.port, reply_timeout_s=0.3) as arm:
        # a move that never ends: the client gives up, stops it, and says so
        with pytest.raises(DeviceError, match=r"did not answer.*moveL"):
            arm.move_linear([0.41, 0.0, 0.2, 0.0, math.pi, 0.0], 0.1, 1.0)
        assert arm.get_pose() == pytest.approx(START)  # stopped where it was
        model.duration = 0.01
        arm.move_linear([0.42, 0.0, 0.2, 0.0, math.pi, 0.0], 0.1, 1.0)  # stale replies skipped
    with RigArm("127.0.0.1", server.port) as arm, pytest.raises(DeviceError, match="out of reach"):
        arm.request("moveL", pose=[1.1, 0, 0.2, 0, 0, 0], speed=0.1, acceleration=1.0)


def test_rig_arm_protocol_errors(arm_server):
    server = arm_server(FakeArmModel())
    with socket.create_connection(("127.0.0.1", server.port), timeout=5.0) as sock:
        reader = sock.makefile("rb")
        assert b"liquidtouch-rig-arm" in reader.readline()
        for request, match in (
            (b"not json\n", b"not a JSON object"),
            (b'{"cmd": "get_pose"}\n', b"id must be an integer"),
            (b'{"id": 1, "cmd": "fly"}\n', b"unknown cmd"),
            (b'{"id": 2, "cmd": "moveL", "pose": [1, 2]}\n', b"6 numbers"),
        ):
            sock.sendall(request)
            assert match in reader.readline()


def test_not_a_rig_arm():
    with socket.create_server(("127.0.0.1", 0)) as listener:
        listener.settimeout(5.0)
        port = listener.getsockname()[1]

        def greet():
            conn, _ = listener.accept()
            with conn:
                conn.sendall(b'{"server": "something-else"}\n')
                conn.recv(10)

        thread = threading.Thread(target=greet, daemon=True)
        thread.start()
        with pytest.raises(DeviceError, match="not a liquidtouch rig arm"):
            RigArm("127.0.0.1", port)
        thread.join(timeout=5.0)


def test_sim_arm():
    arm = SimArm()
    arm.move_linear([0.4, 0.0, 0.25, 0.0, math.pi, 0.0], 0.05, 0.5)
    assert arm.get_pose()[2] == 0.25
    arm.stop()
    assert arm.stops == 1
