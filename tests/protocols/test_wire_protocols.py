"""The wire protocols are written once: client (acquire) and server (sim.rig) share them.

``liquidtouch.protocols`` holds the WSG-50's GCL, the rig's arm protocol and the MJPEG
stream format; the clients in ``liquidtouch.acquire`` and the simulated rig's servers in
``liquidtouch.sim.rig`` use the same module objects, and neither side imports the other
or writes the protocol's words itself.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import liquidtouch
import liquidtouch.acquire.arms.rig as arm_client
import liquidtouch.acquire.cameras.mjpeg as mjpeg_client
import liquidtouch.acquire.grippers as grippers
import liquidtouch.acquire.grippers.base as gripper_base
import liquidtouch.acquire.grippers.wsg50 as gcl_client
import liquidtouch.sim.rig.arm_server as arm_server
import liquidtouch.sim.rig.fingers as fingers
import liquidtouch.sim.rig.gcl_server as gcl_server
import liquidtouch.sim.rig.mjpeg as mjpeg_server
import liquidtouch.sim.rig.state as rig_state
from liquidtouch.protocols import arm, gcl, mjpeg

SRC = Path(liquidtouch.__file__).resolve().parent
SIDES = {"client": SRC / "acquire", "server": SRC / "sim" / "rig"}

# the protocols' own words: written in liquidtouch/protocols/ only (docstrings aside)
WIRE_WORDS = (
    "liquidtouch-rig-arm",
    "liquidtouchframe",
    "multipart/x-mixed-replace",
    "X-Timestamp",
    "x-timestamp",
    *gcl.ERROR_CODES,
)


def test_client_and_server_use_the_same_protocol_modules():
    assert gcl_client.gcl is gcl and gcl_server.gcl is gcl and fingers.gcl is gcl
    assert gripper_base.gcl is gcl and rig_state.gcl is gcl
    assert arm_client.wire is arm and arm_server.wire is arm
    assert mjpeg_client.mjpeg is mjpeg and mjpeg_server.wire is mjpeg
    # the shared objects themselves, not copies
    assert grippers.GRIP_STATES is gcl.GRIP_STATES
    assert fingers.GclError is gcl.GclError and gcl_server.GclError is gcl.GclError
    assert rig_state.ArmError is arm.ArmError and arm_server.ArmError is arm.ArmError
    assert fingers.OPEN_WIDTH_MM == grippers.MAX_WIDTH_MM == gcl.MAX_WIDTH_MM


def _modules(root: Path):
    for path in sorted(root.rglob("*.py")):
        yield path, ast.parse(path.read_text(encoding="utf-8"))


def _imported(tree: ast.AST) -> set[str]:
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module:
            names.add(node.module)
            names.update(f"{node.module}.{a.name}" for a in node.names)
        elif isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
    return names


def _docstrings(tree: ast.AST) -> set[int]:
    """The string statements: docstrings of modules, classes, functions and attributes."""
    return {
        id(node.value)
        for node in ast.walk(tree)
        if isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant)
    }


@pytest.mark.parametrize("side", sorted(SIDES))
def test_the_protocol_words_are_written_only_in_the_protocol_modules(side):
    found = []
    for path, tree in _modules(SIDES[side]):
        docs = _docstrings(tree)
        for node in ast.walk(tree):
            if isinstance(node, ast.Constant) and isinstance(node.value, str):
                if id(node) in docs:
                    continue
                found += [
                    f"{path.relative_to(SRC)}:{node.lineno}: {word!r}"
                    for word in WIRE_WORDS
                    if word in node.value
                ]
    assert found == []


def test_the_rig_and_the_lab_path_do_not_import_each_other():
    for path, tree in _modules(SIDES["server"]):
        assert not any(n.startswith("liquidtouch.acquire") for n in _imported(tree)), path
    for path, tree in _modules(SIDES["client"]):
        assert not any(n.startswith("liquidtouch.sim") for n in _imported(tree)), path
    # the rig's state raises the protocols' errors: it does not import its own servers
    for name in ("state.py", "fingers.py"):
        tree = ast.parse((SIDES["server"] / name).read_text(encoding="utf-8"))
        imported = _imported(tree)
        assert not any(n.endswith(("gcl_server", "arm_server")) for n in imported), name


def test_the_protocol_modules_import_only_the_ground_floor():
    for path, tree in _modules(SRC / "protocols"):
        own = {n for n in _imported(tree) if n.startswith("liquidtouch")}
        assert all(
            n.startswith(("liquidtouch.errors", "liquidtouch._core", "liquidtouch.protocols"))
            for n in own
        ), (path, own)


def test_gcl_lines_round_trip():
    assert gcl.call(gcl.GRIP, 25, 59, 50) == "GRIP(25.00,59.00,50.00)"
    assert gcl.call(gcl.BYE) == "BYE()"
    assert gcl.parse_call("grip(25.00, 59.00,50.00)") == ("GRIP", "25.00,59.00,50.00")
    assert gcl.parse_call("GRIP 25") is None
    assert gcl.reply(gcl.ACK, gcl.HOME) == "ACK HOME"
    assert gcl.error_reply(gcl.E_RANGE_ERROR) == "ERR E_RANGE_ERROR"
    assert gcl.error_reply(gcl.E_RANGE_ERROR, "force") == "ERR E_RANGE_ERROR: force"
    assert gcl.error_code("ERR E_RANGE_ERROR: force") == "E_RANGE_ERROR: force"
    assert gcl.error_code("ERR") == "(no code)" and gcl.error_code("ACK GRIP") is None
    assert gcl.query_reply("POS", 59.0) == "POS=59" and gcl.query_reply("POS", 59.25) == (
        "POS=59.250"
    )
    assert gcl.parse_query_reply("POS=59.250", "POS") == "59.250"
    assert gcl.parse_query_reply("FORCE=3", "POS") is None


def test_arm_and_mjpeg_messages():
    assert arm.greeting() == {"server": "liquidtouch-rig-arm", "protocol": 2}
    assert arm.encode_request(3, arm.GET_POSE) == '{"id": 3, "cmd": "get_pose"}'
    assert arm.encode_message(arm.ok_reply(3, pose=[0.0])) == (
        b'{"id": 3, "ok": true, "pose": [0.0]}\n'
    )
    assert arm.decode(b"[1]") is None and arm.decode("{") is None
    assert mjpeg.content_type() == "multipart/x-mixed-replace; boundary=liquidtouchframe"
    assert mjpeg.part_head(5, 1.5) == (
        b"--liquidtouchframe\r\nContent-Type: image/jpeg\r\nContent-Length: 5\r\n"
        b"X-Timestamp: 1.500000\r\n\r\n"
    )
    assert mjpeg.parse_boundary(mjpeg.content_type()) == mjpeg.BOUNDARY
    assert mjpeg.parse_boundary('multipart/x-mixed-replace; boundary="--b"') == "b"
    assert mjpeg.parse_boundary("image/jpeg") is None
