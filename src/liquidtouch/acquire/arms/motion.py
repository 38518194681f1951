"""What every arm backend shares: move limits, pose and move checks, the :class:`Arm` interface.

Poses are ``[x, y, z, rx, ry, rz]``: position [m] and rotation vector [rad] of the tool
in the base frame, as UR controllers use them; speeds [m/s], accelerations [m/s²].
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Protocol, runtime_checkable

from liquidtouch.errors import DeviceError

__all__ = [
    "MAX_ACCELERATION_M_S2",
    "MAX_SPEED_M_S",
    "MAX_STEP_M",
    "POSITION_TOLERANCE_M",
    "Arm",
    "check_move",
    "check_pose",
    "linear_move_duration",
]

MAX_SPEED_M_S = 1.0
"""Fastest tool speed liquidtouch commands [m/s] (a push is ~0.1 m/s)."""
MAX_ACCELERATION_M_S2 = 10.0
"""Largest tool acceleration liquidtouch commands [m/s²]."""
MAX_STEP_M = 0.3
"""Longest single move liquidtouch commands [m]: a longer one is a unit mistake."""
POSITION_TOLERANCE_M = 0.002
"""A move has arrived when the tool is this close to the target [m]."""


def linear_move_duration(distance_m: float, speed_m_s: float, acceleration_m_s2: float) -> float:
    """Duration [s] of a straight move with a trapezoidal speed profile (as UR's ``moveL``).

    Accelerates at ``acceleration_m_s2`` to ``speed_m_s``, cruises, decelerates; a short
    move that never reaches the speed is a triangle.
    """
    d, v, a = abs(distance_m), speed_m_s, acceleration_m_s2
    if d == 0:
        return 0.0
    if d >= v * v / a:
        return d / v + v / a
    return 2.0 * math.sqrt(d / a)


def check_pose(pose: Sequence[float], what: str = "pose") -> list[float]:
    """``pose`` as 6 floats; :class:`DeviceError` unless 6 finite numbers."""
    try:
        values = [float(v) for v in pose]
    except (TypeError, ValueError):
        raise DeviceError(
            f"the {what} must be 6 numbers [x, y, z, rx, ry, rz], got {pose!r}"
        ) from None
    if len(values) != 6 or not all(math.isfinite(v) for v in values):
        raise DeviceError(
            f"the {what} must be 6 finite numbers [x, y, z, rx, ry, rz], got {pose!r}"
        )
    return values


def check_move(
    start: Sequence[float], target: Sequence[float], speed_m_s: float, acceleration_m_s2: float
) -> tuple[list[float], float]:
    """Validate a linear move; return the target pose and the move's distance [m]."""
    target = check_pose(target, "target pose")
    for name, value, high, unit in (
        ("speed", speed_m_s, MAX_SPEED_M_S, "m/s"),
        ("acceleration", acceleration_m_s2, MAX_ACCELERATION_M_S2, "m/s²"),
    ):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise DeviceError(f"arm {name} must be a number of {unit}, got {value!r}")
        if not 0 < value <= high:
            raise DeviceError(f"arm {name} {value!r} {unit} is outside (0, {high:g}] {unit}")
    distance = math.dist(start[:3], target[:3])
    if distance > MAX_STEP_M:
        raise DeviceError(
            f"refusing an arm move of {distance * 1e3:.0f} mm (more than {MAX_STEP_M * 1e3:.0f} "
            "mm in one move): poses are in metres"
        )
    return target, distance


@runtime_checkable
class Arm(Protocol):
    """What the trial protocol needs from an arm (module docstring: units)."""

    url: str

    def get_pose(self) -> list[float]:
        """The tool pose now."""

    def move_linear(self, pose: Sequence[float], speed_m_s: float, acceleration_m_s2: float):
        """Move the tool in a straight line to ``pose``; blocks until it arrives."""

    def stop(self, deceleration_m_s2: float = 2.0) -> None:
        """Stop any motion now (decelerating at ``deceleration_m_s2``)."""

    def close(self) -> None:
        """Disconnect (stops nothing that is still held)."""
