"""A TCP server speaking the Weiss WSG-50's text command interface (GCL), for the simulated rig.

The protocol as served (a subset of the WSG's GCL; ``liquidtouch.acquire.gripper`` is
the matching client): one command per ``\\n``-terminated ASCII line.

- Motions ``HOME()``, ``GRIP(force, width, speed)``, ``RELEASE(pullback, speed)``,
  ``MOVE(width, speed)``: ``ACK <CMD>`` at once, then ``FIN <CMD>`` when the fingers
  stop; ``ERR <code>`` instead of the ACK when the command is refused (bad or missing
  parameters, a FAST STOP pending, a motion already running), or instead of the FIN
  when the motion fails (no part found) or is stopped (``E_CMD_ABORTED``).
- ``STOP()``: stops a running motion, ``ACK STOP``. ``FSACK()``: acknowledges a FAST
  STOP, ``ACK FSACK``. ``VERBOSE=1`` / ``VERBOSE=0``: echoed; verbose ERR lines add
  ``: <text>``.
- Queries ``POS?``, ``FORCE?``, ``SPEED?``, ``GRIPSTATE?``: ``<KEY>=<value>``.
- ``BYE()``: ``ACK BYE``, then the server closes the connection. A client that
  disconnects without it raises a FAST STOP, as the real gripper does: motion
  commands are refused (``ERR E_ACCESS_DENIED``) until ``FSACK()``.
- Anything else: ``ERR E_CMD_UNKNOWN``; a malformed call ``ERR E_CMD_FORMAT_ERROR``.

The gripper itself (widths, forces, timing) is a :class:`GripperModel`; the rig's is
``liquidtouch.sim.rig.rig.RigGripper``.
"""

from __future__ import annotations

import contextlib
import re
import socket
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

from liquidtouch.sim.rig.line_server import LineServer

MOTIONS = ("HOME", "GRIP", "RELEASE", "MOVE")
QUERIES = ("POS", "FORCE", "SPEED", "GRIPSTATE")
MAX_LINE = 1024
IDLE_TIMEOUT_S = 3600.0
"""A connection silent this long is closed (every socket wait is bounded)."""

_CALL = re.compile(r"^([A-Z]+)\((.*)\)$")


class GclError(Exception):
    """A GCL error reply: ``ERR <code>`` (``code`` like ``E_RANGE_ERROR``)."""

    def __init__(self, code: str, text: str = ""):
        super().__init__(code)
        self.code, self.text = code, text


@dataclass
class Motion:
    """A finger motion the model has accepted.

    ``run(cancelled)`` blocks until the motion ends (checking the event), raises
    :class:`GclError` if it fails; ``cancel()`` makes the model stop where it is.
    """

    run: Callable[[threading.Event], None]
    cancel: Callable[[], None]


class GripperModel(Protocol):
    """The simulated gripper behind the server."""

    def begin(self, command: str, args: list[float]) -> Motion:
        """Validate and start a motion (``HOME``, ``GRIP``, ...); raise :class:`GclError`."""

    def query(self, key: str) -> float:
        """``POS`` [mm], ``FORCE`` [N], ``SPEED`` [mm/s] or ``GRIPSTATE``."""

    def acknowledge(self) -> None:
        """Clear a FAST STOP."""

    def fast_stop(self) -> None:
        """Raise a FAST STOP (a client left without ``BYE()``)."""


def _format(value: float) -> str:
    return str(int(value)) if float(value).is_integer() and abs(value) < 1e9 else f"{value:.3f}"


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
        text = f": {exc.text}" if self.verbose and exc.text else ""
        self.send(f"ERR {exc.code}{text}")

    def serve(self) -> None:
        buffer = b""
        self.sock.settimeout(IDLE_TIMEOUT_S)
        try:
            while not self.server.stopping.is_set():
                try:
                    chunk = self.sock.recv(4096)
                except TimeoutError:
                    break
                except OSError:
                    break
                if not chunk:
                    break
                buffer += chunk
                if len(buffer) > MAX_LINE and b"\n" not in buffer:
                    self.send("ERR E_CMD_FORMAT_ERROR")
                    break
                while b"\n" in buffer:
                    raw, _, buffer = buffer.partition(b"\n")
                    line = raw.decode("ascii", errors="replace").strip()
                    if line and self.handle(line):
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
            self.server.model.fast_stop()
        with contextlib.suppress(OSError):
            self.sock.close()

    def handle(self, line: str) -> bool:
        """Answer one command line; True when the connection is to be closed."""
        upper = line.upper()
        if upper.startswith("VERBOSE="):
            self.verbose = upper.endswith("1")
            self.send(f"VERBOSE={int(self.verbose)}")
            return False
        if upper.endswith("?") and upper[:-1] in QUERIES:
            try:
                self.send(f"{upper[:-1]}={_format(self.server.model.query(upper[:-1]))}")
            except GclError as exc:
                self.error(exc)
            return False
        match = _CALL.match(upper.replace(" ", ""))
        if match is None:
            self.error(GclError("E_CMD_UNKNOWN", f"unknown command {line[:40]}"))
            return False
        name, arg_text = match.groups()
        try:
            args = [float(a) for a in arg_text.split(",")] if arg_text else []
        except ValueError:
            self.error(GclError("E_CMD_FORMAT_ERROR", "parameters must be numbers"))
            return False
        if name == "BYE":
            self.said_bye = True
            self.send("ACK BYE")
            return True
        if name == "FSACK":
            self.server.model.acknowledge()
            self.send("ACK FSACK")
            return False
        if name == "STOP":
            self.stop_motion()
            self.send("ACK STOP")
            return False
        if name in MOTIONS:
            self.start_motion(name, args)
            return False
        self.error(GclError("E_CMD_UNKNOWN", f"unknown command {name}"))
        return False

    def start_motion(self, name: str, args: list[float]) -> None:
        if self.motion_thread is not None and self.motion_thread.is_alive():
            self.error(GclError("E_ALREADY_RUNNING", "a motion is running; STOP() it first"))
            return
        try:
            motion = self.server.model.begin(name, args)
        except GclError as exc:
            self.error(exc)
            return
        self.motion = motion
        self.cancelled = threading.Event()
        self.send(f"ACK {name}")
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
                self.error(GclError("E_CMD_ABORTED", "stopped"))
            else:
                self.send(f"FIN {name}")
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
        """``wsg50://host:port``, what ``liquidtouch.acquire.gripper.open_gripper`` takes."""
        return f"wsg50://{self.host}:{self.port}"

    def _connection(self, client: socket.socket) -> _Connection:
        return _Connection(self, client)
