"""The rig's gripper: the WSG-50's finger commands (GCL) acting on the rig's state.

Part of the simulated rig (:mod:`liquidtouch.sim.rig.rig`). :class:`FingerCommands` is a
base of :class:`~liquidtouch.sim.rig.state.Rig` (``gcl_server.GripperModel``): its methods
work on the rig's attributes (``width_mm``, ``holding``, ``grip_state``, the bottle and
the arm's pose) under the rig's lock. Refusals and failures raise
:class:`~liquidtouch.protocols.gcl.GclError` (the protocol's ``ERR <code>``).
"""

from __future__ import annotations

import logging
import math
import threading
import time

from liquidtouch.protocols import gcl
from liquidtouch.protocols.gcl import GclError
from liquidtouch.sim.rig.interfaces import Motion
from liquidtouch.sim.rig.kinematics import FingerMotion

__all__ = [
    "CLAMP_TRAVEL_MM",
    "DEFAULT_SPEED_MM_S",
    "HOME_SPEED_MM_S",
    "OPEN_WIDTH_MM",
    "FingerCommands",
]

logger = logging.getLogger(__name__)

OPEN_WIDTH_MM = gcl.MAX_WIDTH_MM
"""The WSG-50's full opening [mm]."""
CLAMP_TRAVEL_MM = 10.0
"""GRIP finds the part if it lies within this distance of the commanded width [mm]."""
HOME_SPEED_MM_S = 100.0
"""How fast ``HOME()`` opens the fingers [mm/s]."""
DEFAULT_SPEED_MM_S = 50.0
"""The speed of a motion command that gives none [mm/s]."""


class FingerCommands:
    """``HOME``, ``GRIP``, ``RELEASE``, ``MOVE``, the queries and FAST STOP of the rig's gripper."""

    def _width(self, now: float) -> float:
        motion = self._finger_motion
        return motion.width_at(now) if motion is not None else self.width_mm

    def begin(self, command: str, args: list[float]) -> Motion:
        """Validate and start a finger motion (``HOME``, ``GRIP``, ``RELEASE``, ``MOVE``)."""
        with self._lock:
            if self.fast_stop:
                raise GclError(gcl.E_ACCESS_DENIED, "FAST STOP: acknowledge it with FSACK()")
            if self._finger_motion is not None:
                raise GclError(gcl.E_ALREADY_RUNNING, "the fingers are moving")
            now = time.monotonic()
            width = self._width(now)
            if command == gcl.HOME:
                target, speed, on_done = OPEN_WIDTH_MM, HOME_SPEED_MM_S, self._opened
                self._open_now(now)
            elif command == gcl.GRIP:
                target, speed, on_done = self._begin_grip(args, width)
            elif command == gcl.RELEASE:
                pullback = _arg(args, 0, None, gcl.MIN_PULLBACK_MM, OPEN_WIDTH_MM, "pullback")
                speed = _speed(args, 1)
                target, on_done = min(width + pullback, OPEN_WIDTH_MM), self._opened
                self._open_now(now)
                self.grip_state = gcl.RELEASING
            elif command == gcl.MOVE:
                if self.holding:
                    raise GclError(gcl.E_ACCESS_DENIED, "a part is held: RELEASE() it first")
                target = _arg(args, 0, None, 0.0, OPEN_WIDTH_MM, "width")
                speed = _speed(args, 1)
                if target < self.bottle_width_mm and width >= self.bottle_width_mm:
                    raise GclError(gcl.E_AXIS_BLOCKED, "the fingers are blocked by the bottle")
                on_done = self._opened
                self.grip_state = gcl.POSITIONING
            else:
                raise GclError(gcl.E_CMD_UNKNOWN, command)
            duration = abs(target - width) / speed * self.gripper_time_scale
            motion = FingerMotion(width, target, now, duration, speed)
            self._finger_motion = motion
            logger.debug("fingers: %s %.1f -> %.1f mm in %.2f s", command, width, target, duration)

        def run(cancelled: threading.Event) -> None:
            end = motion.t0 + motion.duration
            while not cancelled.is_set():
                remaining = end - time.monotonic()
                if remaining <= 0:
                    break
                cancelled.wait(min(remaining, 0.02))
            with self._lock:
                if self._finger_motion is motion:
                    self.width_mm = motion.width_at(time.monotonic())
                    self._finger_motion = None
                if cancelled.is_set():
                    return
                on_done()

        return Motion(run=run, cancel=lambda: self._cancel_fingers(motion))

    def _begin_grip(self, args: list[float], width: float):
        if not args:
            raise GclError(gcl.E_NOT_ENOUGH_PARAMS, "GRIP(force, width, speed)")
        force = _arg(args, 0, None, gcl.MIN_FORCE_N, gcl.MAX_FORCE_N, "force")
        part = _arg(args, 1, self.bottle_width_mm, 0.0, OPEN_WIDTH_MM, "width")
        speed = _speed(args, 2)
        if self.holding:
            self.grip_force_n = force
            return width, speed, lambda: None
        self.grip_state = gcl.GRASPING
        found = (
            not self.dropped
            and width >= self.bottle_width_mm
            and abs(part - self.bottle_width_mm) <= CLAMP_TRAVEL_MM
        )
        if found:

            def on_done() -> None:
                self.holding, self.grip_force_n, self.grip_state = True, force, gcl.HOLDING
                logger.info("rig gripper: holding the bottle with %g N", force)
                self.grasp_z = self._pose[2] if self._arm_motion is None else None

            return self.bottle_width_mm, speed, on_done

        def no_part() -> None:
            self.grip_state = gcl.NO_PART
            logger.info("rig gripper: GRIP found no part at %g mm", part)
            raise GclError(gcl.E_CMD_FAILED, "no part found")

        target = max(part - CLAMP_TRAVEL_MM, 0.0)
        if width >= self.bottle_width_mm and not self.dropped:
            target = max(target, self.bottle_width_mm)  # the fingers stop at the bottle
        return target, speed, no_part

    def _open_now(self, now: float) -> None:
        """The fingers start opening: a held bottle is let go (and falls if lifted)."""
        if self.holding:
            if self._weight(self.pose(now)[2]) > 0.0:
                logger.warning("rig gripper: opened with the bottle lifted: it fell")
                self.dropped = True
            self.holding, self.grip_force_n, self.grasp_z = False, 0.0, None
            self._set_down()

    def _opened(self) -> None:
        self.grip_state = gcl.IDLE

    def _cancel_fingers(self, motion: FingerMotion) -> None:
        with self._lock:
            if self._finger_motion is motion:
                self.width_mm = motion.width_at(time.monotonic())
                self._finger_motion = None

    def query(self, key: str) -> float:
        with self._lock:
            now = time.monotonic()
            if key == "POS":
                return round(self._width(now), 3)
            if key == "FORCE":
                return round(self.grip_force_n, 3)
            if key == "SPEED":
                motion = self._finger_motion
                return motion.speed if motion is not None else 0.0
            if key == "GRIPSTATE":
                return float(gcl.ERROR if self.fast_stop else self.grip_state)
        raise GclError(gcl.E_CMD_UNKNOWN, key)

    def acknowledge(self) -> None:
        with self._lock:
            self.fast_stop = False

    def raise_fast_stop(self) -> None:
        """A client left without ``BYE()``: motion commands are refused until ``FSACK()``."""
        with self._lock:
            self.fast_stop = True


def _arg(args: list[float], i: int, default: float | None, low: float, high: float, what: str):
    if i >= len(args):
        if default is None:
            raise GclError(gcl.E_NOT_ENOUGH_PARAMS, f"missing {what}")
        return default
    value = args[i]
    if not (math.isfinite(value) and low <= value <= high):
        raise GclError(gcl.E_RANGE_ERROR, f"{what} {value:g} outside {low:g}-{high:g}")
    return value


def _speed(args: list[float], i: int) -> float:
    return _arg(args, i, DEFAULT_SPEED_MM_S, gcl.MIN_SPEED_MM_S, gcl.MAX_SPEED_MM_S, "speed")
