"""The trial protocol's parameters: :class:`ProtocolParameters`, read from a TOML file
(:func:`load_protocol`) or a mapping (:func:`protocol_from_mapping`).

Used by :func:`liquidtouch.acquire.protocol.run_trial` (see its module docstring).
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from liquidtouch._core.containers import CONTAINERS
from liquidtouch.acquire.arms import linear_move_duration
from liquidtouch.errors import LiquidTouchError

__all__ = [
    "MAX_PROTOCOL_BYTES",
    "ProtocolParameters",
    "load_protocol",
    "protocol_from_mapping",
    "trial_parameters",
]

MAX_PROTOCOL_BYTES = 64 * 1024


class ProtocolParameters(BaseModel):
    """The trial protocol's parameters (units in the names; defaults: the paper's where it
    gives them: a ~25 N grasp, a short lateral push, 13 s of recording after it).

    The push defaults (15 mm at 0.1 m/s and 1 m/s², i.e. 0.25 s) are those of the
    simulator's trials (10-20 mm over 0.25-0.35 s), which move the GelSight markers
    by a few pixels at the push and leave a sub-pixel ring-down.
    """

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True)

    grasp_force_n: float = Field(25.0, ge=5.0, le=80.0)
    part_width_mm: float = Field(59.0, ge=0.0, le=110.0)
    """The bottle's width across the fingers [mm] (GRIP's expected part width)."""
    grasp_speed_mm_s: float = Field(50.0, gt=0.0, le=420.0)
    lift_mm: float = Field(50.0, ge=5.0, le=200.0)
    lift_speed_m_s: float = Field(0.05, gt=0.0, le=0.25)
    lift_acceleration_m_s2: float = Field(0.5, gt=0.0, le=5.0)
    settle_s: float = Field(1.0, ge=0.0, le=60.0)
    """Wait after the lift, before recording [s]."""
    pre_push_s: float = Field(1.0, ge=0.2, le=30.0)
    """Recording before the push starts [s]."""
    push_axis: Literal["x", "y"] = "x"
    """Base-frame axis of the push: the bottle's length (the slosh direction)."""
    push_distance_mm: float = Field(15.0, ge=-100.0, le=100.0)
    """Signed push distance along ``push_axis`` [mm]; at least 1 mm either way."""
    push_speed_m_s: float = Field(0.1, gt=0.0, le=0.5)
    push_acceleration_m_s2: float = Field(1.0, gt=0.0, le=5.0)
    hold_s: float = Field(13.0, ge=2.0, le=600.0)
    """Recording after the push has ended [s]: the ring-down."""
    release_mm: float = Field(10.0, gt=0.0, le=110.0)
    release_speed_mm_s: float = Field(20.0, gt=0.0, le=420.0)
    log_interval_s: float = Field(1.0, ge=0.1, le=60.0)
    """How often the gripper's readings and the arm's pose are logged while holding [s]."""
    camera_profile: Literal["raw", "mini", "r15", "digit"] = "raw"
    """The cameras' sensor profile (``acquire.cameras.PROFILES``: ``raw``, ``mini``, ``r15``,
    ``digit``; ``run-trial --sensor``)."""
    recording_format: Literal["ffv1", "png"] = "ffv1"
    max_pushes: int = Field(1, ge=1, le=10)
    """Pushes at most (``run-trial --max-pushes``): after a hold whose combined answer misses
    a ``--until-std`` target, the bottle is pushed again, back and forth along ``push_axis``
    (never more than one push from where it was lifted); at most 10 (about 2.5 min of
    holds at the default ``hold_s``)."""
    container: str | None = None
    """The container's catalogue name (``run-trial --plan``: the push is planned for it)."""
    start_pose: tuple[float, float, float, float, float, float] | None = None
    """The tool pose [x, y, z m; rx, ry, rz rad] the bottle is grasped at, on the table;
    the trial starts and ends there (default: the arm's own start pose, e.g. the
    simulated rig's; an arm without one starts wherever it is:
    :mod:`liquidtouch.acquire.start_state`)."""

    def model_post_init(self, _context: Any) -> None:
        if abs(self.push_distance_mm) < 1.0:
            raise ValueError("push_distance_mm must be at least 1 mm either way")
        if self.container is not None and self.container not in CONTAINERS:
            raise ValueError(
                f"container {self.container!r} is not in the catalogue ({', '.join(CONTAINERS)})"
            )

    @property
    def push_duration_s(self) -> float:
        """How long the push's ``moveL`` takes [s] (trapezoidal speed profile)."""
        return linear_move_duration(
            self.push_distance_mm * 1e-3, self.push_speed_m_s, self.push_acceleration_m_s2
        )

    @property
    def recording_s(self) -> float:
        """Length of the recording [s]: before, during and after the push."""
        return self.pre_push_s + self.push_duration_s + self.hold_s


def _first_error(exc: ValidationError) -> str:
    first = exc.errors()[0]
    where = ".".join(str(p) for p in first["loc"]) or "(file)"
    return f"{where}: {first['msg']}"


def protocol_from_mapping(
    values: Mapping[str, object], source: str = "protocol"
) -> ProtocolParameters:
    """Validated :class:`ProtocolParameters`; :class:`LiquidTouchError` names the bad field."""
    try:
        return ProtocolParameters.model_validate(dict(values))
    except ValidationError as exc:
        raise LiquidTouchError(f"{source}: {_first_error(exc)}") from None


def load_protocol(path: str | Path) -> ProtocolParameters:
    """Read a protocol TOML file: top-level keys of :class:`ProtocolParameters`, all optional.

    ```toml
    grasp_force_n = 25.0
    push_distance_mm = 15.0
    hold_s = 13.0
    ```
    """
    path = Path(path)
    try:
        size = path.stat().st_size
        if size > MAX_PROTOCOL_BYTES:
            raise LiquidTouchError(
                f"{path}: a protocol file is at most 64 KiB, this is {size} bytes"
            )
        values = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise LiquidTouchError(f"{path} is not valid TOML: {exc}") from None
    except UnicodeDecodeError:
        raise LiquidTouchError(f"{path} is not UTF-8 text") from None
    except FileNotFoundError:
        raise LiquidTouchError(f"protocol file {path} not found") from None
    except OSError as exc:
        raise LiquidTouchError(f"cannot read {path}: {exc.strerror or exc}") from None
    return protocol_from_mapping(values, str(path))


def trial_parameters(
    protocol: str | Path | None = None,
    *,
    hold_s: float | None = None,
    camera_profile: str | None = None,
    max_pushes: int | None = None,
) -> ProtocolParameters:
    """The protocol file's parameters (default: the paper's) with ``hold_s`` [s],
    ``camera_profile`` and ``max_pushes`` overriding it when given; :class:`LiquidTouchError`
    names a bad one."""
    params = load_protocol(protocol) if protocol is not None else ProtocolParameters()
    overrides: dict[str, object] = {}
    if hold_s is not None:
        if not math.isfinite(hold_s):
            raise LiquidTouchError(f"--seconds must be a finite number, got {hold_s}")
        overrides["hold_s"] = hold_s
    if camera_profile is not None:
        overrides["camera_profile"] = str(camera_profile)
    if max_pushes is not None:
        overrides["max_pushes"] = max_pushes
    options = {"hold_s": "--seconds", "camera_profile": "--sensor", "max_pushes": "--max-pushes"}
    for key, value in overrides.items():  # one at a time: the error names its option
        option = options[key]
        params = protocol_from_mapping({**params.model_dump(), key: value}, option)
    return params
