"""An in-process simulated gripper (``sim://``): no network, no physics; dry runs and tests."""

from __future__ import annotations

import logging
import time

from liquidtouch.acquire.grippers.base import check_grip, check_release
from liquidtouch.errors import DeviceError
from liquidtouch.protocols import gcl

__all__ = ["HOME_SPEED_MM_S", "SimGripper"]

logger = logging.getLogger(__name__)

HOME_SPEED_MM_S = 100.0
"""How fast the simulated fingers open on ``home()`` [mm/s]."""


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
        self.width_mm = gcl.MAX_WIDTH_MM
        self.force = 0.0
        self.state = gcl.IDLE
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
        self.force, self.state = 0.0, gcl.IDLE
        self._move(gcl.MAX_WIDTH_MM, HOME_SPEED_MM_S)

    def grip(self, force_n: float, width_mm: float, speed_mm_s: float) -> None:
        force, width, speed = check_grip(force_n, width_mm, speed_mm_s)
        self.log.append(f"GRIP {force:g} {width:g} {speed:g}")
        part = self.part_width_mm
        if part is None or part > self.width_mm or abs(part - width) > 20.0:
            self._move(0.0 if part is None or part > self.width_mm else width, speed)
            self.state = gcl.NO_PART
            logger.info("simulated gripper: no part found at %g mm", width)
            raise DeviceError("the simulated gripper found no part (GRIPSTATE=2 NO PART)")
        self._move(part, speed)
        self.force, self.state = force, gcl.HOLDING

    def release(self, pullback_mm: float, speed_mm_s: float) -> None:
        pullback, speed = check_release(pullback_mm, speed_mm_s)
        self.log.append(f"RELEASE {pullback:g} {speed:g}")
        self.force, self.state = 0.0, gcl.RELEASING
        self._move(min(self.width_mm + pullback, gcl.MAX_WIDTH_MM), speed)
        self.state = gcl.IDLE

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
