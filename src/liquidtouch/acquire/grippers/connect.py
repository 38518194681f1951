"""Connect to a gripper by URL: :func:`open_gripper` picks the backend.

- ``wsg50://HOST[:PORT]`` -- a Weiss (Schunk) WSG-50 over its TCP text command
  interface, the GCL (:mod:`liquidtouch.protocols.gcl`; default port 1000). The
  simulated rig (``liquidtouch rig serve``) speaks the same protocol.
- ``sim://`` -- an in-process simulated gripper (no network): for dry runs and tests.
"""

from __future__ import annotations

from liquidtouch.acquire.device_link import parse_device_url
from liquidtouch.acquire.grippers.base import Gripper
from liquidtouch.acquire.grippers.sim import SimGripper
from liquidtouch.acquire.grippers.wsg50 import Wsg50Gripper
from liquidtouch.errors import DeviceError
from liquidtouch.protocols import gcl

__all__ = ["GRIPPER_SCHEMES", "open_gripper"]

GRIPPER_SCHEMES = ("wsg50", "sim")


def open_gripper(url: str, **options: float) -> Gripper:
    """Connect to the gripper at ``url`` (``wsg50://HOST[:PORT]`` or ``sim://``).

    ``options`` go to :class:`Wsg50Gripper` (``connect_timeout_s``, ``ack_timeout_s``,
    ``motion_timeout_s``). Raises :class:`~liquidtouch.errors.DeviceError` for a bad
    URL or an unreachable gripper.
    """
    address = parse_device_url(url, GRIPPER_SCHEMES, "gripper URL")
    if address.scheme == "sim":
        if address.host or address.port:
            raise DeviceError(
                f"gripper URL {url!r}: sim:// is the in-process simulated gripper and takes "
                "no address; the simulated rig's gripper speaks the real protocol: use "
                "wsg50://HOST:PORT with the port `liquidtouch rig serve` prints"
            )
        return SimGripper()
    if not address.host:
        raise DeviceError(f"gripper URL {url!r} has no host; use wsg50://HOST[:PORT]")
    return Wsg50Gripper(address.host, address.port or gcl.DEFAULT_PORT, **options)
