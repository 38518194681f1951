"""The simulated lab rig on the network: the gripper, arm and two cameras of a :class:`Rig`.

The rig stands in for the paper's robot (a UR5e arm, a Weiss WSG-50 gripper, two
GelSight sensors at 640 × 480 and 30 fps) so that the lab path -- ``liquidtouch
run-trial`` with its gripper, arm and camera clients -- can be run end to end on one
machine. :class:`RigServer` puts a :class:`Rig` on the network: the gripper as a GCL
server (:mod:`~liquidtouch.sim.rig.gcl_server`, the WSG's real protocol), the arm as a
JSON line endpoint (:mod:`~liquidtouch.sim.rig.arm_server`) and the two sensors as
MJPEG streams (:class:`~liquidtouch.sim.rig.mjpeg.MjpegServer`); the protocols are
those of :mod:`liquidtouch.protocols`, shared with the clients in
:mod:`liquidtouch.acquire`.

The parts, by concept: :mod:`~liquidtouch.sim.rig.state` (the physical state machine,
:class:`Rig`, and what it simulates), :mod:`~liquidtouch.sim.rig.fingers` (the
gripper's commands), :mod:`~liquidtouch.sim.rig.kinematics` (arm and finger motions in
time), :mod:`~liquidtouch.sim.rig.live_sensor` (rendering the gels frame by frame),
:mod:`~liquidtouch.sim.rig.interfaces` (what the servers need of the rig) and this
module (serving); the names are re-exported here.
"""

from __future__ import annotations

import logging
import signal
import threading
from collections.abc import Callable
from typing import Any

from liquidtouch.errors import LiquidTouchError
from liquidtouch.sim.gelsight import SENSOR_NAMES
from liquidtouch.sim.rig.arm_server import ArmServer
from liquidtouch.sim.rig.gcl_server import GclServer
from liquidtouch.sim.rig.interfaces import ArmMove, Motion
from liquidtouch.sim.rig.mjpeg import MjpegServer
from liquidtouch.sim.rig.state import HOME_POSE, Rig

__all__ = ["RigArmModel", "RigGripper", "RigServer", "check_ports", "serve_rig"]

logger = logging.getLogger(__name__)


class RigGripper:
    """The rig's gripper as the GCL server sees it (``interfaces.GripperModel``)."""

    def __init__(self, rig: Rig):
        self.rig = rig

    def begin(self, command: str, args: list[float]) -> Motion:
        self.rig.note(f"gripper {command}")
        return self.rig.begin(command, args)

    def query(self, key: str) -> float:
        self.rig.note(f"gripper {key}?")
        return self.rig.query(key)

    def acknowledge(self) -> None:
        self.rig.note("gripper FSACK")
        self.rig.acknowledge()

    def fast_stop(self) -> None:
        self.rig.raise_fast_stop()


class RigArmModel:
    """The rig's arm as the arm server sees it (``interfaces.ArmModel``)."""

    def __init__(self, rig: Rig):
        self.rig = rig

    def begin_move(self, pose: list[float], speed: float, acceleration: float) -> ArmMove:
        self.rig.note("arm moveL")
        return self.rig.begin_move(pose, speed, acceleration)

    def pose(self) -> list[float]:
        self.rig.note("arm get_pose")
        return self.rig.pose()

    def start_pose(self) -> list[float]:
        self.rig.note("arm start_pose")
        return list(HOME_POSE)

    def stop(self) -> None:
        self.rig.note("arm stop")
        self.rig.stop_arm()

    def truth(self) -> dict[str, Any]:
        return self.rig.truth()

    def status(self) -> dict[str, Any]:
        return self.rig.status()


class RigServer:
    """Serve a :class:`Rig` on ``host``: GCL gripper, JSON arm, two MJPEG camera streams.

    Ports 0 pick free ports; :meth:`endpoints` tells which after :meth:`start`.
    ``cameras=False`` serves no streams (the gripper and arm only).
    """

    def __init__(
        self,
        rig: Rig,
        *,
        host: str = "127.0.0.1",
        gripper_port: int = 0,
        arm_port: int = 0,
        camera_ports: tuple[int, int] = (0, 0),
        cameras: bool = True,
        jpeg_quality: int = 95,
    ):
        self.rig, self.host = rig, host
        self.gcl = GclServer(RigGripper(rig), host=host, port=gripper_port)
        self.arm = ArmServer(RigArmModel(rig), host=host, port=arm_port)
        self.streams: list[MjpegServer] = []
        if cameras:
            self.streams = [
                MjpegServer(
                    (lambda t_s, i=i: rig.frame(i, t_s)),  # the scene at the frame's stamp
                    fps=rig.profile.fps,
                    timed=True,
                    host=host,
                    port=camera_ports[i],
                    quality=jpeg_quality,
                )
                for i in range(len(SENSOR_NAMES))
            ]

    def start(self) -> RigServer:
        try:
            for i in range(len(self.streams)):
                self.rig.sensor(i).prepare()
            self.gcl.start()
            self.arm.start()
            for stream in self.streams:
                stream.start()
        except BaseException as exc:
            logger.info("the rig could not start: %s", exc or type(exc).__name__)
            self.stop()
            raise
        logger.info(
            "rig serving: gripper %s, arm %s, %d camera streams",
            self.gcl.url,
            self.arm.url,
            len(self.streams),
        )
        return self

    def stop(self) -> None:
        for stream in self.streams:
            try:
                stream.stop()
            except Exception as exc:  # stopping the rest anyway
                logger.warning("stopping a camera stream failed: %s", exc)
        self.arm.stop()
        self.gcl.stop()
        logger.info("rig stopped")

    def endpoints(self) -> dict[str, Any]:
        """Where to reach the rig, and its truth (JSON-ready)."""
        return {
            "gripper": self.gcl.url,
            "arm": self.arm.url,
            "cameras": {
                name: stream.url for name, stream in zip(SENSOR_NAMES, self.streams, strict=False)
            },
            "truth": self.rig.truth(),
        }

    def __enter__(self) -> RigServer:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()


def check_ports(gripper_port: int, arm_port: int, camera_port: int) -> None:
    """:class:`LiquidTouchError` unless each is a TCP port (0: any free one); the cameras
    take ``camera_port`` and the next."""
    for name, port, high in (
        ("--gripper-port", gripper_port, 65535),
        ("--arm-port", arm_port, 65535),
        ("--camera-port", camera_port, 65534),
    ):
        if not 0 <= port <= high:
            raise LiquidTouchError(f"{name} {port} is not a TCP port (0-{high})")


def serve_rig(
    rig: Rig,
    host: str,
    ports: tuple[int, int, int],
    *,
    on_ready: Callable[[dict[str, Any]], None],
    poll_s: float = 0.5,
) -> None:
    """Serve ``rig`` on ``host`` (ports: gripper, arm, left camera; 0 any) until Ctrl-C or
    SIGTERM; ``on_ready(endpoints)`` once listening. A camera stream that fails ends it
    with :class:`LiquidTouchError`."""
    gripper_port, arm_port, camera_port = ports
    cameras = (camera_port, camera_port + 1 if camera_port else 0)
    stop = threading.Event()
    previous = signal.getsignal(signal.SIGTERM)
    try:
        signal.signal(signal.SIGTERM, lambda *_: stop.set())
    except ValueError:  # not the main thread (e.g. called from a test's thread)
        previous = None
    server = RigServer(
        rig, host=host, gripper_port=gripper_port, arm_port=arm_port, camera_ports=cameras
    )
    try:
        try:
            server.start()
        except OSError as exc:
            raise LiquidTouchError(f"cannot listen on {host}: {exc.strerror or exc}") from None
        on_ready(server.endpoints())
        try:
            while not stop.wait(poll_s):
                for stream in server.streams:
                    if stream.error is not None:
                        raise LiquidTouchError(f"a camera stream failed: {stream.error}")
        except KeyboardInterrupt:
            pass
    finally:
        server.stop()
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
