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

import time

from liquidtouch.acquire.device_link import DeviceAddress, LineConnection, parse_device_url
from liquidtouch.acquire.gripper_base import (
    GRIP_STATES,
    HOLDING,
    MAX_FORCE_N,
    MAX_WIDTH_MM,
    Gripper,
)
from liquidtouch.acquire.gripper_base import _check_grip as _check_grip
from liquidtouch.acquire.gripper_base import _check_number as _check_number
from liquidtouch.acquire.gripper_base import _check_release as _check_release
from liquidtouch.acquire.gripper_wsg50 import GCL_DEFAULT_PORT, GripperCommandError, Wsg50Gripper
from liquidtouch.errors import DeviceError

__all__ = [
    "GCL_DEFAULT_PORT",
    "GRIPPER_SCHEMES",
    "GRIP_STATES",
    "HOLDING",
    "MAX_FORCE_N",
    "MAX_WIDTH_MM",
    "DeviceAddress",
    "Gripper",
    "GripperCommandError",
    "LineConnection",
    "SimGripper",
    "Wsg50Gripper",
    "open_gripper",
    "parse_device_url",
]


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
