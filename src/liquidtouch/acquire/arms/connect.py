"""Connect to an arm by URL: :func:`open_arm` picks the backend.

- ``ur-rtde://HOST`` -- a UR arm (the paper's UR5e) through the ``ur_rtde`` package
  (``pip install 'liquidtouch[robot]'``; imported only when used): :class:`URArm`.
- ``sim://HOST:PORT`` -- the simulated rig's arm endpoint (``liquidtouch rig serve``),
  over :mod:`liquidtouch.protocols.arm`: :class:`RigArm`.
- ``sim://`` -- an in-process stand-in arm (no network, no physics): :class:`SimArm`.
"""

from __future__ import annotations

from typing import Any

from liquidtouch.acquire.arms.motion import Arm
from liquidtouch.acquire.arms.rig import RigArm
from liquidtouch.acquire.arms.sim import SimArm
from liquidtouch.acquire.arms.ur import URArm
from liquidtouch.acquire.device_link import parse_device_url
from liquidtouch.errors import DeviceError

__all__ = ["ARM_SCHEMES", "open_arm"]

ARM_SCHEMES = ("ur-rtde", "sim")


def open_arm(url: str, **options: Any) -> Arm:
    """Connect to the arm at ``url`` (``ur-rtde://HOST``, ``sim://HOST:PORT`` or ``sim://``).

    ``options`` go to the backend's class (:class:`URArm`, :class:`RigArm`). Raises
    :class:`~liquidtouch.errors.DeviceError` for a bad URL or an unreachable arm.
    """
    address = parse_device_url(url, ARM_SCHEMES, "arm URL")
    if address.scheme == "ur-rtde":
        if not address.host:
            raise DeviceError(f"arm URL {url!r} has no host; use ur-rtde://HOST")
        if address.port is not None:
            raise DeviceError(
                f"arm URL {url!r}: ur_rtde uses the controller's fixed RTDE ports; "
                "give ur-rtde://HOST without a port"
            )
        return URArm(address.host, **options)
    if not address.host and address.port is None:
        return SimArm(**options)
    if not address.host or address.port is None:
        raise DeviceError(
            f"arm URL {url!r}: use sim://HOST:PORT (the port `liquidtouch rig serve` prints) "
            "or sim:// for the in-process stand-in"
        )
    return RigArm(address.host, address.port, **options)
