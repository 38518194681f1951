"""An in-process stand-in arm (``sim://``): no network, no physics; dry runs and tests."""

from __future__ import annotations

import math
import time
from collections.abc import Sequence

from liquidtouch.acquire.arms.motion import check_move, check_pose, linear_move_duration
from liquidtouch.errors import DeviceError

__all__ = ["SimArm"]


class SimArm:
    """An in-process stand-in arm: the pose jumps (``time_scale`` > 0: moves) to targets."""

    def __init__(
        self, pose: Sequence[float] = (0.4, 0.0, 0.2, 0.0, math.pi, 0.0), *, time_scale: float = 0.0
    ):
        self.url = "sim://"
        self.pose = check_pose(pose)
        self.home = list(self.pose)
        self.time_scale = float(time_scale)
        self.moves: list[list[float]] = []
        self.stops = 0
        self.closed = False

    def get_pose(self) -> list[float]:
        return list(self.pose)

    def start_pose(self) -> list[float]:
        """Where a trial starts and ends: the pose this stand-in was made at."""
        return list(self.home)

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
