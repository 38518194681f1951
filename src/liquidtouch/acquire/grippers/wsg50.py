"""The Weiss WSG-50 client over its GCL text interface (:mod:`liquidtouch.protocols.gcl`).

Every wait has a timeout; a timeout, an ``ERR``, an unexpected reply or a closed
connection raises :class:`~liquidtouch.errors.DeviceError`. A client that disconnects
without ``BYE()`` makes the WSG raise a FAST STOP, so :meth:`Wsg50Gripper.close`
always says ``BYE()`` first (it never opens the fingers: a held bottle stays held).
"""

from __future__ import annotations

import logging
import math
import threading
import time

from liquidtouch.acquire.device_link import LineConnection
from liquidtouch.acquire.grippers.base import check_grip, check_release
from liquidtouch.errors import DeviceError
from liquidtouch.protocols import gcl

__all__ = ["GripperCommandError", "Wsg50Gripper"]

logger = logging.getLogger(__name__)


class GripperCommandError(DeviceError):
    """The gripper answered a command with ``ERR <code>``."""

    def __init__(self, command: str, code: str):
        self.command, self.code = command, code
        super().__init__(f"the gripper refused {command}: ERR {code}")


class Wsg50Gripper:
    """A Weiss WSG-50 over its GCL text interface (protocol: :mod:`liquidtouch.protocols.gcl`).

    Connecting acknowledges a pending FAST STOP (``FSACK()``). ``ack_timeout_s``
    bounds the wait for a command's ``ACK`` (and query replies); a motion's
    ``FIN`` is awaited for ``motion_timeout_s``, or longer when the commanded
    travel at the commanded speed needs it.
    """

    def __init__(
        self,
        host: str,
        port: int = gcl.DEFAULT_PORT,
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
        logger.info("connected to the gripper at %s:%s", host, port)
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
            if line and not line.startswith(gcl.AUTOSEND_PREFIX):
                return line
            if line:
                logger.debug("gripper autosend skipped: %s", line)

    def _expect(self, command: str, word: str, timeout_s: float) -> None:
        """Wait for ``<word> <command>``; raise on ``ERR`` or any other reply."""
        expected = gcl.reply(word, command)
        reply = self._next_reply(timeout_s, expected)
        while command == gcl.STOP and reply.startswith(gcl.error_reply(gcl.E_CMD_ABORTED)):
            # the motion STOP ended is answered first
            reply = self._next_reply(timeout_s, expected)
        if reply == expected:
            return
        code = gcl.error_code(reply)
        if code is not None:
            logger.info("gripper: %s answered ERR %s", command, code)
            raise GripperCommandError(command, code)
        self._conn.close()
        logger.info("gripper: unexpected reply %r (expected %s); closed", reply, expected)
        raise DeviceError(
            f"unexpected reply {reply!r} from the gripper (expected {expected}); "
            "closed the connection"
        )

    def _command(self, call: str, *, motion_timeout_s: float | None = None) -> None:
        """Send ``call`` (e.g. ``GRIP(25.00,60.00,20.00)``); wait for ACK (and FIN if a motion)."""
        name = call.split("(", 1)[0]
        with self._lock:
            logger.debug("gripper <- %s", call)
            self._conn.send_line(call)
            self._expect(name, gcl.ACK, self.ack_timeout_s)
            if motion_timeout_s is not None:
                self._expect(name, gcl.FIN, motion_timeout_s)

    def _query(self, key: str) -> float:
        with self._lock:
            self._conn.send_line(gcl.query(key))
            reply = self._next_reply(self.ack_timeout_s, f"{key}=...")
            code = gcl.error_code(reply)
            if code is not None:
                raise GripperCommandError(gcl.query(key), code)
            value = gcl.parse_query_reply(reply, key)
            if value is not None:
                try:
                    number = float(value)
                except ValueError:
                    number = math.nan
                if math.isfinite(number):
                    return number
            self._conn.close()
            logger.info("gripper: unexpected reply %r to %s?; closed", reply, key)
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
            self._command(gcl.call(gcl.FSACK))
        except GripperCommandError as exc:
            logger.info("gripper: FSACK() refused (ERR %s); going on", exc.code)

    def home(self) -> None:
        self._command(
            gcl.call(gcl.HOME), motion_timeout_s=self._travel_timeout(gcl.MAX_WIDTH_MM, 20.0)
        )

    def grip(self, force_n: float, width_mm: float, speed_mm_s: float) -> None:
        force, width, speed = check_grip(force_n, width_mm, speed_mm_s)
        self._command(
            gcl.call(gcl.GRIP, force, width, speed),
            motion_timeout_s=self._travel_timeout(gcl.MAX_WIDTH_MM, speed),
        )
        state = self.grip_state()
        if state != gcl.HOLDING:
            raise DeviceError(
                f"the gripper finished GRIP but is not holding a part (GRIPSTATE={state} "
                f"{gcl.GRIP_STATES.get(state, '?')}); check the part width and the bottle's "
                "position"
            )

    def release(self, pullback_mm: float, speed_mm_s: float) -> None:
        pullback, speed = check_release(pullback_mm, speed_mm_s)
        self._command(
            gcl.call(gcl.RELEASE, pullback, speed),
            motion_timeout_s=self._travel_timeout(pullback, speed),
        )

    def stop(self) -> None:
        self._command(gcl.call(gcl.STOP))

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
                self._conn.send_line(gcl.call(gcl.BYE))
                self._expect(gcl.BYE, gcl.ACK, min(self.ack_timeout_s, 1.0))
            except DeviceError as exc:  # disconnecting anyway; the gripper may already be gone
                logger.info("gripper: no clean BYE (%s)", exc)
            finally:
                self._conn.close()
                logger.info("disconnected from the %s", self._conn.what)

    def __enter__(self) -> Wsg50Gripper:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
