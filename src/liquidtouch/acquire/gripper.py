"""The gripper that holds the bottle: a Weiss WSG-50 over its text interface, or a stand-in.

:func:`open_gripper` picks the backend from a URL:

- ``wsg50://HOST[:PORT]`` -- a Weiss (Schunk) WSG-50 over its TCP text command
  interface, the "GCL" (Gripper Control Language; enable "Use text based interface"
  in the gripper's web interface; default port 1000). The simulated rig
  (``liquidtouch rig serve``) speaks the same protocol.
- ``sim://`` -- an in-process simulated gripper (no network): for dry runs and tests.

The GCL, as this client uses it (one command per line, ``\\n``-terminated, ASCII):

==========================  ===============================================
command                     replies
==========================  ===============================================
``FSACK()``                 ``ACK FSACK`` (acknowledges a pending FAST STOP)
``HOME()``                  ``ACK HOME``, then ``FIN HOME`` when the move ends
``GRIP(force, width, v)``   ``ACK GRIP``, ``FIN GRIP``; force [N], expected part width [mm],
                            speed [mm/s]
``RELEASE(pullback, v)``    ``ACK RELEASE``, ``FIN RELEASE``; opening [mm], speed [mm/s]
``STOP()``                  ``ACK STOP``
``POS?``                    ``POS=<width mm>``
``FORCE?``                  ``FORCE=<grip force N>``
``GRIPSTATE?``              ``GRIPSTATE=<n>`` (0 idle, 1 grasping, 2 no part found,
                            3 part lost, 4 holding, 5 releasing, 6 positioning, 7 error)
``BYE()``                   ``ACK BYE``; the gripper then closes the connection
==========================  ===============================================

Any command may be answered with ``ERR <code>`` (``ERR E_CMD_UNKNOWN``, ``ERR
E_RANGE_ERROR``, ...; in verbose mode followed by a text) instead of its ``ACK``,
or instead of its ``FIN`` when the motion fails. Lines starting with ``@`` are the
gripper's periodic ``AUTOSEND`` values and are skipped. Every wait has a timeout;
a timeout, an ``ERR``, an unexpected reply or a closed connection raises
:class:`~liquidtouch.errors.DeviceError`. A client that disconnects without
``BYE()`` makes the WSG raise a FAST STOP, so :meth:`Wsg50Gripper.close` always
says ``BYE()`` first (it never opens the fingers: a held bottle stays held).
"""

from __future__ import annotations

import math
import socket
import threading
import time
from dataclasses import dataclass
from typing import Protocol, runtime_checkable
from urllib.parse import urlsplit

from liquidtouch.errors import DeviceError

GCL_DEFAULT_PORT = 1000
"""The WSG's default TCP port of its command interface."""
MAX_WIDTH_MM = 110.0
"""The WSG-50's stroke: finger opening 0-110 mm."""
MAX_FORCE_N = 80.0
"""The WSG-50's largest grip force [N]."""

GRIP_STATES = {
    0: "IDLE",
    1: "GRASPING",
    2: "NO PART",
    3: "PART LOST",
    4: "HOLDING",
    5: "RELEASING",
    6: "POSITIONING",
    7: "ERROR",
}
"""The WSG's grasping states (``GRIPSTATE?``)."""
HOLDING = 4


@dataclass(frozen=True)
class DeviceAddress:
    """A parsed device URL: ``scheme://host:port``."""

    scheme: str
    host: str
    port: int | None


def parse_device_url(url: str, schemes: tuple[str, ...], what: str) -> DeviceAddress:
    """Split ``url`` into scheme, host and port; :class:`DeviceError` if malformed or unknown."""
    if not isinstance(url, str) or "://" not in url:
        raise DeviceError(
            f"{what} {url!r} is not a URL; use one of: " + ", ".join(f"{s}://..." for s in schemes)
        )
    parts = urlsplit(url)
    scheme = parts.scheme.lower()
    if scheme not in schemes:
        raise DeviceError(
            f"unknown {what} scheme {parts.scheme!r} in {url!r}; use one of: "
            + ", ".join(f"{s}://" for s in schemes)
        )
    if parts.path not in ("", "/") or parts.query or parts.fragment:
        raise DeviceError(f"{what} {url!r} has a path or query; give only scheme://HOST[:PORT]")
    try:
        port = parts.port
    except ValueError:
        raise DeviceError(f"{what} {url!r} has a bad port; use a number 1-65535") from None
    if port == 0:
        raise DeviceError(f"{what} {url!r} has port 0; use a number 1-65535")
    return DeviceAddress(scheme, parts.hostname or "", port)


class LineConnection:
    """A TCP connection carrying ``\\n``-terminated ASCII lines; every read has a deadline."""

    def __init__(self, host: str, port: int, *, connect_timeout_s: float, what: str):
        self.what = what
        self._buffer = b""
        try:
            self._sock = socket.create_connection((host, port), timeout=connect_timeout_s)
        except OSError as exc:
            raise DeviceError(
                f"cannot connect to the {what} at {host}:{port}: {exc.strerror or exc}; "
                "check that it is powered, on the network and that the address is right"
            ) from None
        self._sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.closed = False

    def send_line(self, line: str) -> None:
        """Send one line (the ``\\n`` is added)."""
        if self.closed:
            raise DeviceError(f"the connection to the {self.what} is closed")
        try:
            self._sock.settimeout(5.0)
            self._sock.sendall(line.encode("ascii") + b"\n")
        except OSError as exc:
            self.close()
            raise DeviceError(
                f"lost the connection to the {self.what} while sending {line!r}: "
                f"{exc.strerror or exc}"
            ) from None

    def read_line(self, timeout_s: float, waiting_for: str) -> str:
        """The next line (without its line end); :class:`DeviceError` after ``timeout_s``."""
        deadline = time.monotonic() + timeout_s
        while b"\n" not in self._buffer:
            if self.closed:
                raise DeviceError(f"the connection to the {self.what} is closed")
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise DeviceError(
                    f"the {self.what} did not answer within {timeout_s:g} s "
                    f"(waiting for {waiting_for})"
                )
            try:
                self._sock.settimeout(remaining)
                chunk = self._sock.recv(4096)
            except TimeoutError:
                continue
            except OSError as exc:
                self.close()
                raise DeviceError(
                    f"lost the connection to the {self.what} while waiting for {waiting_for}: "
                    f"{exc.strerror or exc}"
                ) from None
            if not chunk:
                self.close()
                raise DeviceError(
                    f"the {self.what} closed the connection while we waited for {waiting_for}"
                )
            self._buffer += chunk
            if len(self._buffer) > 1 << 16 and b"\n" not in self._buffer:
                self.close()
                raise DeviceError(f"the {self.what} sent a line longer than 64 KiB")
        line, _, self._buffer = self._buffer.partition(b"\n")
        return line.decode("ascii", errors="replace").strip()

    def close(self) -> None:
        """Close the socket (idempotent)."""
        if not self.closed:
            self.closed = True
            try:
                self._sock.close()
            except OSError:
                pass


@runtime_checkable
class Gripper(Protocol):
    """What the trial protocol needs from a gripper (widths [mm], forces [N], speeds [mm/s])."""

    url: str

    def acknowledge(self) -> None:
        """Clear a pending fast stop / error so that motion commands are accepted."""

    def home(self) -> None:
        """Open fully (and reference); blocks until done."""

    def grip(self, force_n: float, width_mm: float, speed_mm_s: float) -> None:
        """Close on a part of about ``width_mm`` with ``force_n``; blocks; raises unless holding."""

    def release(self, pullback_mm: float, speed_mm_s: float) -> None:
        """Open by ``pullback_mm`` from the held part; blocks until done."""

    def stop(self) -> None:
        """Stop the current finger motion."""

    def position_mm(self) -> float:
        """Current finger opening [mm]."""

    def force_n(self) -> float:
        """Current grip force [N]."""

    def grip_state(self) -> int:
        """Grasping state (:data:`GRIP_STATES`)."""

    def close(self) -> None:
        """Disconnect cleanly (never opens the fingers)."""


def _check_number(name: str, value: float, low: float, high: float, unit: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise DeviceError(f"gripper {name} must be a finite number of {unit}, got {value!r}")
    if not low <= value <= high:
        raise DeviceError(f"gripper {name} {value:g} {unit} is outside {low:g}-{high:g} {unit}")
    return float(value)


def _check_grip(force_n: float, width_mm: float, speed_mm_s: float) -> tuple[float, float, float]:
    return (
        _check_number("force", force_n, 5.0, MAX_FORCE_N, "N"),
        _check_number("part width", width_mm, 0.0, MAX_WIDTH_MM, "mm"),
        _check_number("speed", speed_mm_s, 0.1, 420.0, "mm/s"),
    )


def _check_release(pullback_mm: float, speed_mm_s: float) -> tuple[float, float]:
    return (
        _check_number("release distance", pullback_mm, 0.1, MAX_WIDTH_MM, "mm"),
        _check_number("speed", speed_mm_s, 0.1, 420.0, "mm/s"),
    )


class GripperCommandError(DeviceError):
    """The gripper answered a command with ``ERR <code>``."""

    def __init__(self, command: str, code: str):
        self.command, self.code = command, code
        super().__init__(f"the gripper refused {command}: ERR {code}")


class Wsg50Gripper:
    """A Weiss WSG-50 over its GCL text interface (module docstring: the protocol).

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


class SimGripper:
    """An in-process simulated gripper: keeps width, force and state; motions take no time.

    ``part_width_mm`` is the width of the part between the fingers (``None``: nothing
    there, a GRIP finds no part). ``time_scale`` > 0 makes motions take
    travel / speed × ``time_scale`` seconds.
    """

    def __init__(self, *, part_width_mm: float | None = 59.0, time_scale: float = 0.0):
        self.url = "sim://"
        self.part_width_mm = part_width_mm
        self.time_scale = float(time_scale)
        self.width_mm = MAX_WIDTH_MM
        self.force = 0.0
        self.state = 0
        self.closed = False
        self.log: list[str] = []

    def _move(self, target_mm: float, speed_mm_s: float) -> None:
        if self.closed:
            raise DeviceError("the simulated gripper is closed")
        if self.time_scale > 0:
            time.sleep(abs(target_mm - self.width_mm) / speed_mm_s * self.time_scale)
        self.width_mm = target_mm

    def acknowledge(self) -> None:
        self.log.append("FSACK")

    def home(self) -> None:
        self.log.append("HOME")
        self.force, self.state = 0.0, 0
        self._move(MAX_WIDTH_MM, 100.0)

    def grip(self, force_n: float, width_mm: float, speed_mm_s: float) -> None:
        force, width, speed = _check_grip(force_n, width_mm, speed_mm_s)
        self.log.append(f"GRIP {force:g} {width:g} {speed:g}")
        part = self.part_width_mm
        if part is None or part > self.width_mm or abs(part - width) > 20.0:
            self._move(0.0 if part is None or part > self.width_mm else width, speed)
            self.state = 2
            raise DeviceError("the simulated gripper found no part (GRIPSTATE=2 NO PART)")
        self._move(part, speed)
        self.force, self.state = force, HOLDING

    def release(self, pullback_mm: float, speed_mm_s: float) -> None:
        pullback, speed = _check_release(pullback_mm, speed_mm_s)
        self.log.append(f"RELEASE {pullback:g} {speed:g}")
        self.force, self.state = 0.0, 5
        self._move(min(self.width_mm + pullback, MAX_WIDTH_MM), speed)
        self.state = 0

    def stop(self) -> None:
        self.log.append("STOP")

    def position_mm(self) -> float:
        return self.width_mm

    def force_n(self) -> float:
        return self.force

    def grip_state(self) -> int:
        return self.state

    def close(self) -> None:
        self.log.append("BYE")
        self.closed = True

    def __enter__(self) -> SimGripper:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


GRIPPER_SCHEMES = ("wsg50", "sim")


def open_gripper(url: str, **options: float) -> Gripper:
    """Connect to the gripper at ``url`` (``wsg50://HOST[:PORT]`` or ``sim://``).

    ``options`` go to :class:`Wsg50Gripper` (``connect_timeout_s``, ``ack_timeout_s``,
    ``motion_timeout_s``). Raises :class:`~liquidtouch.errors.DeviceError` for a bad
    URL or an unreachable gripper.
    """
    address = parse_device_url(url, GRIPPER_SCHEMES, "gripper URL")
    if address.scheme == "sim":
        if address.host or address.port:
            raise DeviceError(
                f"gripper URL {url!r}: sim:// is the in-process simulated gripper and takes "
                "no address; the simulated rig's gripper speaks the real protocol: use "
                "wsg50://HOST:PORT with the port `liquidtouch rig serve` prints"
            )
        return SimGripper()
    if not address.host:
        raise DeviceError(f"gripper URL {url!r} has no host; use wsg50://HOST[:PORT]")
    return Wsg50Gripper(address.host, address.port or GCL_DEFAULT_PORT, **options)
