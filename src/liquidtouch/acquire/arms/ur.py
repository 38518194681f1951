"""A Universal Robots arm through the ``ur_rtde`` package (imported only when used)."""

from __future__ import annotations

import contextlib
import logging
import math
import time
from collections.abc import Sequence
from typing import Any

from liquidtouch.acquire.arms.motion import (
    POSITION_TOLERANCE_M,
    check_move,
    check_pose,
    linear_move_duration,
)
from liquidtouch.errors import DeviceError

__all__ = ["URArm", "import_ur_rtde"]

logger = logging.getLogger(__name__)


def import_ur_rtde() -> tuple[Any, Any]:
    """The ``rtde_control`` and ``rtde_receive`` modules; :class:`DeviceError` without them."""
    try:
        # why: ur_rtde is optional (liquidtouch[robot]); imported only for a UR arm
        import rtde_control
        import rtde_receive
    except ImportError:
        raise DeviceError(
            "ur-rtde:// needs the ur_rtde package: pip install 'liquidtouch[robot]' "
            "(or pip install ur_rtde)"
        ) from None
    return rtde_control, rtde_receive


class URArm:
    """A Universal Robots arm through ``ur_rtde`` (its control and receive interfaces).

    ``move_linear`` starts an asynchronous ``moveL`` and polls
    ``getAsyncOperationProgress`` (negative: no move running) until the tool is at the
    target; past ``2 × the move's duration + move_margin_s`` it calls ``stopL`` and raises.
    ``modules`` = ``(rtde_control, rtde_receive)`` replaces the imports (tests pass fakes).
    """

    def __init__(
        self,
        host: str,
        *,
        modules: tuple[Any, Any] | None = None,
        move_margin_s: float = 3.0,
        poll_s: float = 0.01,
    ):
        rtde_control, rtde_receive = modules if modules is not None else import_ur_rtde()
        self.url = f"ur-rtde://{host}"
        self.move_margin_s = float(move_margin_s)
        self.poll_s = float(poll_s)
        try:
            self._receive = rtde_receive.RTDEReceiveInterface(host)
            self._control = rtde_control.RTDEControlInterface(host)
        except RuntimeError as exc:
            logger.info("cannot connect to the UR arm at %s: %s", host, exc)
            raise DeviceError(f"cannot connect to the UR arm at {host}: {exc}") from None
        logger.info("connected to the UR arm at %s", host)

    def get_pose(self) -> list[float]:
        return check_pose(self._receive.getActualTCPPose(), "arm's reported pose")

    def _check_safety(self) -> None:
        for flag, what in (
            ("isProtectiveStopped", "protective stop"),
            ("isEmergencyStopped", "emergency stop"),
        ):
            check = getattr(self._receive, flag, None)
            if check is not None and check():
                logger.info("the UR arm is in a %s", what)
                raise DeviceError(f"the UR arm is in a {what}; clear it on the teach pendant")

    def move_linear(
        self, pose: Sequence[float], speed_m_s: float, acceleration_m_s2: float
    ) -> list[float]:
        start = self.get_pose()
        target, distance = check_move(start, pose, speed_m_s, acceleration_m_s2)
        self._check_safety()
        duration = linear_move_duration(distance, speed_m_s, acceleration_m_s2)
        limit = 2.0 * duration + self.move_margin_s
        if not self._control.moveL(target, float(speed_m_s), float(acceleration_m_s2), True):
            raise DeviceError("the UR arm refused the moveL (is the control script running?)")
        begun = time.monotonic()
        try:
            while True:
                elapsed = time.monotonic() - begun
                running = self._control.getAsyncOperationProgress() >= 0
                now = self.get_pose()
                if not running and math.dist(now[:3], target[:3]) <= POSITION_TOLERANCE_M:
                    return now
                if not running and elapsed > duration + 0.5:
                    self._check_safety()
                    raise DeviceError(
                        f"the UR arm stopped {math.dist(now[:3], target[:3]) * 1e3:.1f} mm "
                        "short of the target"
                    )
                if elapsed > limit:
                    raise DeviceError(
                        f"the UR arm did not finish a {distance * 1e3:.0f} mm move within "
                        f"{limit:.1f} s"
                    )
                time.sleep(self.poll_s)
        except BaseException as exc:
            logger.info("UR arm move failed (%s): stopping the arm", exc or type(exc).__name__)
            with contextlib.suppress(Exception):
                self.stop()
            raise

    def stop(self, deceleration_m_s2: float = 2.0) -> None:
        self._control.stopL(float(deceleration_m_s2))

    def close(self) -> None:
        for call in (
            getattr(self._control, "stopScript", None),
            getattr(self._control, "disconnect", None),
            getattr(self._receive, "disconnect", None),
        ):
            if call is not None:
                try:
                    call()
                except RuntimeError as exc:
                    logger.info(
                        "UR arm: %s failed while closing: %s", getattr(call, "__name__", call), exc
                    )

    def __enter__(self) -> URArm:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
