"""The rig's gripper: the WSG-50's finger commands (GCL) acting on the rig's state.

Part of the simulated rig (:mod:`liquidtouch.sim.rig.rig`). :class:`FingerCommands` is a
base of :class:`~liquidtouch.sim.rig.state.Rig` (``gcl_server.GripperModel``): its methods
work on the rig's attributes (``width_mm``, ``holding``, ``grip_state``, the bottle and
the arm's pose) under the rig's lock.
"""

from __future__ import annotations

import math
import threading
import time

from liquidtouch.sim.rig.gcl_server import GclError, Motion
from liquidtouch.sim.rig.kinematics import FingerMotion

OPEN_WIDTH_MM = 110.0
"""The WSG-50's full opening [mm]."""
CLAMP_TRAVEL_MM = 10.0
"""GRIP finds the part if it lies within this distance of the commanded width [mm]."""
HOME_SPEED_MM_S = 100.0
MAX_GRIP_FORCE_N = 80.0


class FingerCommands:
    """``HOME``, ``GRIP``, ``RELEASE``, ``MOVE``, the queries and FAST STOP of the rig's gripper."""

    def _width(self, now: float) -> float:
        motion = self._finger_motion
        return motion.width_at(now) if motion is not None else self.width_mm

    def begin(self, command: str, args: list[float]) -> Motion:
        """Validate and start a finger motion (``HOME``, ``GRIP``, ``RELEASE``, ``MOVE``)."""
        with self._lock:
            if self.fast_stop:
                raise GclError("E_ACCESS_DENIED", "FAST STOP: acknowledge it with FSACK()")
            if self._finger_motion is not None:
                raise GclError("E_ALREADY_RUNNING", "the fingers are moving")
            now = time.monotonic()
            width = self._width(now)
            if command == "HOME":
                target, speed, on_done = OPEN_WIDTH_MM, HOME_SPEED_MM_S, self._opened
                self._open_now(now)
            elif command == "GRIP":
                target, speed, on_done = self._begin_grip(args, width)
            elif command == "RELEASE":
                pullback = _arg(args, 0, None, 0.1, OPEN_WIDTH_MM, "pullback")
                speed = _arg(args, 1, 50.0, 0.1, 420.0, "speed")
                target, on_done = min(width + pullback, OPEN_WIDTH_MM), self._opened
                self._open_now(now)
                self.grip_state = 5
            elif command == "MOVE":
                if self.holding:
                    raise GclError("E_ACCESS_DENIED", "a part is held: RELEASE() it first")
                target = _arg(args, 0, None, 0.0, OPEN_WIDTH_MM, "width")
                speed = _arg(args, 1, 50.0, 0.1, 420.0, "speed")
                if target < self.bottle_width_mm and width >= self.bottle_width_mm:
                    raise GclError("E_AXIS_BLOCKED", "the fingers are blocked by the bottle")
                on_done = self._opened
                self.grip_state = 6
            else:
                raise GclError("E_CMD_UNKNOWN", command)
            duration = abs(target - width) / speed * self.gripper_time_scale
            motion = FingerMotion(width, target, now, duration, speed)
            self._finger_motion = motion

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
            raise GclError("E_NOT_ENOUGH_PARAMS", "GRIP(force, width, speed)")
        force = _arg(args, 0, None, 5.0, MAX_GRIP_FORCE_N, "force")
        part = _arg(args, 1, self.bottle_width_mm, 0.0, OPEN_WIDTH_MM, "width")
        speed = _arg(args, 2, 50.0, 0.1, 420.0, "speed")
        if self.holding:
            self.grip_force_n = force
            return width, speed, lambda: None
        self.grip_state = 1
        found = (
            not self.dropped
            and width >= self.bottle_width_mm
            and abs(part - self.bottle_width_mm) <= CLAMP_TRAVEL_MM
        )
        if found:

            def on_done() -> None:
                self.holding, self.grip_force_n, self.grip_state = True, force, 4
                self.grasp_z = self._pose[2] if self._arm_motion is None else None

            return self.bottle_width_mm, speed, on_done

        def no_part() -> None:
            self.grip_state = 2
            raise GclError("E_CMD_FAILED", "no part found")

        target = max(part - CLAMP_TRAVEL_MM, 0.0)
        if width >= self.bottle_width_mm and not self.dropped:
            target = max(target, self.bottle_width_mm)  # the fingers stop at the bottle
        return target, speed, no_part

    def _open_now(self, now: float) -> None:
        """The fingers start opening: a held bottle is let go (and falls if lifted)."""
        if self.holding:
            if self._weight(self.pose(now)[2]) > 0.0:
                self.dropped = True
            self.holding, self.grip_force_n, self.grasp_z = False, 0.0, None
            self._set_down()

    def _opened(self) -> None:
        self.grip_state = 0

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
                return float(7 if self.fast_stop else self.grip_state)
        raise GclError("E_CMD_UNKNOWN", key)

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
            raise GclError("E_NOT_ENOUGH_PARAMS", f"missing {what}")
        return default
    value = args[i]
    if not (math.isfinite(value) and low <= value <= high):
        raise GclError("E_RANGE_ERROR", f"{what} {value:g} outside {low:g}-{high:g}")
    return value
