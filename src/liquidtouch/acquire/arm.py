"""The arm that lifts and pushes the bottle: a Universal Robots arm, the simulated rig's, or none.

:func:`open_arm` picks the backend from a URL:

- ``ur-rtde://HOST`` -- a UR arm (the paper's UR5e) through the ``ur_rtde`` package
  (``pip install 'liquidtouch[robot]'``; imported only when used). Moves are
  ``moveL`` in the base frame, run asynchronously and polled, so that a timeout or
  Ctrl-C can stop them (``stopL``); the pose is ``getActualTCPPose``.
- ``sim://HOST:PORT`` -- the simulated rig's arm endpoint (``liquidtouch rig serve``),
  over the line protocol below.
- ``sim://`` -- an in-process stand-in arm (no network, no physics): dry runs and tests.

Poses are ``[x, y, z, rx, ry, rz]``: position [m] and rotation vector [rad] of the tool
in the base frame, as UR controllers use them; speeds [m/s], accelerations [m/s²].

**The rig's arm protocol** (one JSON object per ``\\n``-terminated line, UTF-8). On
connecting the server sends ``{"server": "liquidtouch-rig-arm", "protocol": 1}``. Each
request carries an ``id`` (an integer the client chooses) and a ``cmd``; its reply
carries the same ``id``, ``"ok": true`` and the result, or ``"ok": false`` and an
``"error"`` text:

==========================================================  ==================================
request                                                     reply (besides ``id``, ``ok``)
==========================================================  ==================================
``{"cmd": "moveL", "pose": [6], "speed": v, "acceleration": a}``  ``"pose"`` when the move has
                                                            ended (a linear move with a
                                                            trapezoidal speed profile)
``{"cmd": "get_pose"}``                                     ``"pose"``
``{"cmd": "stop", "acceleration": a}``                      ``"pose"``; a running ``moveL``
                                                            then fails with ``"stopped"``
``{"cmd": "truth"}``                                        ``"truth"``: the simulated liquid's
                                                            λ, ω and labels
``{"cmd": "status"}``                                       ``"status"``: the rig's state
==========================================================  ==================================
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from typing import Any

from liquidtouch.acquire.arm_motion import (
    MAX_ACCELERATION_M_S2,
    MAX_SPEED_M_S,
    MAX_STEP_M,
    POSITION_TOLERANCE_M,
    Arm,
    check_move,
    check_pose,
    linear_move_duration,
)
from liquidtouch.acquire.arm_rig import RIG_ARM_PROTOCOL, RigArm
from liquidtouch.acquire.arm_ur import URArm
from liquidtouch.acquire.arm_ur import _import_ur_rtde as _import_ur_rtde
from liquidtouch.acquire.device_link import LineConnection, parse_device_url
from liquidtouch.errors import DeviceError

__all__ = [
    "ARM_SCHEMES",
    "MAX_ACCELERATION_M_S2",
    "MAX_SPEED_M_S",
    "MAX_STEP_M",
    "POSITION_TOLERANCE_M",
    "RIG_ARM_PROTOCOL",
    "Arm",
    "LineConnection",
    "RigArm",
    "SimArm",
    "URArm",
    "check_move",
    "check_pose",
    "linear_move_duration",
    "open_arm",
    "parse_device_url",
]

ARM_SCHEMES = ("ur-rtde", "sim")


class SimArm:
    """An in-process stand-in arm: the pose jumps (``time_scale`` > 0: moves) to targets."""

    def __init__(
        self, pose: Sequence[float] = (0.4, 0.0, 0.2, 0.0, math.pi, 0.0), *, time_scale: float = 0.0
    ):
        self.url = "sim://"
        self.pose = check_pose(pose)
        self.time_scale = float(time_scale)
        self.moves: list[list[float]] = []
        self.stops = 0
        self.closed = False

    def get_pose(self) -> list[float]:
        return list(self.pose)

    def move_linear(
        self, pose: Sequence[float], speed_m_s: float, acceleration_m_s2: float
    ) -> list[float]:
        if self.closed:
            raise DeviceError("the simulated arm is closed")
        target, distance = check_move(self.pose, pose, speed_m_s, acceleration_m_s2)
        if self.time_scale > 0:
            time.sleep(
                self.time_scale * linear_move_duration(distance, speed_m_s, acceleration_m_s2)
            )
        self.pose = target
        self.moves.append(list(target))
        return list(target)

    def stop(self, deceleration_m_s2: float = 2.0) -> None:
        self.stops += 1

    def close(self) -> None:
        self.closed = True

    def __enter__(self) -> SimArm:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def open_arm(url: str, **options: Any) -> Arm:
    """Connect to the arm at ``url`` (``ur-rtde://HOST``, ``sim://HOST:PORT`` or ``sim://``).

    ``options`` go to the backend's class (:class:`URArm`, :class:`RigArm`). Raises
    :class:`~liquidtouch.errors.DeviceError` for a bad URL or an unreachable arm.
    """
    address = parse_device_url(url, ARM_SCHEMES, "arm URL")
    if address.scheme == "ur-rtde":
        if not address.host:
            raise DeviceError(f"arm URL {url!r} has no host; use ur-rtde://HOST")
        if address.port is not None:
            raise DeviceError(
                f"arm URL {url!r}: ur_rtde uses the controller's fixed RTDE ports; "
                "give ur-rtde://HOST without a port"
            )
        return URArm(address.host, **options)
    if not address.host and address.port is None:
        return SimArm(**options)
    if not address.host or address.port is None:
        raise DeviceError(
            f"arm URL {url!r}: use sim://HOST:PORT (the port `liquidtouch rig serve` prints) "
            "or sim:// for the in-process stand-in"
        )
    return RigArm(address.host, address.port, **options)
