"""Arms: what lifts and pushes the bottle, by URL (:func:`open_arm`): a UR arm, the rig's, or none.

Takes an arm URL (``ur-rtde://HOST``, ``sim://HOST:PORT``, ``sim://``); gives an
:class:`Arm`: ``move_linear`` (a straight ``moveL``, blocking until it arrives, every
move checked against :data:`MAX_SPEED_M_S`, :data:`MAX_ACCELERATION_M_S2` and
:data:`MAX_STEP_M`), ``get_pose``, ``stop``, ``close``; every failure a
:class:`~liquidtouch.errors.DeviceError`.

Poses are ``[x, y, z, rx, ry, rz]``: position [m] and rotation vector [rad] of the tool
in the base frame, as UR controllers use them; speeds [m/s], accelerations [m/s²].

The modules: :mod:`~.motion` (the interface, limits and checks), :mod:`~.ur` (a
Universal Robots arm through ``ur_rtde``: ``moveL`` run asynchronously and polled, so
that a timeout or Ctrl-C can stop it with ``stopL``), :mod:`~.rig` (the simulated rig's
arm, protocol :mod:`liquidtouch.protocols.arm`), :mod:`~.sim` (the in-process stand-in)
and :mod:`~.connect` (URLs).
"""

from liquidtouch.acquire.arms.connect import ARM_SCHEMES, open_arm
from liquidtouch.acquire.arms.motion import (
    MAX_ACCELERATION_M_S2,
    MAX_SPEED_M_S,
    MAX_STEP_M,
    POSITION_TOLERANCE_M,
    Arm,
    check_move,
    check_pose,
    linear_move_duration,
)
from liquidtouch.acquire.arms.rig import RigArm
from liquidtouch.acquire.arms.sim import SimArm
from liquidtouch.acquire.arms.ur import URArm
from liquidtouch.protocols.arm import PROTOCOL_VERSION as RIG_ARM_PROTOCOL

__all__ = [
    "ARM_SCHEMES",
    "MAX_ACCELERATION_M_S2",
    "MAX_SPEED_M_S",
    "MAX_STEP_M",
    "POSITION_TOLERANCE_M",
    "RIG_ARM_PROTOCOL",
    "Arm",
    "RigArm",
    "SimArm",
    "URArm",
    "check_move",
    "check_pose",
    "linear_move_duration",
    "open_arm",
]
