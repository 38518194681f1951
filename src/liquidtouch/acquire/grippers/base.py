"""What every gripper backend shares: the :class:`Gripper` interface and the command checks.

The WSG-50's limits and grasping states are those of its protocol,
:mod:`liquidtouch.protocols.gcl`.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

from liquidtouch._core.checks import check_range
from liquidtouch.errors import DeviceError
from liquidtouch.protocols import gcl

__all__ = ["Gripper", "check_grip", "check_release"]


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
        """Grasping state (:data:`liquidtouch.protocols.gcl.GRIP_STATES`)."""

    def close(self) -> None:
        """Disconnect cleanly (never opens the fingers)."""


def _check(what: str, value: float, low: float, high: float, unit: str) -> float:
    return check_range(value, f"gripper {what}", low, high, unit, error=DeviceError)


def check_grip(force_n: float, width_mm: float, speed_mm_s: float) -> tuple[float, float, float]:
    """A ``GRIP``'s force [N], part width [mm] and speed [mm/s], checked against the WSG-50's
    limits; :class:`DeviceError` names the bad one."""
    return (
        _check("force", force_n, gcl.MIN_FORCE_N, gcl.MAX_FORCE_N, "N"),
        _check("part width", width_mm, 0.0, gcl.MAX_WIDTH_MM, "mm"),
        _check("speed", speed_mm_s, gcl.MIN_SPEED_MM_S, gcl.MAX_SPEED_MM_S, "mm/s"),
    )


def check_release(pullback_mm: float, speed_mm_s: float) -> tuple[float, float]:
    """A ``RELEASE``'s opening [mm] and speed [mm/s], checked; :class:`DeviceError` otherwise."""
    return (
        _check("release distance", pullback_mm, gcl.MIN_PULLBACK_MM, gcl.MAX_WIDTH_MM, "mm"),
        _check("speed", speed_mm_s, gcl.MIN_SPEED_MM_S, gcl.MAX_SPEED_MM_S, "mm/s"),
    )
