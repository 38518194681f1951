"""The Weiss WSG-50 client over its GCL text interface.

The protocol is described in :mod:`liquidtouch.acquire.gripper`.
"""

from __future__ import annotations

import math
import threading
import time

from liquidtouch.acquire.device_link import LineConnection
from liquidtouch.acquire.gripper_base import (
    GRIP_STATES,
    HOLDING,
    MAX_WIDTH_MM,
    _check_grip,
    _check_release,
)
from liquidtouch.errors import DeviceError

GCL_DEFAULT_PORT = 1000
"""The WSG's default TCP port of its command interface."""


class GripperCommandError(DeviceError):
    """The gripper answered a command with ``ERR <code>``."""

    def __init__(self, command: str, code: str):
        self.command, self.code = command, code
        super().__init__(f"the gripper refused {command}: ERR {code}")


class Wsg50Gripper:
    """A Weiss WSG-50 over its GCL text interface (protocol: :mod:`liquidtouch.acquire.gripper`).

    Connecting acknowledges a pending FAST STOP (``FSACK()``). ``ack_timeout_s``
    bounds the wait for a command's ``ACK`` (and query replies); a motion's
    ``FIN`` is awaited for ``motion_timeout_s``, or longer when the commanded
    travel at the commanded speed needs it.
    """

    def __init__(
        self,
        host: str,
        port: int = GCL_DEFAULT_PORT,
        *,
        connect_timeout_s: float = 5.0,
        ack_timeout_s: float = 2.0,
        motion_timeout_s: float = 10.0,
        acknowledge: bool = True,
    ):
        self.url = f"wsg50://{host}:{port}"
        self.ack_timeout_s = float(ack_timeout_s)
        self.motion_timeout_s = float(motion_timeout_s)
        self._lock = threading.RLock()
        self._conn = LineConnection(
            host, port, connect_timeout_s=connect_timeout_s, what=f"gripper at {host}:{port}"
        )
        try:
            if acknowledge:
                self.acknowledge()
        except BaseException:
            self._conn.close()
            raise

    # -- protocol ------------------------------------------------------------------------

    def _next_reply(self, timeout_s: float, waiting_for: str) -> str:
        """The next line that is not an ``@`` autosend value."""
        deadline = time.monotonic() + timeout_s
        while True:
            line = self._conn.read_line(max(deadline - time.monotonic(), 0.0), waiting_for)
            if line and not line.startswith("@"):
                return line

    def _expect(self, command: str, word: str, timeout_s: float) -> None:
        """Wait for ``<word> <command>``; raise on ``ERR`` or any other reply."""
        reply = self._next_reply(timeout_s, f"{word} {command}")
        while command == "STOP" and reply.startswith("ERR E_CMD_ABORTED"):
            # the motion STOP ended is answered first
            reply = self._next_reply(timeout_s, f"{word} {command}")
        if reply == f"{word} {command}":
            return
        if reply.startswith("ERR"):
            code = reply[3:].strip() or "(no code)"
            raise GripperCommandError(command, code)
        self._conn.close()
        raise DeviceError(
            f"unexpected reply {reply!r} from the gripper (expected {word} {command}); "
            "closed the connection"
        )

    def _command(self, call: str, *, motion_timeout_s: float | None = None) -> None:
        """Send ``call`` (e.g. ``GRIP(25.0,60.0,20.0)``); wait for ACK (and FIN if a motion)."""
        name = call.split("(", 1)[0]
        with self._lock:
            self._conn.send_line(call)
            self._expect(name, "ACK", self.ack_timeout_s)
            if motion_timeout_s is not None:
                self._expect(name, "FIN", motion_timeout_s)

    def _query(self, key: str) -> float:
        with self._lock:
            self._conn.send_line(f"{key}?")
            reply = self._next_reply(self.ack_timeout_s, f"{key}=...")
            if reply.startswith("ERR"):
                raise GripperCommandError(f"{key}?", reply[3:].strip() or "(no code)")
            name, sep, value = reply.partition("=")
            if sep and name.strip() == key:
                try:
                    number = float(value)
                except ValueError:
                    number = math.nan
                if math.isfinite(number):
                    return number
            self._conn.close()
            raise DeviceError(
                f"unexpected reply {reply!r} from the gripper to {key}? (expected {key}=<number>)"
            )

    def _travel_timeout(self, travel_mm: float, speed_mm_s: float) -> float:
        return max(self.motion_timeout_s, 2.0 * travel_mm / speed_mm_s + 2.0)

    # -- the Gripper interface -----------------------------------------------------------

    def acknowledge(self) -> None:
        """``FSACK()``; an ``ERR`` reply is ignored: there may be no FAST STOP to acknowledge,
        and a gripper that cannot leave one refuses the next motion command anyway."""
        try:
            self._command("FSACK()")
        except GripperCommandError:
            pass

    def home(self) -> None:
        self._command("HOME()", motion_timeout_s=self._travel_timeout(MAX_WIDTH_MM, 20.0))

    def grip(self, force_n: float, width_mm: float, speed_mm_s: float) -> None:
        force, width, speed = _check_grip(force_n, width_mm, speed_mm_s)
        self._command(
            f"GRIP({force:.2f},{width:.2f},{speed:.2f})",
            motion_timeout_s=self._travel_timeout(MAX_WIDTH_MM, speed),
        )
        state = self.grip_state()
        if state != HOLDING:
            raise DeviceError(
                f"the gripper finished GRIP but is not holding a part (GRIPSTATE={state} "
                f"{GRIP_STATES.get(state, '?')}); check the part width and the bottle's position"
            )

    def release(self, pullback_mm: float, speed_mm_s: float) -> None:
        pullback, speed = _check_release(pullback_mm, speed_mm_s)
        self._command(
            f"RELEASE({pullback:.2f},{speed:.2f})",
            motion_timeout_s=self._travel_timeout(pullback, speed),
        )

    def stop(self) -> None:
        self._command("STOP()")

    def position_mm(self) -> float:
        return self._query("POS")

    def force_n(self) -> float:
        return self._query("FORCE")

    def grip_state(self) -> int:
        return int(self._query("GRIPSTATE"))

    def close(self) -> None:
        """Say ``BYE()`` (so the WSG raises no FAST STOP) and close; never opens the fingers."""
        with self._lock:
            if self._conn.closed:
                return
            try:
                self._conn.send_line("BYE()")
                self._expect("BYE", "ACK", min(self.ack_timeout_s, 1.0))
            except DeviceError:
                pass  # disconnecting anyway; the gripper may already be gone
            finally:
                self._conn.close()

    def __enter__(self) -> Wsg50Gripper:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
