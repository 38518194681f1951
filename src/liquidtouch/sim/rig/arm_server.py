"""The simulated rig's arm endpoint: a line-based JSON-over-TCP server.

The protocol is :mod:`liquidtouch.protocols.arm`, shared with its client
:class:`liquidtouch.acquire.arms.RigArm`. One move at a time per connection; the
connection keeps reading while it runs, so ``stop`` can end it.

The arm itself is an :class:`~liquidtouch.sim.rig.interfaces.ArmModel` (the rig's:
``liquidtouch.sim.rig.rig.RigArmModel``).
"""

from __future__ import annotations

import contextlib
import logging
import socket
import threading
from typing import Any

from liquidtouch.protocols import arm as wire
from liquidtouch.protocols.arm import ArmError
from liquidtouch.sim.rig.interfaces import ArmModel, ArmMove
from liquidtouch.sim.rig.line_server import LineServer

__all__ = ["IDLE_TIMEOUT_S", "ArmServer"]

logger = logging.getLogger(__name__)

IDLE_TIMEOUT_S = 3600.0
"""A connection silent this long is closed (every socket wait is bounded)."""


class _Connection:
    def __init__(self, server: ArmServer, sock: socket.socket):
        self.server, self.sock = server, sock
        self.send_lock = threading.Lock()
        self.move: ArmMove | None = None
        self.move_thread: threading.Thread | None = None
        self.cancelled = threading.Event()

    def send(self, message: dict[str, Any]) -> None:
        data = wire.encode_message(message)
        with self.send_lock, contextlib.suppress(OSError):
            self.sock.sendall(data)

    def serve(self) -> None:
        logger.info("rig arm client connected")
        self.send(wire.greeting())
        self.sock.settimeout(IDLE_TIMEOUT_S)
        buffer = b""
        try:
            while not self.server.stopping.is_set():
                try:
                    chunk = self.sock.recv(65536)
                except OSError as exc:  # timeouts included
                    logger.info("rig arm connection ended: %s", exc)
                    break
                if not chunk:
                    break
                buffer += chunk
                if len(buffer) > wire.MAX_LINE_BYTES and b"\n" not in buffer:
                    logger.warning("rig arm client sent a line over %d bytes", wire.MAX_LINE_BYTES)
                    self.send(wire.error_reply(None, "line too long"))
                    break
                while b"\n" in buffer:
                    raw, _, buffer = buffer.partition(b"\n")
                    if raw.strip():
                        self.handle_safely(raw)
        finally:
            self.stop_move()
            with contextlib.suppress(OSError):
                self.sock.close()
            logger.info("rig arm client disconnected")

    def stop_move(self) -> None:
        move, thread = self.move, self.move_thread
        if move is not None:
            self.cancelled.set()
            move.cancel()
        if thread is not None:
            thread.join(timeout=2.0)

    def handle_safely(self, raw: bytes) -> None:
        """:meth:`handle`; anything it did not foresee is answered with an error reply
        (and logged), so that a bad request never ends the connection's thread."""
        try:
            self.handle(raw)
        except Exception as exc:
            logger.warning("rig arm: a request failed: %s: %s", type(exc).__name__, exc)
            logger.debug("rig arm: the failed request", exc_info=True)
            self.send(wire.error_reply(None, f"bad request: {type(exc).__name__}"))

    def handle(self, raw: bytes) -> None:
        request = wire.decode(raw)
        if request is None:
            logger.warning("rig arm: a request that is not a JSON object: %r", raw[:80])
            self.send(wire.error_reply(None, "not a JSON object (or a number out of range)"))
            return
        ident = request.get("id")
        if isinstance(ident, bool) or not isinstance(ident, int):
            logger.warning("rig arm: a request without an integer id: %r", raw[:80])
            self.send(wire.error_reply(None, "id must be an integer"))
            return
        cmd = request.get("cmd")
        model = self.server.model
        logger.debug("rig arm: %s (id %s)", cmd, ident)
        try:
            if cmd == wire.MOVE_L:
                self.start_move(ident, request)
                return
            if cmd == wire.GET_POSE:
                result: dict[str, Any] = {"pose": model.pose()}
            elif cmd == wire.START_POSE:
                result = {"pose": model.start_pose()}
            elif cmd == wire.STOP:
                self.stop_move()
                result = {"pose": model.pose()}
            elif cmd == wire.TRUTH:
                result = {"truth": model.truth()}
            elif cmd == wire.STATUS:
                result = {"status": model.status()}
            else:
                raise ArmError(
                    f"unknown cmd {cmd!r}; use {', '.join(wire.COMMANDS[:-1])} or "
                    f"{wire.COMMANDS[-1]}"
                )
        except ArmError as exc:
            logger.info("rig arm refused %s: %s", cmd, exc)
            self.send(wire.error_reply(ident, str(exc)))
            return
        self.send(wire.ok_reply(ident, **result))

    def start_move(self, ident: int, request: dict[str, Any]) -> None:
        if self.move_thread is not None and self.move_thread.is_alive():
            raise ArmError("a move is running; stop it or wait for its reply")
        pose, speed, accel = request.get("pose"), request.get("speed"), request.get("acceleration")
        if not isinstance(pose, list) or len(pose) != wire.POSE_LENGTH:
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
            logger.info("rig arm move failed: %s", exc)
            self.send(wire.error_reply(ident, str(exc)))
        except Exception as exc:  # the simulation failed: tell the client, keep serving
            logger.exception("rig arm move failed in the simulation")
            self.send(wire.error_reply(ident, f"rig failure: {exc}"))
        else:
            if cancelled.is_set():
                logger.info("rig arm move stopped")
                self.send(wire.error_reply(ident, wire.STOPPED))
            else:
                self.send(wire.ok_reply(ident, pose=pose))
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
        """``sim://host:port``, what ``liquidtouch.acquire.arms.open_arm`` takes."""
        return f"sim://{self.host}:{self.port}"

    def _connection(self, client: socket.socket) -> _Connection:
        return _Connection(self, client)
