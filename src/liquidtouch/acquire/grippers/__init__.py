"""Grippers: the bottle's holder, by URL (:func:`open_gripper`): a Weiss WSG-50 or a stand-in.

Takes a gripper URL (``wsg50://HOST[:PORT]``, ``sim://``); gives a :class:`Gripper`:
``grip``, ``release``, ``home``, ``stop`` and the readings (width [mm], force [N],
grasping state), each blocking until done, every wait bounded, every failure a
:class:`~liquidtouch.errors.DeviceError`. A gripper is never opened on close: a held
bottle stays held.

The modules: :mod:`~.base` (the interface and the command checks), :mod:`~.wsg50`
(the WSG-50 client over the GCL, :mod:`liquidtouch.protocols.gcl`), :mod:`~.sim`
(the in-process stand-in) and :mod:`~.connect` (URLs). The WSG-50's limits
(``MAX_WIDTH_MM``, ``MAX_FORCE_N``, ...) and grasping states (``GRIP_STATES``,
``HOLDING``) are the protocol's and are re-exported here.
"""

from liquidtouch.acquire.grippers.base import Gripper, check_grip, check_release
from liquidtouch.acquire.grippers.connect import GRIPPER_SCHEMES, open_gripper
from liquidtouch.acquire.grippers.sim import SimGripper
from liquidtouch.acquire.grippers.wsg50 import GripperCommandError, Wsg50Gripper
from liquidtouch.protocols.gcl import (
    DEFAULT_PORT as GCL_DEFAULT_PORT,
)
from liquidtouch.protocols.gcl import (
    GRIP_STATES,
    HOLDING,
    MAX_FORCE_N,
    MAX_WIDTH_MM,
)

__all__ = [
    "GCL_DEFAULT_PORT",
    "GRIPPER_SCHEMES",
    "GRIP_STATES",
    "HOLDING",
    "MAX_FORCE_N",
    "MAX_WIDTH_MM",
    "Gripper",
    "GripperCommandError",
    "SimGripper",
    "Wsg50Gripper",
    "check_grip",
    "check_release",
    "open_gripper",
]
