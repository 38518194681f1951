"""The WSG-50 gripper client against scripted GCL servers (127.0.0.1), and the sim backend.

Each scripted server answers the lines it receives from a script (a function of the
line returning the replies to send, with optional delays, or ``CLOSE`` to hang up),
and records what it received.
"""

from __future__ import annotations

import logging
import socket
import threading
import time

import pytest

from liquidtouch.acquire.device_link import parse_device_url
from liquidtouch.acquire.grippers import (
    GCL_DEFAULT_PORT,
    GripperCommandError,
    SimGripper,
    Wsg50Gripper,
    open_gripper,
)
from liquidtouch.errors import DeviceError

CLOSE = object()


class ScriptedGcl:
    """A one-connection TCP server on 127.0.0.1 answering each line by ``script(line)``."""

    def __init__(self, script):
        self.script = script
        self.received: list[str] = []
        self.sock = socket.create_server(("127.0.0.1", 0))
        self.sock.settimeout(5.0)
        self.port = self.sock.getsockname()[1]
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def _serve(self) -> None:
        try:
            conn, _ = self.sock.accept()
        except OSError:
            return
        conn.settimeout(5.0)
        buffer = b""
        with conn:
            while True:
                try:
                    chunk = conn.recv(1024)
                except OSError:
                    return
                if not chunk:
                    return
                buffer += chunk
                while b"\n" in buffer:
                    raw, _, buffer = buffer.partition(b"\n")
                    line = raw.decode().strip()
                    self.received.append(line)
                    for reply in self.script(line):
                        if reply is CLOSE:
                            return
                        if isinstance(reply, float):
                            time.sleep(reply)
                            continue
                        conn.sendall(reply.encode() + b"\n")

    def close(self) -> None:
        self.sock.close()
        self.thread.join(timeout=5.0)


def well_behaved(line: str) -> list:
    """A WSG that does everything asked: ACK, FIN for motions; holding after GRIP."""
    name = line.split("(")[0]
    if line.endswith("?"):
        key = line[:-1]
        return [{"POS": "POS=59.5", "FORCE": "FORCE=24.8", "GRIPSTATE": "GRIPSTATE=4"}[key]]
    if name in ("HOME", "GRIP", "RELEASE", "MOVE"):
        return [f"ACK {name}", 0.02, f"FIN {name}"]
    return [f"ACK {name}"]


@pytest.fixture
def serve():
    servers: list[ScriptedGcl] = []

    def start(script):
        server = ScriptedGcl(script)
        servers.append(server)
        return server

    yield start
    for server in servers:
        server.close()


def connect(server: ScriptedGcl, **options) -> Wsg50Gripper:
    options.setdefault("ack_timeout_s", 0.5)
    options.setdefault("motion_timeout_s", 1.0)
    return Wsg50Gripper("127.0.0.1", server.port, **options)


def test_grip_sends_the_commands_and_waits_for_ack_then_fin(serve):
    server = serve(well_behaved)
    with connect(server) as gripper:
        gripper.grip(25.0, 59.0, 50.0)
        assert gripper.position_mm() == 59.5
        assert gripper.force_n() == 24.8
        gripper.release(10.0, 20.0)
    assert server.received == [
        "FSACK()",
        "GRIP(25.00,59.00,50.00)",
        "GRIPSTATE?",
        "POS?",
        "FORCE?",
        "RELEASE(10.00,20.00)",
        "BYE()",
    ]


def test_the_client_logs_its_connection_and_the_protocol_errors(serve, caplog):
    def script(line):
        if line.startswith("GRIP"):
            return ["ERR E_RANGE_ERROR"]
        return well_behaved(line)

    caplog.set_level(logging.DEBUG, logger="liquidtouch.acquire")
    server = serve(script)
    with connect(server) as gripper, pytest.raises(GripperCommandError):
        gripper.grip(25.0, 59.0, 50.0)
    messages = [(r.name, r.levelname, r.getMessage()) for r in caplog.records]
    where = "liquidtouch.acquire.grippers.wsg50"
    assert (where, "INFO", f"connected to the gripper at 127.0.0.1:{server.port}") in messages
    assert (where, "DEBUG", "gripper <- GRIP(25.00,59.00,50.00)") in messages
    assert (where, "INFO", "gripper: GRIP answered ERR E_RANGE_ERROR") in messages


def test_fin_before_ack_is_a_protocol_error(serve):
    def script(line):
        if line.startswith("GRIP"):
            return ["FIN GRIP", "ACK GRIP"]
        return well_behaved(line)

    with connect(serve(script)) as gripper, pytest.raises(DeviceError, match="unexpected reply"):
        gripper.grip(25.0, 59.0, 50.0)


def test_err_instead_of_ack_names_the_code(serve):
    def script(line):
        return ["ERR E_RANGE_ERROR"] if line.startswith("GRIP") else well_behaved(line)

    with connect(serve(script)) as gripper:
        with pytest.raises(GripperCommandError, match="E_RANGE_ERROR") as info:
            gripper.grip(25.0, 59.0, 50.0)
        assert info.value.code == "E_RANGE_ERROR"


def test_err_instead_of_fin_fails_the_motion(serve):
    def script(line):
        if line.startswith("GRIP"):
            return ["ACK GRIP", 0.05, "ERR E_CMD_FAILED: no part found"]
        return well_behaved(line)

    with connect(serve(script)) as gripper, pytest.raises(GripperCommandError, match="E_CMD"):
        gripper.grip(25.0, 59.0, 50.0)


def test_a_grip_that_holds_nothing_is_an_error(serve):
    def script(line):
        return ["GRIPSTATE=2"] if line == "GRIPSTATE?" else well_behaved(line)

    with connect(serve(script)) as gripper, pytest.raises(DeviceError, match="NO PART"):
        gripper.grip(25.0, 59.0, 50.0)


def test_no_ack_times_out(serve):
    def script(line):
        return [] if line.startswith("GRIP") else well_behaved(line)

    with connect(serve(script), ack_timeout_s=0.3) as gripper:
        start = time.monotonic()
        with pytest.raises(DeviceError, match=r"did not answer within 0\.3 s"):
            gripper.grip(25.0, 59.0, 50.0)
        assert time.monotonic() - start < 2.0


def test_no_fin_times_out(serve):
    def script(line):
        return ["ACK GRIP"] if line.startswith("GRIP") else well_behaved(line)

    gripper = connect(serve(script), motion_timeout_s=0.3)
    # the travel at 420 mm/s needs under the 0.3 s floor: the floor applies
    with gripper, pytest.raises(DeviceError, match="FIN GRIP"):
        gripper._command("GRIP(25.00,59.00,420.00)", motion_timeout_s=0.3)


def test_a_server_that_closes_mid_command(serve):
    def script(line):
        return ["ACK GRIP", CLOSE] if line.startswith("GRIP") else well_behaved(line)

    gripper = connect(serve(script))
    with pytest.raises(DeviceError, match="closed the connection"):
        gripper.grip(25.0, 59.0, 50.0)
    gripper.close()  # nothing left to say BYE to: no error


def test_autosend_lines_are_skipped(serve):
    def script(line):
        if line == "POS?":
            return ["@POS=12.0", "@FORCE=1.0", "POS=58.25"]
        return well_behaved(line)

    with connect(serve(script)) as gripper:
        assert gripper.position_mm() == 58.25


def test_a_malformed_query_reply(serve):
    def script(line):
        return ["POS=abc"] if line == "POS?" else well_behaved(line)

    with connect(serve(script)) as gripper, pytest.raises(DeviceError, match="POS=<number>"):
        gripper.position_mm()


def test_fsack_refused_is_not_fatal(serve):
    def script(line):
        return ["ERR E_ACCESS_DENIED"] if line == "FSACK()" else well_behaved(line)

    with connect(serve(script)) as gripper:
        assert gripper.grip_state() == 4


def test_stop_skips_the_aborted_motion_reply(serve):
    def script(line):
        return ["ERR E_CMD_ABORTED", "ACK STOP"] if line == "STOP()" else well_behaved(line)

    with connect(serve(script)) as gripper:
        gripper.stop()


def test_close_says_bye_and_never_releases(serve):
    server = serve(well_behaved)
    gripper = connect(server)
    gripper.close()
    gripper.close()
    assert server.received == ["FSACK()", "BYE()"]


def test_bad_arguments_are_refused_before_sending(serve):
    server = serve(well_behaved)
    with connect(server) as gripper:
        for args in ((0.0, 59.0, 50.0), (25.0, 200.0, 50.0), (25.0, 59.0, float("nan"))):
            with pytest.raises(DeviceError):
                gripper.grip(*args)
    assert not any(line.startswith("GRIP") for line in server.received)


def test_unreachable_gripper():
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]  # bound, not listening: the connection is refused
        with pytest.raises(DeviceError, match="cannot connect"):
            Wsg50Gripper("127.0.0.1", port, connect_timeout_s=1.0)


def test_urls():
    address = parse_device_url("wsg50://192.168.1.20", ("wsg50", "sim"), "gripper URL")
    assert (address.scheme, address.host, address.port) == ("wsg50", "192.168.1.20", None)
    assert GCL_DEFAULT_PORT == 1000
    for bad, match in (
        ("192.168.1.20", "not a URL"),
        ("ftp://x", "unknown gripper URL scheme"),
        ("wsg50://x:99999", "bad port"),
        ("wsg50://x/path", "path"),
        ("wsg50://", "no host"),
        ("sim://127.0.0.1:1000", "takes no address"),
    ):
        with pytest.raises(DeviceError, match=match):
            open_gripper(bad)
    assert isinstance(open_gripper("sim://"), SimGripper)


def test_sim_gripper():
    gripper = SimGripper(part_width_mm=59.0)
    gripper.grip(25.0, 60.0, 50.0)
    assert (gripper.grip_state(), gripper.position_mm(), gripper.force_n()) == (4, 59.0, 25.0)
    gripper.release(10.0, 20.0)
    assert (gripper.grip_state(), gripper.position_mm(), gripper.force_n()) == (0, 69.0, 0.0)
    with pytest.raises(DeviceError, match="no part"):
        SimGripper(part_width_mm=None).grip(25.0, 60.0, 50.0)
