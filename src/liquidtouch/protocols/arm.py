"""The simulated rig's arm protocol: one JSON object per ``\\n``-terminated UTF-8 line.

Written once for both sides: :class:`liquidtouch.acquire.arms.RigArm` (the client,
``sim://HOST:PORT``) and :mod:`liquidtouch.sim.rig.arm_server` (the server) build and
read their messages with this module.

On connecting the server sends :func:`greeting`, ``{"server": "liquidtouch-rig-arm",
"protocol": 2}`` (:data:`SERVER_NAME`, :data:`PROTOCOL_VERSION`); a client refuses
another version. Each request carries an ``id`` (an integer the client chooses) and a
``cmd``; its reply carries the same ``id``, ``"ok": true`` and the result, or ``"ok":
false`` and an ``"error"`` text (``"id": null`` when the request could not be read):

==========================================================  ==================================
request                                                     reply (besides ``id``, ``ok``)
==========================================================  ==================================
``{"cmd": "moveL", "pose": [6], "speed": v, "acceleration": a}``  ``"pose"`` when the move has
                                                            ended (a linear move with a
                                                            trapezoidal speed profile); one
                                                            move at a time per connection
``{"cmd": "get_pose"}``                                     ``"pose"``
``{"cmd": "start_pose"}``                                   ``"pose"``: where a trial starts
                                                            and ends (the bottle on the
                                                            table between the open fingers)
``{"cmd": "stop", "acceleration": a}``                      ``"pose"``; a running ``moveL``
                                                            then fails with ``"stopped"``
``{"cmd": "truth"}``                                        ``"truth"``: the simulated liquid's
                                                            λ, ω and labels
``{"cmd": "status"}``                                       ``"status"``: the rig's state
==========================================================  ==================================

Poses are ``[x, y, z, rx, ry, rz]``: position [m] and rotation vector [rad] of the tool
in the base frame; speeds [m/s], accelerations [m/s²]. A line is at most
:data:`MAX_LINE_BYTES` long.
"""

from __future__ import annotations

import json
import math
from typing import Any

__all__ = [
    "COMMANDS",
    "GET_POSE",
    "MAX_LINE_BYTES",
    "MOVE_L",
    "POSE_LENGTH",
    "PROTOCOL_VERSION",
    "SERVER_NAME",
    "START_POSE",
    "STATUS",
    "STOP",
    "STOPPED",
    "TRUTH",
    "ArmError",
    "decode",
    "encode_message",
    "encode_request",
    "error_reply",
    "greeting",
    "ok_reply",
]

PROTOCOL_VERSION = 2
"""The protocol's version; client and server must agree."""
SERVER_NAME = "liquidtouch-rig-arm"
"""The ``server`` field of the greeting."""
MAX_LINE_BYTES = 65536
"""The longest line either side accepts [bytes]."""
POSE_LENGTH = 6

MOVE_L, GET_POSE, STOP, TRUTH, STATUS = "moveL", "get_pose", "stop", "truth", "status"
START_POSE = "start_pose"
COMMANDS = (MOVE_L, GET_POSE, START_POSE, STOP, TRUTH, STATUS)
STOPPED = "stopped"
"""The ``error`` of a ``moveL`` ended by ``stop``."""


class ArmError(Exception):
    """A refused or failed arm request (its text is the reply's ``error``). Raised by an
    arm model; its server answers it."""


def greeting() -> dict[str, Any]:
    """What the server sends first."""
    return {"server": SERVER_NAME, "protocol": PROTOCOL_VERSION}


def encode_request(ident: int, cmd: str, **fields: Any) -> str:
    """A client's request line (without its line end)."""
    return json.dumps({"id": ident, "cmd": cmd, **fields})


def encode_message(message: dict[str, Any]) -> bytes:
    """A server's message as bytes, line end included (NaN refused)."""
    return json.dumps(message, allow_nan=False).encode() + b"\n"


def ok_reply(ident: int, **result: Any) -> dict[str, Any]:
    """A successful reply."""
    return {"id": ident, "ok": True, **result}


def error_reply(ident: int | None, error: str) -> dict[str, Any]:
    """A failed reply (``ident`` ``None``: the request could not be read)."""
    return {"id": ident, "ok": False, "error": error}


def _finite(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(f"number out of range: {text[:40]}")
    return value


def _no_constant(name: str) -> float:
    raise ValueError(f"{name} is not a number")


def decode(line: str | bytes) -> dict[str, Any] | None:
    """The JSON object on ``line``; ``None`` when it is not one, or holds a number that is
    not finite (``1e999``, ``NaN``), an integer of over 4300 digits or nesting too deep
    for the parser."""
    try:
        message = json.loads(line, parse_float=_finite, parse_constant=_no_constant)
    except (ValueError, UnicodeDecodeError, RecursionError):  # JSONDecodeError is a ValueError
        return None
    return message if isinstance(message, dict) else None
