"""A TCP server speaking the Weiss WSG-50's text command interface (GCL), for the simulated rig.

The protocol (a subset of the WSG's GCL) is :mod:`liquidtouch.protocols.gcl`, shared
with its client :class:`liquidtouch.acquire.grippers.Wsg50Gripper`. One motion at a
time per connection, run on a worker thread so that ``STOP()`` can end it; a client
that disconnects without ``BYE()`` raises a FAST STOP, as the real gripper does.

The gripper itself (widths, forces, timing) is a
:class:`~liquidtouch.sim.rig.interfaces.GripperModel`; the rig's is
``liquidtouch.sim.rig.rig.RigGripper``.
"""

from __future__ import annotations

import contextlib
import logging
import socket
import threading

from liquidtouch.protocols import gcl
from liquidtouch.protocols.gcl import GclError
from liquidtouch.sim.rig.interfaces import GripperModel, Motion
from liquidtouch.sim.rig.line_server import LineServer

__all__ = ["IDLE_TIMEOUT_S", "MAX_LINE", "GclServer"]

logger = logging.getLogger(__name__)

MAX_LINE = 1024
"""The longest command line accepted [bytes]."""
IDLE_TIMEOUT_S = 3600.0
"""A connection silent this long is closed (every socket wait is bounded)."""


def _peer(sock: socket.socket) -> str:
    try:
        host, port = sock.getpeername()[:2]
    except OSError:
        return "?"
    return f"{host}:{port}"


class _Connection:
    """One client: reads lines, runs at most one motion at a time in a worker thread."""

    def __init__(self, server: GclServer, sock: socket.socket):
        self.server, self.sock = server, sock
        self.send_lock = threading.Lock()
        self.verbose = False
        self.motion: Motion | None = None
        self.motion_thread: threading.Thread | None = None
        self.cancelled = threading.Event()
        self.said_bye = False

    def send(self, line: str) -> None:
        with self.send_lock, contextlib.suppress(OSError):
            self.sock.sendall(line.encode("ascii") + b"\n")

    def error(self, exc: GclError) -> None:
        logger.debug("GCL: ERR %s (%s)", exc.code, exc.text)
        self.send(gcl.error_reply(exc.code, exc.text if self.verbose else ""))

    def serve(self) -> None:
        buffer = b""
        logger.info("GCL client connected from %s", _peer(self.sock))
        self.sock.settimeout(IDLE_TIMEOUT_S)
        try:
            while not self.server.stopping.is_set():
                try:
                    chunk = self.sock.recv(4096)
                except TimeoutError:
                    logger.info("GCL client idle for %g s: closed", IDLE_TIMEOUT_S)
                    break
                except OSError as exc:
                    logger.debug("GCL connection: %s", exc)
                    break
                if not chunk:
                    break
                buffer += chunk
                if len(buffer) > MAX_LINE and b"\n" not in buffer:
                    logger.warning("GCL client sent a line over %d bytes: closed", MAX_LINE)
                    self.send(gcl.error_reply(gcl.E_CMD_FORMAT_ERROR))
                    break
                while b"\n" in buffer:
                    raw, _, buffer = buffer.partition(b"\n")
                    line = raw.decode("ascii", errors="replace").strip()
                    if line and self.handle_safely(line):
                        return
        finally:
            self.close()

    def stop_motion(self) -> None:
        """Stop a running motion; its command is answered ``ERR E_CMD_ABORTED`` first."""
        motion, thread = self.motion, self.motion_thread
        if motion is not None:
            self.cancelled.set()
            motion.cancel()
        if thread is not None:
            thread.join(timeout=2.0)

    def close(self) -> None:
        self.stop_motion()
        if not self.said_bye and not self.server.stopping.is_set():
            logger.warning("GCL client left without BYE(): FAST STOP raised")
            self.server.model.fast_stop()
        else:
            logger.info("GCL client disconnected")
        with contextlib.suppress(OSError):
            self.sock.close()

    def handle_safely(self, line: str) -> bool:
        """:meth:`handle`; anything it did not foresee is answered ``ERR E_CMD_FORMAT_ERROR``
        (and logged), so that a bad command never ends the connection's thread."""
        try:
            return self.handle(line)
        except Exception as exc:
            logger.warning("GCL: a command failed: %s: %s", type(exc).__name__, exc)
            logger.debug("GCL: the failed command", exc_info=True)
            self.error(GclError(gcl.E_CMD_FORMAT_ERROR, f"bad command: {type(exc).__name__}"))
            return False

    def handle(self, line: str) -> bool:
        """Answer one command line; True when the connection is to be closed."""
        upper = line.upper()
        if upper.startswith("VERBOSE="):
            self.verbose = upper.endswith("1")
            self.send(f"VERBOSE={int(self.verbose)}")
            return False
        if upper.endswith("?") and upper[:-1] in gcl.QUERIES:
            key = upper[:-1]
            try:
                self.send(gcl.query_reply(key, self.server.model.query(key)))
            except GclError as exc:
                self.error(exc)
            return False
        call = gcl.parse_call(line)
        if call is None:
            self.error(GclError(gcl.E_CMD_UNKNOWN, f"unknown command {line[:40]}"))
            return False
        name, arg_text = call
        args = gcl.parse_args(arg_text)
        if args is None:
            self.error(GclError(gcl.E_CMD_FORMAT_ERROR, "parameters must be decimal numbers"))
            return False
        logger.debug("GCL: %s(%s)", name, arg_text)
        if name == gcl.BYE:
            self.said_bye = True
            self.send(gcl.reply(gcl.ACK, gcl.BYE))
            return True
        if name == gcl.FSACK:
            self.server.model.acknowledge()
            self.send(gcl.reply(gcl.ACK, gcl.FSACK))
            return False
        if name == gcl.STOP:
            self.stop_motion()
            self.send(gcl.reply(gcl.ACK, gcl.STOP))
            return False
        if name in gcl.MOTIONS:
            self.start_motion(name, args)
            return False
        self.error(GclError(gcl.E_CMD_UNKNOWN, f"unknown command {name}"))
        return False

    def start_motion(self, name: str, args: list[float]) -> None:
        if self.motion_thread is not None and self.motion_thread.is_alive():
            self.error(GclError(gcl.E_ALREADY_RUNNING, "a motion is running; STOP() it first"))
            return
        try:
            motion = self.server.model.begin(name, args)
        except GclError as exc:
            self.error(exc)
            return
        self.motion = motion
        self.cancelled = threading.Event()
        self.send(gcl.reply(gcl.ACK, name))
        self.motion_thread = threading.Thread(
            target=self._run_motion, args=(name, motion, self.cancelled), daemon=True
        )
        self.motion_thread.start()

    def _run_motion(self, name: str, motion: Motion, cancelled: threading.Event) -> None:
        try:
            motion.run(cancelled)
        except GclError as exc:
            self.error(exc)
        else:
            if cancelled.is_set():
                self.error(GclError(gcl.E_CMD_ABORTED, "stopped"))
            else:
                self.send(gcl.reply(gcl.FIN, name))
        finally:
            if self.motion is motion:
                self.motion = None


class GclServer(LineServer):
    """Serve ``model`` over the GCL on ``host:port`` (``port=0``: any free port).

    ``start()`` binds and starts the accept thread; ``stop()`` closes everything.
    ``port`` holds the bound port after ``start()``.
    """

    thread_name = "rig-gcl"
    model: GripperModel

    def __init__(self, model: GripperModel, *, host: str = "127.0.0.1", port: int = 0):
        super().__init__(model, host=host, port=port)

    @property
    def url(self) -> str:
        """``wsg50://host:port``, what ``liquidtouch.acquire.grippers.open_gripper`` takes."""
        return f"wsg50://{self.host}:{self.port}"

    def _connection(self, client: socket.socket) -> _Connection:
        return _Connection(self, client)
