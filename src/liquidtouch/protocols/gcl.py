"""The Weiss (Schunk) WSG-50's text command interface, the GCL (Gripper Control Language).

Written once for both sides: :class:`liquidtouch.acquire.grippers.Wsg50Gripper` (the
client) and :mod:`liquidtouch.sim.rig.gcl_server` (the simulated rig's gripper) build
and read their lines with this module. On the real gripper, enable "Use text based
interface" in its web interface; it listens on :data:`DEFAULT_PORT`.

One command per ``\\n``-terminated ASCII line:

==========================  ===============================================
command                     replies
==========================  ===============================================
``FSACK()``                 ``ACK FSACK`` (acknowledges a pending FAST STOP)
``HOME()``                  ``ACK HOME``, then ``FIN HOME`` when the move ends
``GRIP(force, width, v)``   ``ACK GRIP``, ``FIN GRIP``; force [N], expected part width [mm],
                            speed [mm/s]
``RELEASE(pullback, v)``    ``ACK RELEASE``, ``FIN RELEASE``; opening [mm], speed [mm/s]
``MOVE(width, v)``          ``ACK MOVE``, ``FIN MOVE`` (served by the rig; the client
                            does not use it)
``STOP()``                  ``ACK STOP`` (a running motion is answered ``ERR
                            E_CMD_ABORTED`` first)
``POS?``                    ``POS=<width mm>``
``FORCE?``                  ``FORCE=<grip force N>``
``SPEED?``                  ``SPEED=<finger speed mm/s>``
``GRIPSTATE?``              ``GRIPSTATE=<n>`` (:data:`GRIP_STATES`: 0 idle, 1 grasping,
                            2 no part found, 3 part lost, 4 holding, 5 releasing,
                            6 positioning, 7 error)
``VERBOSE=1`` / ``=0``      echoed; verbose ``ERR`` lines add ``: <text>``
``BYE()``                   ``ACK BYE``; the gripper then closes the connection
==========================  ===============================================

Any command may be answered with ``ERR <code>`` (:data:`ERROR_CODES`; in verbose mode
followed by ``: <text>``) instead of its ``ACK``, or instead of its ``FIN`` when the
motion fails (no part found) or is stopped (``E_CMD_ABORTED``). Lines starting with
``@`` (:data:`AUTOSEND_PREFIX`) are the gripper's periodic ``AUTOSEND`` values.
A client that disconnects without ``BYE()`` makes the WSG raise a FAST STOP:
motion commands are refused (``ERR E_ACCESS_DENIED``) until ``FSACK()``.
"""

from __future__ import annotations

import math
import re

__all__ = [
    "ACK",
    "AUTOSEND_PREFIX",
    "BYE",
    "DEFAULT_PORT",
    "ERR",
    "ERROR",
    "ERROR_CODES",
    "E_ACCESS_DENIED",
    "E_ALREADY_RUNNING",
    "E_AXIS_BLOCKED",
    "E_CMD_ABORTED",
    "E_CMD_FAILED",
    "E_CMD_FORMAT_ERROR",
    "E_CMD_UNKNOWN",
    "E_NOT_ENOUGH_PARAMS",
    "E_RANGE_ERROR",
    "FIN",
    "FSACK",
    "GRASPING",
    "GRIP",
    "GRIP_STATES",
    "HOLDING",
    "HOME",
    "IDLE",
    "MAX_ARG_CHARS",
    "MAX_FORCE_N",
    "MAX_SPEED_MM_S",
    "MAX_WIDTH_MM",
    "MIN_FORCE_N",
    "MIN_PULLBACK_MM",
    "MIN_SPEED_MM_S",
    "MOTIONS",
    "MOVE",
    "NO_PART",
    "PART_LOST",
    "POSITIONING",
    "QUERIES",
    "RELEASE",
    "RELEASING",
    "STOP",
    "GclError",
    "call",
    "error_code",
    "error_reply",
    "format_value",
    "parse_args",
    "parse_call",
    "parse_query_reply",
    "query",
    "query_reply",
    "reply",
]

DEFAULT_PORT = 1000
"""The WSG's default TCP port of its command interface."""

# --- limits -------------------------------------------------------------------------------

MAX_WIDTH_MM = 110.0
"""The WSG-50's stroke: finger opening 0-110 mm."""
MIN_FORCE_N = 5.0
"""The WSG-50's smallest grip force [N]."""
MAX_FORCE_N = 80.0
"""The WSG-50's largest grip force [N]."""
MIN_SPEED_MM_S = 0.1
"""The slowest finger speed a command may ask for [mm/s]."""
MAX_SPEED_MM_S = 420.0
"""The WSG-50's fastest finger speed [mm/s]."""
MIN_PULLBACK_MM = 0.1
"""The shortest ``RELEASE`` opening [mm]."""

# --- grasping states (GRIPSTATE?) ---------------------------------------------------------

IDLE, GRASPING, NO_PART, PART_LOST, HOLDING, RELEASING, POSITIONING, ERROR = range(8)
GRIP_STATES = {
    IDLE: "IDLE",
    GRASPING: "GRASPING",
    NO_PART: "NO PART",
    PART_LOST: "PART LOST",
    HOLDING: "HOLDING",
    RELEASING: "RELEASING",
    POSITIONING: "POSITIONING",
    ERROR: "ERROR",
}
"""The WSG's grasping states (``GRIPSTATE?``)."""

# --- commands and replies -----------------------------------------------------------------

HOME, GRIP, RELEASE, MOVE = "HOME", "GRIP", "RELEASE", "MOVE"
STOP, FSACK, BYE = "STOP", "FSACK", "BYE"
MOTIONS = (HOME, GRIP, RELEASE, MOVE)
"""Commands answered ``ACK`` at once and ``FIN`` when the fingers stop."""
QUERIES = ("POS", "FORCE", "SPEED", "GRIPSTATE")
"""Queries ``<KEY>?``, answered ``<KEY>=<value>``."""
ACK, FIN, ERR = "ACK", "FIN", "ERR"
AUTOSEND_PREFIX = "@"
"""Lines starting with this are periodic ``AUTOSEND`` values, not replies."""

E_ACCESS_DENIED = "E_ACCESS_DENIED"
E_ALREADY_RUNNING = "E_ALREADY_RUNNING"
E_AXIS_BLOCKED = "E_AXIS_BLOCKED"
E_CMD_ABORTED = "E_CMD_ABORTED"
E_CMD_FAILED = "E_CMD_FAILED"
E_CMD_FORMAT_ERROR = "E_CMD_FORMAT_ERROR"
E_CMD_UNKNOWN = "E_CMD_UNKNOWN"
E_NOT_ENOUGH_PARAMS = "E_NOT_ENOUGH_PARAMS"
E_RANGE_ERROR = "E_RANGE_ERROR"
ERROR_CODES = (
    E_ACCESS_DENIED,
    E_ALREADY_RUNNING,
    E_AXIS_BLOCKED,
    E_CMD_ABORTED,
    E_CMD_FAILED,
    E_CMD_FORMAT_ERROR,
    E_CMD_UNKNOWN,
    E_NOT_ENOUGH_PARAMS,
    E_RANGE_ERROR,
)
"""The error codes of ``ERR <code>`` replies used here (the WSG has more)."""

_CALL = re.compile(r"^([A-Z]+)\((.*)\)$")


class GclError(Exception):
    """A GCL error reply: ``ERR <code>`` (``code`` like ``E_RANGE_ERROR``), with a text
    for verbose mode. Raised by a gripper model; its server answers it."""

    def __init__(self, code: str, text: str = ""):
        super().__init__(code)
        self.code, self.text = code, text


def call(name: str, *args: float) -> str:
    """A command line: ``call("GRIP", 25, 59, 50)`` is ``GRIP(25.00,59.00,50.00)``."""
    return f"{name}({','.join(f'{a:.2f}' for a in args)})"


def parse_call(line: str) -> tuple[str, str] | None:
    """``(NAME, argument text)`` of a command line (upper case, spaces removed), or ``None``."""
    match = _CALL.match(line.upper().replace(" ", ""))
    return None if match is None else (match.group(1), match.group(2))


_NUMBER = re.compile(r"[+-]?(\d+(\.\d*)?|\.\d+)(E[+-]?\d{1,3})?", re.IGNORECASE)
MAX_ARG_CHARS = 32
"""Longest parameter of a command [characters]."""


def parse_args(arg_text: str) -> list[float] | None:
    """The parameters of a command (``"25.00,59.00"``) as finite floats; ``None`` when one
    is not a plain decimal number (``1_0_0``, ``inf``, ``0x10`` and empty ones are refused,
    though Python's ``float`` would take some of them)."""
    if not arg_text:
        return []
    values = []
    for text in arg_text.split(","):
        if len(text) > MAX_ARG_CHARS or not _NUMBER.fullmatch(text):
            return None
        value = float(text)
        if not math.isfinite(value):
            return None
        values.append(value)
    return values


def reply(word: str, command: str) -> str:
    """``ACK <command>`` or ``FIN <command>``."""
    return f"{word} {command}"


def error_reply(code: str, text: str = "") -> str:
    """``ERR <code>``, with ``: <text>`` when a text is given (verbose mode)."""
    return f"{ERR} {code}{f': {text}' if text else ''}"


def error_code(line: str) -> str | None:
    """The code of an ``ERR`` reply (``"(no code)"`` when it has none); ``None`` otherwise."""
    if not line.startswith(ERR):
        return None
    return line[len(ERR) :].strip() or "(no code)"


def query(key: str) -> str:
    """The query line ``<KEY>?``."""
    return f"{key}?"


def format_value(value: float) -> str:
    """A query reply's number: an integer as such, else three decimals."""
    return str(int(value)) if float(value).is_integer() and abs(value) < 1e9 else f"{value:.3f}"


def query_reply(key: str, value: float) -> str:
    """The reply ``<KEY>=<value>``."""
    return f"{key}={format_value(value)}"


def parse_query_reply(line: str, key: str) -> str | None:
    """The value text of a ``<KEY>=<value>`` reply to ``key``; ``None`` for another line."""
    name, sep, value = line.partition("=")
    return value if sep and name.strip() == key else None
