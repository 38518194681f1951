"""What the rig's servers need of the rig: the gripper and arm models and their motion handles.

The servers (:mod:`~liquidtouch.sim.rig.gcl_server`, :mod:`~liquidtouch.sim.rig.arm_server`)
drive a :class:`GripperModel` and an :class:`ArmModel`; the rig's state
(:mod:`~liquidtouch.sim.rig.state`) implements them. Both sides import this module and
the wire protocols (:mod:`liquidtouch.protocols.gcl`, :mod:`liquidtouch.protocols.arm`,
whose :class:`~liquidtouch.protocols.gcl.GclError` and
:class:`~liquidtouch.protocols.arm.ArmError` a model raises), never each other.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

__all__ = ["ArmModel", "ArmMove", "GripperModel", "Motion"]


@dataclass
class Motion:
    """A finger motion the model has accepted.

    ``run(cancelled)`` blocks until the motion ends (checking the event), raises
    :class:`~liquidtouch.protocols.gcl.GclError` if it fails; ``cancel()`` makes the
    model stop where it is.
    """

    run: Callable[[threading.Event], None]
    cancel: Callable[[], None]


class GripperModel(Protocol):
    """The simulated gripper behind the GCL server."""

    def begin(self, command: str, args: list[float]) -> Motion:
        """Validate and start a motion (``HOME``, ``GRIP``, ...); raise ``GclError``."""

    def query(self, key: str) -> float:
        """``POS`` [mm], ``FORCE`` [N], ``SPEED`` [mm/s] or ``GRIPSTATE``."""

    def acknowledge(self) -> None:
        """Clear a FAST STOP."""

    def fast_stop(self) -> None:
        """Raise a FAST STOP (a client left without ``BYE()``)."""


@dataclass
class ArmMove:
    """An accepted move: ``run(cancelled)`` blocks until it ends and returns the pose."""

    run: Callable[[threading.Event], list[float]]
    cancel: Callable[[], None]


class ArmModel(Protocol):
    """The simulated arm behind the arm server."""

    def begin_move(self, pose: list[float], speed: float, acceleration: float) -> ArmMove:
        """Validate and start a move; raise ``ArmError``."""

    def pose(self) -> list[float]:
        """The tool pose now."""

    def start_pose(self) -> list[float]:
        """Where a trial starts and ends."""

    def truth(self) -> dict[str, Any]:
        """Ground truth and labels of the simulated liquid."""

    def status(self) -> dict[str, Any]:
        """The rig's state."""
