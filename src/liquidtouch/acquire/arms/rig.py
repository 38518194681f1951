"""The client of the simulated rig's arm endpoint (protocol: :mod:`liquidtouch.protocols.arm`)."""

from __future__ import annotations

import contextlib
import itertools
import logging
import threading
import time
from collections.abc import Sequence
from typing import Any

from liquidtouch._core.checks import is_real
from liquidtouch.acquire.arms.motion import check_move, check_pose, linear_move_duration
from liquidtouch.acquire.device_link import LineConnection
from liquidtouch.errors import DeviceError
from liquidtouch.protocols import arm as wire

__all__ = ["RigArm"]

logger = logging.getLogger(__name__)

MAX_TRUTH = 1e6
"""Largest λ [1/s] or ω [rad/s] taken from the rig's truth."""


class RigArm:
    """The simulated rig's arm endpoint, ``sim://HOST:PORT`` (protocol:
    :mod:`liquidtouch.protocols.arm`)."""

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
            if hello.get("server") != wire.SERVER_NAME:
                raise DeviceError(f"{host}:{port} is not a liquidtouch rig arm (said {hello!r})")
            if hello.get("protocol") != wire.PROTOCOL_VERSION:
                raise DeviceError(
                    f"the rig arm speaks protocol {hello.get('protocol')!r}, this liquidtouch "
                    f"{wire.PROTOCOL_VERSION}; run the same liquidtouch version on both sides"
                )
        except BaseException as exc:
            logger.info("rig arm at %s:%s: %s", host, port, exc or type(exc).__name__)
            self._conn.close()
            raise
        logger.info(
            "connected to the rig arm at %s:%s (protocol %s)", host, port, hello["protocol"]
        )

    def _read_json(self, timeout_s: float, waiting_for: str) -> dict[str, Any]:
        line = self._conn.read_line(timeout_s, waiting_for)
        message = wire.decode(line)
        if message is None:
            self._conn.close()
            logger.info("rig arm sent a line that is not a JSON object: %r", line[:80])
            raise DeviceError(f"the rig arm sent a line that is not a JSON object: {line[:80]!r}")
        return message

    def request(self, cmd: str, timeout_s: float | None = None, **fields: Any) -> dict[str, Any]:
        """Send one request; return its reply (replies to older requests are skipped)."""
        timeout_s = self.reply_timeout_s if timeout_s is None else timeout_s
        with self._lock:
            ident = next(self._ids)
            self._conn.send_line(wire.encode_request(ident, cmd, **fields))
            deadline = time.monotonic() + timeout_s
            while True:
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    raise DeviceError(f"the rig arm did not answer {cmd} within {timeout_s:g} s")
                reply = self._read_json(remaining, f"the reply to {cmd}")
                if reply.get("id") == ident:
                    break
                logger.debug("rig arm: skipped a reply to an older request: %r", reply)
        if not reply.get("ok"):
            logger.info("rig arm refused %s: %s", cmd, reply.get("error"))
            raise DeviceError(f"the rig arm refused {cmd}: {reply.get('error', 'no reason given')}")
        return reply

    def _result(self, reply: dict[str, Any], key: str, cmd: str) -> Any:
        """The reply's ``key``; :class:`DeviceError` when the rig left it out."""
        if key not in reply:
            raise DeviceError(f"the rig arm's reply to {cmd} has no {key!r}")
        return reply[key]

    def get_pose(self) -> list[float]:
        reply = self.request(wire.GET_POSE)
        return check_pose(self._result(reply, "pose", wire.GET_POSE), "arm's reported pose")

    def start_pose(self) -> list[float]:
        """The rig's start pose (its arm's home: the bottle stands between the open fingers)."""
        reply = self.request(wire.START_POSE)
        return check_pose(self._result(reply, "pose", wire.START_POSE), "arm's start pose")

    def move_linear(
        self, pose: Sequence[float], speed_m_s: float, acceleration_m_s2: float
    ) -> list[float]:
        start = self.get_pose()
        target, distance = check_move(start, pose, speed_m_s, acceleration_m_s2)
        duration = linear_move_duration(distance, speed_m_s, acceleration_m_s2)
        try:
            reply = self.request(
                wire.MOVE_L,
                timeout_s=2.0 * duration + self.reply_timeout_s,
                pose=target,
                speed=float(speed_m_s),
                acceleration=float(acceleration_m_s2),
            )
        except BaseException as exc:
            logger.info("rig arm move failed (%s): stopping the arm", exc or type(exc).__name__)
            with contextlib.suppress(DeviceError):
                self.stop()
            raise
        return check_pose(self._result(reply, "pose", wire.MOVE_L), "arm's reported pose")

    def stop(self, deceleration_m_s2: float = 2.0) -> None:
        self.request(wire.STOP, acceleration=float(deceleration_m_s2))

    def truth(self) -> dict[str, Any]:
        """The simulated liquid's ground truth (λ [1/s], ω [rad/s]) and labels; checked:
        :class:`DeviceError` when λ or ω is missing or not a positive finite number."""
        truth = self._result(self.request(wire.TRUTH), "truth", wire.TRUTH)
        if not isinstance(truth, dict):
            raise DeviceError("the rig arm's truth is not a JSON object")
        for key in ("true_decay_rate", "true_angular_frequency"):
            value = truth.get(key)
            if not is_real(value) or not 0 < value < MAX_TRUTH:
                raise DeviceError(f"the rig arm's truth has no valid {key} (got {str(value)[:40]})")
        return truth

    def status(self) -> dict[str, Any]:
        """The rig's state (gripper, arm, trial clock)."""
        return self.request(wire.STATUS)["status"]

    def close(self) -> None:
        self._conn.close()

    def __enter__(self) -> RigArm:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
