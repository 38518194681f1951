"""The arm that lifts and pushes the bottle: a Universal Robots arm, the simulated rig's, or none.

:func:`open_arm` picks the backend from a URL:

- ``ur-rtde://HOST`` -- a UR arm (the paper's UR5e) through the ``ur_rtde`` package
  (``pip install 'liquidtouch[robot]'``; imported only when used). Moves are
  ``moveL`` in the base frame, run asynchronously and polled, so that a timeout or
  Ctrl-C can stop them (``stopL``); the pose is ``getActualTCPPose``.
- ``sim://HOST:PORT`` -- the simulated rig's arm endpoint (``liquidtouch rig serve``),
  over the line protocol below.
- ``sim://`` -- an in-process stand-in arm (no network, no physics): dry runs and tests.

Poses are ``[x, y, z, rx, ry, rz]``: position [m] and rotation vector [rad] of the tool
in the base frame, as UR controllers use them; speeds [m/s], accelerations [m/s²].

**The rig's arm protocol** (one JSON object per ``\\n``-terminated line, UTF-8). On
connecting the server sends ``{"server": "liquidtouch-rig-arm", "protocol": 1}``. Each
request carries an ``id`` (an integer the client chooses) and a ``cmd``; its reply
carries the same ``id``, ``"ok": true`` and the result, or ``"ok": false`` and an
``"error"`` text:

==========================================================  ==================================
request                                                     reply (besides ``id``, ``ok``)
==========================================================  ==================================
``{"cmd": "moveL", "pose": [6], "speed": v, "acceleration": a}``  ``"pose"`` when the move has
                                                            ended (a linear move with a
                                                            trapezoidal speed profile)
``{"cmd": "get_pose"}``                                     ``"pose"``
``{"cmd": "stop", "acceleration": a}``                      ``"pose"``; a running ``moveL``
                                                            then fails with ``"stopped"``
``{"cmd": "truth"}``                                        ``"truth"``: the simulated liquid's
                                                            λ, ω and labels
``{"cmd": "status"}``                                       ``"status"``: the rig's state
==========================================================  ==================================
"""

from __future__ import annotations

import contextlib
import itertools
import json
import math
import threading
import time
from collections.abc import Sequence
from typing import Any, Protocol, runtime_checkable

from liquidtouch.acquire.gripper import LineConnection, parse_device_url
from liquidtouch.errors import DeviceError

ARM_SCHEMES = ("ur-rtde", "sim")
MAX_SPEED_M_S = 1.0
"""Fastest tool speed liquidtouch commands [m/s] (a push is ~0.1 m/s)."""
MAX_ACCELERATION_M_S2 = 10.0
"""Largest tool acceleration liquidtouch commands [m/s²]."""
MAX_STEP_M = 0.3
"""Longest single move liquidtouch commands [m]: a longer one is a unit mistake."""
POSITION_TOLERANCE_M = 0.002
"""A move has arrived when the tool is this close to the target [m]."""
RIG_ARM_PROTOCOL = 1


def linear_move_duration(distance_m: float, speed_m_s: float, acceleration_m_s2: float) -> float:
    """Duration [s] of a straight move with a trapezoidal speed profile (as UR's ``moveL``).

    Accelerates at ``acceleration_m_s2`` to ``speed_m_s``, cruises, decelerates; a short
    move that never reaches the speed is a triangle.
    """
    d, v, a = abs(distance_m), speed_m_s, acceleration_m_s2
    if d == 0:
        return 0.0
    if d >= v * v / a:
        return d / v + v / a
    return 2.0 * math.sqrt(d / a)


def check_pose(pose: Sequence[float], what: str = "pose") -> list[float]:
    """``pose`` as 6 floats; :class:`DeviceError` unless 6 finite numbers."""
    try:
        values = [float(v) for v in pose]
    except (TypeError, ValueError):
        raise DeviceError(
            f"the {what} must be 6 numbers [x, y, z, rx, ry, rz], got {pose!r}"
        ) from None
    if len(values) != 6 or not all(math.isfinite(v) for v in values):
        raise DeviceError(
            f"the {what} must be 6 finite numbers [x, y, z, rx, ry, rz], got {pose!r}"
        )
    return values


def check_move(
    start: Sequence[float], target: Sequence[float], speed_m_s: float, acceleration_m_s2: float
) -> tuple[list[float], float]:
    """Validate a linear move; return the target pose and the move's distance [m]."""
    target = check_pose(target, "target pose")
    for name, value, high, unit in (
        ("speed", speed_m_s, MAX_SPEED_M_S, "m/s"),
        ("acceleration", acceleration_m_s2, MAX_ACCELERATION_M_S2, "m/s²"),
    ):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise DeviceError(f"arm {name} must be a number of {unit}, got {value!r}")
        if not 0 < value <= high:
            raise DeviceError(f"arm {name} {value!r} {unit} is outside (0, {high:g}] {unit}")
    distance = math.dist(start[:3], target[:3])
    if distance > MAX_STEP_M:
        raise DeviceError(
            f"refusing an arm move of {distance * 1e3:.0f} mm (more than {MAX_STEP_M * 1e3:.0f} "
            "mm in one move): poses are in metres"
        )
    return target, distance


@runtime_checkable
class Arm(Protocol):
    """What the trial protocol needs from an arm (module docstring: units)."""

    url: str

    def get_pose(self) -> list[float]:
        """The tool pose now."""

    def move_linear(self, pose: Sequence[float], speed_m_s: float, acceleration_m_s2: float):
        """Move the tool in a straight line to ``pose``; blocks until it arrives."""

    def stop(self, deceleration_m_s2: float = 2.0) -> None:
        """Stop any motion now (decelerating at ``deceleration_m_s2``)."""

    def close(self) -> None:
        """Disconnect (stops nothing that is still held)."""


def _import_ur_rtde() -> tuple[Any, Any]:
    try:
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
        rtde_control, rtde_receive = modules if modules is not None else _import_ur_rtde()
        self.url = f"ur-rtde://{host}"
        self.move_margin_s = float(move_margin_s)
        self.poll_s = float(poll_s)
        try:
            self._receive = rtde_receive.RTDEReceiveInterface(host)
            self._control = rtde_control.RTDEControlInterface(host)
        except RuntimeError as exc:
            raise DeviceError(f"cannot connect to the UR arm at {host}: {exc}") from None

    def get_pose(self) -> list[float]:
        return check_pose(self._receive.getActualTCPPose(), "arm's reported pose")

    def _check_safety(self) -> None:
        for flag, what in (
            ("isProtectiveStopped", "protective stop"),
            ("isEmergencyStopped", "emergency stop"),
        ):
            check = getattr(self._receive, flag, None)
            if check is not None and check():
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
        except BaseException:
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
                except RuntimeError:
                    pass

    def __enter__(self) -> URArm:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class RigArm:
    """The simulated rig's arm endpoint (``sim://HOST:PORT``; module docstring: the protocol)."""

    def __init__(
        self,
        host: str,
        port: int,
        *,
        connect_timeout_s: float = 5.0,
        reply_timeout_s: float = 5.0,
    ):
        self.url = f"sim://{host}:{port}"
        self.reply_timeout_s = float(reply_timeout_s)
        self._ids = itertools.count(1)
        self._lock = threading.RLock()
        self._conn = LineConnection(
            host, port, connect_timeout_s=connect_timeout_s, what=f"rig arm at {host}:{port}"
        )
        try:
            hello = self._read_json(self.reply_timeout_s, "the rig arm's greeting")
            if hello.get("server") != "liquidtouch-rig-arm":
                raise DeviceError(f"{host}:{port} is not a liquidtouch rig arm (said {hello!r})")
            if hello.get("protocol") != RIG_ARM_PROTOCOL:
                raise DeviceError(
                    f"the rig arm speaks protocol {hello.get('protocol')!r}, this liquidtouch "
                    f"{RIG_ARM_PROTOCOL}; run the same liquidtouch version on both sides"
                )
        except BaseException:
            self._conn.close()
            raise

    def _read_json(self, timeout_s: float, waiting_for: str) -> dict[str, Any]:
        line = self._conn.read_line(timeout_s, waiting_for)
        try:
            message = json.loads(line)
        except json.JSONDecodeError:
            message = None
        if not isinstance(message, dict):
            self._conn.close()
            raise DeviceError(f"the rig arm sent a line that is not a JSON object: {line[:80]!r}")
        return message

    def request(self, cmd: str, timeout_s: float | None = None, **fields: Any) -> dict[str, Any]:
        """Send one request; return its reply (replies to older requests are skipped)."""
        timeout_s = self.reply_timeout_s if timeout_s is None else timeout_s
        with self._lock:
            ident = next(self._ids)
            self._conn.send_line(json.dumps({"id": ident, "cmd": cmd, **fields}))
            deadline = time.monotonic() + timeout_s
            while True:
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    raise DeviceError(f"the rig arm did not answer {cmd} within {timeout_s:g} s")
                reply = self._read_json(remaining, f"the reply to {cmd}")
                if reply.get("id") == ident:
                    break
        if not reply.get("ok"):
            raise DeviceError(f"the rig arm refused {cmd}: {reply.get('error', 'no reason given')}")
        return reply

    def get_pose(self) -> list[float]:
        return check_pose(self.request("get_pose")["pose"], "arm's reported pose")

    def move_linear(
        self, pose: Sequence[float], speed_m_s: float, acceleration_m_s2: float
    ) -> list[float]:
        start = self.get_pose()
        target, distance = check_move(start, pose, speed_m_s, acceleration_m_s2)
        duration = linear_move_duration(distance, speed_m_s, acceleration_m_s2)
        try:
            reply = self.request(
                "moveL",
                timeout_s=2.0 * duration + self.reply_timeout_s,
                pose=target,
                speed=float(speed_m_s),
                acceleration=float(acceleration_m_s2),
            )
        except BaseException:
            with contextlib.suppress(DeviceError):
                self.stop()
            raise
        return check_pose(reply["pose"], "arm's reported pose")

    def stop(self, deceleration_m_s2: float = 2.0) -> None:
        self.request("stop", acceleration=float(deceleration_m_s2))

    def truth(self) -> dict[str, Any]:
        """The simulated liquid's ground truth (λ, ω) and labels."""
        return self.request("truth")["truth"]

    def status(self) -> dict[str, Any]:
        """The rig's state (gripper, arm, trial clock)."""
        return self.request("status")["status"]

    def close(self) -> None:
        self._conn.close()

    def __enter__(self) -> RigArm:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class SimArm:
    """An in-process stand-in arm: the pose jumps (``time_scale`` > 0: moves) to targets."""

    def __init__(
        self, pose: Sequence[float] = (0.4, 0.0, 0.2, 0.0, math.pi, 0.0), *, time_scale: float = 0.0
    ):
        self.url = "sim://"
        self.pose = check_pose(pose)
        self.time_scale = float(time_scale)
        self.moves: list[list[float]] = []
        self.stops = 0
        self.closed = False

    def get_pose(self) -> list[float]:
        return list(self.pose)

    def move_linear(
        self, pose: Sequence[float], speed_m_s: float, acceleration_m_s2: float
    ) -> list[float]:
        if self.closed:
            raise DeviceError("the simulated arm is closed")
        target, distance = check_move(self.pose, pose, speed_m_s, acceleration_m_s2)
        if self.time_scale > 0:
            time.sleep(
                self.time_scale * linear_move_duration(distance, speed_m_s, acceleration_m_s2)
            )
        self.pose = target
        self.moves.append(list(target))
        return list(target)

    def stop(self, deceleration_m_s2: float = 2.0) -> None:
        self.stops += 1

    def close(self) -> None:
        self.closed = True

    def __enter__(self) -> SimArm:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


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
