"""What every gripper backend shares: the WSG-50's limits, grasping states and interface."""

from __future__ import annotations

import math
from typing import Protocol, runtime_checkable

from liquidtouch.errors import DeviceError

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
