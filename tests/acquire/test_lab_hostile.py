"""Issue 26, hostile input on the lab path: every number is range-checked where it enters,
every server thread answers bad input with an error reply, the CLI says ``error:`` (exit 2).

Loopback only; every socket wait has a timeout.
"""

from __future__ import annotations

import json
import socket

import numpy as np
import pytest

from liquidtouch.acquire.arms import RigArm
from liquidtouch.cli import main
from liquidtouch.errors import DeviceError
from liquidtouch.protocols import arm, gcl
from liquidtouch.sim.rig.arm_server import ArmServer
from liquidtouch.sim.rig.gcl_server import GclServer
from liquidtouch.sim.rig.rig import RigGripper
from liquidtouch.sim.rig.state import Rig


def _run(capsys, *argv: object) -> tuple[int, str]:
    status = main([str(a) for a in argv])
    return status, capsys.readouterr().err


def _one_error_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    return lines[0]


def test_fit_refuses_a_signal_beyond_range(tmp_path, capsys) -> None:
    """|u| ≈ 1e160 raised OverflowError (a traceback, exit 1)."""
    t = np.arange(0, 8, 1 / 30)
    path = tmp_path / "u.csv"
    np.savetxt(
        path,
        np.c_[t, 1e160 * np.exp(-0.3 * t) * np.cos(14 * t)],
        delimiter=",",
        header="t,u",
        comments="",
    )
    status, err = _run(capsys, "fit", path)
    assert status == 2 and "beyond ±1e+12" in _one_error_line(err)


def _marker_csv(path, scale: float = 1.0, t_scale: float | None = None) -> None:
    rows = []
    for f in range(90):
        for r in range(3):
            for c in range(3):
                x0, y0 = 10.0 + 20 * c, 10.0 + 20 * r
                d = 0.5 * np.cos(14 * f / 30)
                row = [f, r, c, x0 * scale, y0 * scale, (x0 + d) * scale, y0 * scale]
                rows.append(row + ([f / 30 * t_scale] if t_scale is not None else []))
    header = "frame,row,col,x0,y0,x,y" + (",t_s" if t_scale is not None else "")
    np.savetxt(path, np.array(rows), delimiter=",", header=header, comments="")


@pytest.mark.parametrize(
    ("scale", "t_scale", "fps", "message"),
    [
        (1e300, None, "30", "beyond ±1e+06 px"),
        (1.0, 1e-300, None, "at least 1e-06 s apart"),
        (1.0, None, "1e300", "up to 1e+06"),
        (1.0, 0.5, None, "holds 90 frames over 1.48 s; the fit needs at least 20 frames over 2 s"),
    ],
)
def test_dataset_add_refuses_marker_tracks_beyond_range(
    tmp_path, capsys, scale, t_scale, fps, message
) -> None:
    """They were added, then crashed `extract` (OverflowError, LinAlgError); tracks shorter
    than the fit's shortest signal were added, then failed `features`."""
    root = tmp_path / "data"
    assert main(["dataset", "init", str(root)]) == 0
    csv = tmp_path / "m.csv"
    _marker_csv(csv, scale, t_scale)
    status, err = _run(
        capsys, "dataset", "add", root, "--markers", csv, *(["--fps", fps] if fps else [])
    )
    assert status == 2 and message in _one_error_line(err)
    assert sorted(p.name for p in root.iterdir()) == [".liquidtouch-dataset"]


def test_arm_lines_with_huge_numbers_or_deep_nesting_are_not_json_objects() -> None:
    assert arm.decode('{"id": 1, "pose": [' + "9" * 5000 + "]}") is None
    assert arm.decode("[" * 60_000 + "]" * 60_000) is None
    assert arm.decode('{"a": ' * 60_000 + "1" + "}" * 60_000) is None
    assert arm.decode('{"x": 1e999}') is None and arm.decode('{"x": NaN}') is None
    assert arm.decode('{"id": 3, "cmd": "get_pose"}') == {"id": 3, "cmd": "get_pose"}


class _Model:
    """An arm model whose truth is whatever the test says."""

    def __init__(self, truth: object) -> None:
        self._truth = truth

    def begin_move(self, pose, speed, acceleration):
        raise arm.ArmError("no moves here")

    def pose(self):
        return [0.3, 0.0, 0.2, 0.0, 3.14, 0.0]

    def truth(self):
        return self._truth

    def status(self):
        return {}


def _lines(sock: socket.socket, n: int) -> list[dict]:
    data = b""
    while data.count(b"\n") < n:
        chunk = sock.recv(65536)
        if not chunk:
            break
        data += chunk
    return [json.loads(line) for line in data.splitlines()[:n]]


def test_the_rig_arm_answers_a_60000_deep_line_and_keeps_serving() -> None:
    """The connection's thread died on RecursionError, without a reply."""
    with ArmServer(_Model({})) as server:
        with socket.create_connection(("127.0.0.1", server.port), timeout=5.0) as sock:
            assert _lines(sock, 1)[0]["server"] == arm.SERVER_NAME
            sock.sendall(b"[" * 60_000 + b"\n")
            sock.sendall(b'{"id": 7, "cmd": "get_pose"}\n')
            bad, good = _lines(sock, 2)
    assert bad["ok"] is False and bad["id"] is None
    assert good == {"id": 7, "ok": True, "pose": [0.3, 0.0, 0.2, 0.0, 3.14, 0.0]}


@pytest.mark.parametrize(
    ("truth", "message"),
    [
        ({}, "no valid true_decay_rate"),
        ({"true_decay_rate": 0.2, "true_angular_frequency": 1e300}, "no valid"),
        ("water", "not a JSON object"),
    ],
)
def test_run_trial_checks_the_rig_arms_truth(truth, message) -> None:
    model = _Model(truth)
    with ArmServer(model) as server, RigArm("127.0.0.1", server.port) as client:
        with pytest.raises(DeviceError, match=message):
            client.truth()


def test_the_simulated_gripper_refuses_numbers_python_would_take() -> None:
    """`MOVE(1_0_0, 5_0)` was read as MOVE(100, 50)."""
    assert gcl.parse_args("1_0_0,5_0") is None
    assert gcl.parse_args("inf") is None and gcl.parse_args("0x10") is None
    assert gcl.parse_args("1" * 40) is None and gcl.parse_args("1,") is None
    assert gcl.parse_args("25.00,59,-1.5e2,.5") == [25.0, 59.0, -150.0, 0.5]
    rig = Rig("water", height_mm=25.0, gripper_time_scale=0.01)
    with GclServer(RigGripper(rig)) as server:  # as `rig serve` runs it
        with socket.create_connection(("127.0.0.1", server.port), timeout=5.0) as sock:
            sock.sendall(b"MOVE(1_0_0, 5_0)\n")
            reply = sock.recv(4096).decode()
    assert reply.startswith(f"ERR {gcl.E_CMD_FORMAT_ERROR}"), reply
    assert rig.width_mm == gcl.MAX_WIDTH_MM  # it did not move


@pytest.mark.parametrize("linger", ["inf", "nan", "1e9", "-1"])
def test_live_linger_is_range_checked(tmp_path, capsys, linger) -> None:
    status, err = _run(capsys, "live", tmp_path, "--linger", linger)
    assert status == 2 and "--linger must be 0 to 86400 s" in _one_error_line(err)


def test_a_100_kb_value_gives_a_short_error_line(tmp_path, capsys) -> None:
    """A 100 KB label gave a 100 054-byte error line; values are cut to 80 characters."""
    root = tmp_path / "data"
    assert main(["dataset", "init", str(root)]) == 0
    capsys.readouterr()
    video = tmp_path / "left.mp4"
    video.write_bytes(b"x" * 100)
    for extra in (["-l", "liquid=" + "x" * 100_000], ["--name", "y" * 100_000]):
        status, err = _run(capsys, "dataset", "add", root, video, *extra)
        line = _one_error_line(err)
        assert status == 2 and len(line) < 400, len(line)


@pytest.mark.parametrize("command", [["record"], ["run-trial"], ["live"]])
def test_camera_commands_share_sensor_and_deadline_options(capsys, command) -> None:
    assert main([*command, "--help"]) == 0
    text = capsys.readouterr().out
    for flag in ("--sensor", "--open-timeout", "--read-timeout", "--warmup-timeout"):
        assert flag in text, (command, flag)
    if command == ["live"]:
        assert "wrench" not in text  # --lowpass: the markers only
