"""The rig's start state: read before a trial moves anything, refused or recovered when unexpected.

A trial starts with the fingers open around a bottle standing on the table and the arm at
its **start pose** (the pose the grasp is made at; the trial ends there again). After an
interrupted trial (Ctrl-C, a failure) the gripper keeps holding the bottle wherever the
arm stopped, so the next trial must not start from there: lifting again and releasing
would drop the bottle. :func:`read_start_state` reads the gripper's ``GRIPSTATE?`` and
``POS?`` (:mod:`liquidtouch.protocols.gcl`) and the arm's pose; :func:`check_start_state`
refuses anything but the start state with :class:`StartStateError`, which says what is
wrong and what to do; :func:`recover_start_state` (``run-trial --recover``) carries a
held bottle back above its start at the height it is at, lowers it onto the table and
opens, or just opens the fingers and moves the arm back — never a release in the air.

The start pose is the protocol file's ``start_pose`` when given, else the arm's own
(``start_pose()``: the simulated rig's home, the stand-in's first pose), else — an arm that
does not know one (a UR arm) — its pose when the trial starts (only the gripper's state
is checked then).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass

from liquidtouch.acquire.arms import POSITION_TOLERANCE_M, Arm, check_pose
from liquidtouch.acquire.grippers import Gripper
from liquidtouch.acquire.protocol_params import ProtocolParameters
from liquidtouch.errors import DeviceError
from liquidtouch.protocols import gcl

__all__ = [
    "ROTATION_TOLERANCE_RAD",
    "StartState",
    "StartStateError",
    "check_start_state",
    "read_start_state",
    "recover_start_state",
    "start_pose",
]

logger = logging.getLogger(__name__)

#: the tool's rotation vector may differ from the start pose's by this much [rad] (0.6°,
#: far above a UR's repeatability of ~0.1 mm at the tool, far below a visibly tilted tool)
ROTATION_TOLERANCE_RAD = 0.01
#: grasping states of a finger motion under way, or one stopped half-way (a GRIP cut short)
MOVING_STATES = (gcl.GRASPING, gcl.RELEASING, gcl.POSITIONING)
RECOVER_HINT = "run the same run-trial with --recover to fix it (or do it by hand)"


class StartStateError(DeviceError):
    """The gripper or the arm is not in the start state; the message says how to fix it."""


@dataclass(frozen=True)
class StartState:
    """What the gripper and the arm report before a trial (widths mm, poses m and rad)."""

    grip_state: int
    finger_mm: float
    pose: tuple[float, ...]
    start: tuple[float, ...]
    start_known: bool

    @property
    def holding(self) -> bool:
        return self.grip_state == gcl.HOLDING

    def offset_mm(self) -> tuple[float, float, float]:
        """The tool's position minus the start pose's (x, y, z) [mm]."""
        return tuple((p - s) * 1e3 for p, s in zip(self.pose[:3], self.start[:3], strict=True))

    def at_start(self) -> bool:
        """The tool is at the start pose (within the arm's arrival tolerance)."""
        position = math.dist(self.pose[:3], self.start[:3]) <= POSITION_TOLERANCE_M
        rotation = max(abs(p - s) for p, s in zip(self.pose[3:], self.start[3:], strict=True))
        return position and rotation <= ROTATION_TOLERANCE_RAD

    def describe_arm(self) -> str:
        """Where the tool is relative to the start pose, in words."""
        if self.at_start():
            return "the arm is at its start pose"
        dx, dy, dz = self.offset_mm()
        moved = ", ".join(
            f"{abs(d):.1f} mm {'+' if d > 0 else '-'}{axis}"
            for axis, d in (("x", dx), ("y", dy), ("z", dz))
            if abs(d) >= 0.05
        )
        return f"the arm is off its start pose ({moved or 'rotated'})"

    def problems(self, part_width_mm: float) -> list[str]:
        """What keeps this state from being the start state (empty: it is)."""
        name = f"GRIPSTATE {self.grip_state} {gcl.GRIP_STATES.get(self.grip_state, '?')}"
        out = []
        if self.grip_state == gcl.ERROR:
            out.append(f"the gripper reports a fault ({name})")
        elif self.holding:
            lifted = self.offset_mm()[2] > POSITION_TOLERANCE_M * 1e3
            out.append(
                f"the gripper is holding a part ({name}, fingers at {self.finger_mm:.1f} mm)"
                + (" in the air" if lifted else "")
            )
        elif self.grip_state == gcl.PART_LOST:
            out.append(f"the gripper lost its part ({name}): the bottle may have fallen")
        elif self.grip_state in MOVING_STATES:
            out.append(f"the fingers were stopped mid-motion ({name})")
        elif self.finger_mm < part_width_mm:
            out.append(
                f"the fingers are at {self.finger_mm:.1f} mm, narrower than the bottle "
                f"(part_width_mm {part_width_mm:g})"
            )
        if self.start_known and not self.at_start():
            out.append(self.describe_arm())
        return out


def start_pose(arm: Arm, params: ProtocolParameters) -> list[float] | None:
    """The start pose [m, rad]: the protocol's ``start_pose``, else the arm's (None: unknown)."""
    if params.start_pose is not None:
        return list(params.start_pose)
    own = getattr(arm, "start_pose", None)  # optional: an arm that knows its start pose
    pose = own() if callable(own) else None
    return None if pose is None else check_pose(pose, "arm's start pose")


def read_start_state(gripper: Gripper, arm: Arm, params: ProtocolParameters) -> StartState:
    """Read the gripper's grasping state and finger opening and the arm's pose (queries only)."""
    pose = check_pose(arm.get_pose(), "arm's reported pose")
    start = start_pose(arm, params)
    state = StartState(
        grip_state=int(gripper.grip_state()),
        finger_mm=float(gripper.position_mm()),
        pose=tuple(pose),
        start=tuple(pose if start is None else start),
        start_known=start is not None,
    )
    logger.info(
        "start state: GRIPSTATE %d, fingers %.1f mm, %s",
        state.grip_state, state.finger_mm, state.describe_arm(),
    )  # fmt: skip
    return state


def check_start_state(gripper: Gripper, arm: Arm, params: ProtocolParameters) -> StartState:
    """The start state; :class:`StartStateError` (what is wrong, what to do) for any other."""
    state = read_start_state(gripper, arm, params)
    problems = state.problems(params.part_width_mm)
    if problems:
        raise StartStateError(
            f"not starting the trial: {'; '.join(problems)}; nothing was moved. {RECOVER_HINT}"
        )
    return state


def _move(arm: Arm, pose: Sequence[float], params: ProtocolParameters) -> None:
    arm.move_linear(list(pose), params.lift_speed_m_s, params.lift_acceleration_m_s2)


def recover_start_state(gripper: Gripper, arm: Arm, params: ProtocolParameters) -> StartState:
    """Bring the rig back to its start state (module docstring); the state reached.

    A held bottle is carried back over its start at the height it is at, lowered to the
    start pose and released; without a part, the fingers are opened (``HOME``) and the arm
    moves to the start pose. A fault is acknowledged first. Raises
    :class:`StartStateError` when the start pose is unknown with a bottle held (put it
    down by hand, or give ``start_pose`` in the protocol file) or the state is still
    wrong afterwards.
    """
    state = read_start_state(gripper, arm, params)
    if state.grip_state == gcl.ERROR:
        logger.info("recover: acknowledging the gripper's fault")
        gripper.acknowledge()
        state = read_start_state(gripper, arm, params)
    if not state.problems(params.part_width_mm):
        return state
    if state.grip_state in MOVING_STATES:
        gripper.stop()
    unsettled = state.grip_state in (gcl.PART_LOST, *MOVING_STATES)
    if state.holding and not state.start_known:
        raise StartStateError(
            "cannot recover: the gripper holds a part but the arm's start pose is unknown; "
            "give start_pose in the protocol file, or put the bottle down by hand"
        )
    if not state.holding and (state.finger_mm < params.part_width_mm or unsettled):
        logger.info("recover: opening the fingers")
        gripper.home()  # open before the arm moves: closed fingers would meet the bottle
    if state.holding or (state.start_known and not state.at_start()):
        # over the start at the height the tool is at, then straight down onto it — exactly,
        # with a bottle held: a tool "at" the start within the arm's tolerance may still hold
        # the bottle a millimetre off the table
        start = list(state.start)
        logger.info("recover: moving the arm back over its start pose, then down to it")
        over = [start[0], start[1], max(state.pose[2], start[2]), *start[3:]]
        if math.dist(over[:3], state.pose[:3]) > 0:
            _move(arm, over, params)
        _move(arm, start, params)
    if state.holding:
        logger.info("recover: releasing the bottle on the table")
        gripper.release(params.release_mm, params.release_speed_mm_s)
    return check_start_state(gripper, arm, params)
