"""The simulated rig's arm endpoint: a line-based JSON-over-TCP protocol.

One JSON object per ``\\n``-terminated line, UTF-8. On connecting the server sends
``{"server": "liquidtouch-rig-arm", "protocol": 1}``. Each request carries an ``id``
(any integer the client chooses) and a ``cmd``; its reply carries the same ``id``,
``"ok": true`` plus the result, or ``"ok": false`` plus an ``"error"`` text.

- ``{"cmd": "moveL", "pose": [x, y, z, rx, ry, rz], "speed": v, "acceleration": a}``:
  a straight move of the tool (metres, rotation vector in radians, m/s, m/s²); the
  reply (``"pose"``) comes when the move has ended. One move at a time per
  connection; the connection keeps reading while it runs, so ``stop`` can end it.
- ``{"cmd": "get_pose"}``: ``"pose"``.
- ``{"cmd": "stop", "acceleration": a}``: stops a running move (whose request then
  fails with ``"stopped"``); ``"pose"``.
- ``{"cmd": "truth"}``: ``"truth"``, the simulated liquid's ground truth and labels.
- ``{"cmd": "status"}``: ``"status"``, the rig's state.

``liquidtouch.acquire.arm.RigArm`` is the client. The arm itself is an
:class:`ArmModel` (the rig's: ``liquidtouch.sim.rig.rig.RigArmModel``).
"""

from __future__ import annotations

import contextlib
import json
import socket
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

from liquidtouch.sim.rig.line_server import LineServer

PROTOCOL = 1
SERVER_NAME = "liquidtouch-rig-arm"
MAX_LINE = 65536
IDLE_TIMEOUT_S = 3600.0


class ArmError(Exception):
    """A refused or failed arm request (its text is the reply's ``error``)."""


@dataclass
class ArmMove:
    """An accepted move: ``run(cancelled)`` blocks until it ends and returns the pose."""

    run: Callable[[threading.Event], list[float]]
    cancel: Callable[[], None]


class ArmModel(Protocol):
    """The simulated arm behind the server."""

    def begin_move(self, pose: list[float], speed: float, acceleration: float) -> ArmMove:
        """Validate and start a move; raise :class:`ArmError`."""

    def pose(self) -> list[float]:
        """The tool pose now."""

    def truth(self) -> dict[str, Any]:
        """Ground truth and labels of the simulated liquid."""

    def status(self) -> dict[str, Any]:
        """The rig's state."""


class _Connection:
    def __init__(self, server: ArmServer, sock: socket.socket):
        self.server, self.sock = server, sock
        self.send_lock = threading.Lock()
        self.move: ArmMove | None = None
        self.move_thread: threading.Thread | None = None
        self.cancelled = threading.Event()

    def send(self, message: dict[str, Any]) -> None:
        data = json.dumps(message, allow_nan=False).encode() + b"\n"
        with self.send_lock, contextlib.suppress(OSError):
            self.sock.sendall(data)

    def serve(self) -> None:
        self.send({"server": SERVER_NAME, "protocol": PROTOCOL})
        self.sock.settimeout(IDLE_TIMEOUT_S)
        buffer = b""
        try:
            while not self.server.stopping.is_set():
                try:
                    chunk = self.sock.recv(65536)
                except OSError:  # timeouts included
                    break
                if not chunk:
                    break
                buffer += chunk
                if len(buffer) > MAX_LINE and b"\n" not in buffer:
                    self.send({"id": None, "ok": False, "error": "line too long"})
                    break
                while b"\n" in buffer:
                    raw, _, buffer = buffer.partition(b"\n")
                    if raw.strip():
                        self.handle(raw)
        finally:
            self.stop_move()
            with contextlib.suppress(OSError):
                self.sock.close()

    def stop_move(self) -> None:
        move, thread = self.move, self.move_thread
        if move is not None:
            self.cancelled.set()
            move.cancel()
        if thread is not None:
            thread.join(timeout=2.0)

    def handle(self, raw: bytes) -> None:
        try:
            request = json.loads(raw)
        except (json.JSONDecodeError, UnicodeDecodeError):
            request = None
        if not isinstance(request, dict):
            self.send({"id": None, "ok": False, "error": "not a JSON object"})
            return
        ident = request.get("id")
        if isinstance(ident, bool) or not isinstance(ident, int):
            self.send({"id": None, "ok": False, "error": "id must be an integer"})
            return
        cmd = request.get("cmd")
        model = self.server.model
        try:
            if cmd == "moveL":
                self.start_move(ident, request)
                return
            if cmd == "get_pose":
                result: dict[str, Any] = {"pose": model.pose()}
            elif cmd == "stop":
                self.stop_move()
                result = {"pose": model.pose()}
            elif cmd == "truth":
                result = {"truth": model.truth()}
            elif cmd == "status":
                result = {"status": model.status()}
            else:
                raise ArmError(f"unknown cmd {cmd!r}; use moveL, get_pose, stop, truth or status")
        except ArmError as exc:
            self.send({"id": ident, "ok": False, "error": str(exc)})
            return
        self.send({"id": ident, "ok": True, **result})

    def start_move(self, ident: int, request: dict[str, Any]) -> None:
        if self.move_thread is not None and self.move_thread.is_alive():
            raise ArmError("a move is running; stop it or wait for its reply")
        pose, speed, accel = request.get("pose"), request.get("speed"), request.get("acceleration")
        if not isinstance(pose, list) or len(pose) != 6:
            raise ArmError("pose must be a list of 6 numbers")
        try:
            values = [float(v) for v in pose]
            speed, accel = float(speed), float(accel)
        except (TypeError, ValueError):
            raise ArmError("pose, speed and acceleration must be numbers") from None
        move = self.server.model.begin_move(values, speed, accel)
        self.move, self.cancelled = move, threading.Event()
        self.move_thread = threading.Thread(
            target=self._run, args=(ident, move, self.cancelled), name="rig-arm-move", daemon=True
        )
        self.move_thread.start()

    def _run(self, ident: int, move: ArmMove, cancelled: threading.Event) -> None:
        try:
            pose = move.run(cancelled)
        except ArmError as exc:
            self.send({"id": ident, "ok": False, "error": str(exc)})
        except Exception as exc:  # the simulation failed: tell the client, keep serving
            self.send({"id": ident, "ok": False, "error": f"rig failure: {exc}"})
        else:
            if cancelled.is_set():
                self.send({"id": ident, "ok": False, "error": "stopped"})
            else:
                self.send({"id": ident, "ok": True, "pose": pose})
        finally:
            if self.move is move:
                self.move = None


class ArmServer(LineServer):
    """Serve ``model`` on ``host:port`` (``port=0``: any free port); ``port`` set by ``start()``."""

    thread_name = "rig-arm"
    model: ArmModel

    def __init__(self, model: ArmModel, *, host: str = "127.0.0.1", port: int = 0):
        super().__init__(model, host=host, port=port)

    @property
    def url(self) -> str:
        """``sim://host:port``, what ``liquidtouch.acquire.arm.open_arm`` takes."""
        return f"sim://{self.host}:{self.port}"

    def _connection(self, client: socket.socket) -> _Connection:
        return _Connection(self, client)
