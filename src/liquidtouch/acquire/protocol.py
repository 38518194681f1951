"""One trial on the robot: grasp, lift, record, push, hold, stop, lower, release.

:func:`run_trial` drives a :class:`~liquidtouch.acquire.grippers.Gripper`, an
:class:`~liquidtouch.acquire.arms.Arm` and the GelSight cameras (through
:class:`~liquidtouch.acquire.recording.Recorder`) through the paper's protocol
(Huang, Guo, Yuan, RSS 2022: the gripper grasps the bottle with about 25 N, the
arm lifts it, gives it a short lateral push and holds still while the sensors
record the sloshing), with the parameters of :class:`ProtocolParameters` (a TOML
file: :func:`load_protocol`):

1. the cameras are opened and warmed up (a camera that does not deliver stops
   the trial before the robot moves);
2. ``GRIP`` with ``grasp_force_n`` on a part of ``part_width_mm``; the gripper
   must report that it holds the part;
3. lift by ``lift_mm`` (``moveL`` straight up), wait ``settle_s``;
4. start recording, wait ``pre_push_s``;
5. push: ``moveL`` by ``push_distance_mm`` along the base ``push_axis`` at
   ``push_speed_m_s`` / ``push_acceleration_m_s2`` (a trapezoidal speed profile);
6. hold still ``hold_s`` while recording (the gripper must keep holding; its
   readings and the arm's pose are logged every ``log_interval_s``);
7. stop recording, lower by ``lift_mm``, release (``RELEASE`` by ``release_mm``);
8. write the trial: meta.json (last) gets the parameters, the push's times on
   the recording's clock, the arm's poses and the gripper's readings.

**Safety.** On any error or Ctrl-C, at any step: the arm is stopped, the gripper
is left holding (it is never opened, so a lifted bottle is not dropped) and the
recording is aborted, so no trial directory appears (nothing looks complete).
Putting the bottle down is then the operator's job.
"""

from __future__ import annotations

import json
import logging
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from liquidtouch.acquire.arms import Arm
from liquidtouch.acquire.deadlines import TRIAL_READ_TIMEOUT_S
from liquidtouch.acquire.grippers import Gripper
from liquidtouch.acquire.protocol_params import (
    ProtocolParameters,
)
from liquidtouch.acquire.recording import Recorder
from liquidtouch.errors import DeviceError
from liquidtouch.protocols import gcl

__all__ = [
    "AXES",
    "TrialLog",
    "TrialRun",
    "failed_run_dir",
    "make_recorder",
    "run_trial",
    "write_failed_run",
]

logger = logging.getLogger(__name__)

AXES = {"x": 0, "y": 1}


@dataclass
class TrialLog:
    """What happened, on :func:`time.monotonic` [s]: events, poses, gripper readings."""

    events: list[dict[str, Any]] = field(default_factory=list)
    poses: dict[str, list[float]] = field(default_factory=dict)
    arm_log: list[dict[str, Any]] = field(default_factory=list)
    gripper_readings: list[dict[str, Any]] = field(default_factory=list)
    on_event: Callable[[str, float], None] | None = field(default=None, repr=False)

    def event(self, name: str, **data: Any) -> float:
        t = time.monotonic()
        self.events.append({"event": name, "t_s": t, **data})
        logger.info("event %s at %.3f s", name, t)
        if self.on_event is not None:
            self.on_event(name, t)
        return t

    def pose(self, name: str, arm: Arm) -> list[float]:
        pose = arm.get_pose()
        self.poses[name] = pose
        self.arm_log.append({"t_s": time.monotonic(), "pose": pose})
        return pose

    def gripper(self, gripper: Gripper, when: str) -> dict[str, Any]:
        reading = {
            "t_s": time.monotonic(),
            "when": when,
            "position_mm": gripper.position_mm(),
            "force_n": gripper.force_n(),
            "grip_state": gripper.grip_state(),
        }
        self.gripper_readings.append(reading)
        return reading

    def to_dict(self) -> dict[str, Any]:
        return {
            "events": self.events,
            "poses": self.poses,
            "arm_log": self.arm_log,
            "gripper_readings": self.gripper_readings,
        }


@dataclass
class TrialRun:
    """A finished trial: its directory, the recording's summary and the log."""

    trial_dir: Path
    summary: Any
    log: TrialLog
    push_start_s: float
    push_end_s: float


def _offset(pose: Sequence[float], axis: int, delta_m: float) -> list[float]:
    moved = list(pose)
    moved[axis] += delta_m
    return moved


def _wait(seconds: float, check: Callable[[], None], step_s: float = 0.05) -> None:
    """Sleep ``seconds`` in short steps, calling ``check()`` between them."""
    end = time.monotonic() + seconds
    while True:
        check()
        remaining = end - time.monotonic()
        if remaining <= 0:
            return
        time.sleep(min(step_s, remaining))


def make_recorder(
    camera_sources, out_dir, *, names, params, labels, on_frame=None, **camera_timeouts
):
    """The trial's :class:`Recorder` (``run_trial``'s default ``recorder_factory``).

    ``camera_timeouts``: ``open_timeout_s``, ``read_timeout_s`` (default
    :data:`~liquidtouch.acquire.deadlines.TRIAL_READ_TIMEOUT_S`), ``warmup_timeout_s`` [s].
    """
    camera_timeouts.setdefault("read_timeout_s", TRIAL_READ_TIMEOUT_S)
    return Recorder(
        camera_sources,
        out_dir,
        names=names,
        profile=params.camera_profile,
        fmt=params.recording_format,
        labels=labels,
        on_frame=on_frame,
        **camera_timeouts,
    )


def failed_run_dir(out_dir: str | Path) -> Path:
    """Where a failed run's record goes: ``DIR.failed`` next to the trial directory."""
    out = Path(out_dir)
    return out.with_name(out.name + ".failed")


def write_failed_run(
    out_dir: str | Path, log: TrialLog, error: BaseException, **extra: Any
) -> Path:
    """Write ``DIR.failed/run.json`` (the events, arm poses, gripper readings and the error):
    a record of what happened, never something that looks like a trial."""
    target = failed_run_dir(out_dir)
    target.mkdir(parents=True, exist_ok=True)
    record = {
        "error": f"{type(error).__name__}: {error}",
        "clock": "time.monotonic",
        "failed_at_s": time.monotonic(),
        **log.to_dict(),
        **extra,
    }
    path = target / "run.json"
    path.write_text(json.dumps(record, indent=1, default=str), encoding="utf-8")
    return path


def _safe(action: Callable[[], object], failures: list[str], what: str) -> None:
    """Run a clean-up step; a failure (or a second Ctrl-C) is noted, never raised."""
    try:
        action()
    except BaseException as exc:  # clean-up must go on: the next steps matter too
        failures.append(f"{what}: {type(exc).__name__}: {exc}")


def run_trial(
    gripper: Gripper,
    arm: Arm,
    camera_sources: Sequence[str],
    out_dir: str | Path,
    params: ProtocolParameters | None = None,
    labels: Mapping[str, object] | None = None,
    *,
    names: Sequence[str] | None = None,
    extra_meta: Mapping[str, object] | None = None,
    on_step: Callable[[str], None] | None = None,
    recorder_factory: Callable[..., Any] = make_recorder,
    on_event: Callable[[str, float], None] | None = None,
    camera_timeouts: Mapping[str, float] | None = None,
) -> TrialRun:
    """Run one trial (module docstring: the steps and the safety rules); return it.

    ``camera_sources`` go to the :class:`~liquidtouch.acquire.recording.Recorder`
    (``names``: the sensors' names, default ``left``, ``right``); ``labels`` become
    meta.json labels; ``extra_meta`` adds meta.json fields. ``on_step(name)`` is
    called as each step begins (for progress output); ``on_event(name, t_s)`` as each
    event is logged [s, :func:`time.monotonic`] (the live estimate takes the push and the
    end of the hold from them). ``camera_timeouts`` (``open_timeout_s``,
    ``read_timeout_s``, ``warmup_timeout_s`` [s]) go to ``recorder_factory``
    (:func:`make_recorder`). The trial directory ``out_dir`` appears only when everything
    succeeded; a failed run writes ``DIR.failed/run.json`` (:func:`write_failed_run`).
    """
    params = ProtocolParameters() if params is None else params
    axis = AXES[params.push_axis]
    report = on_step or (lambda _name: None)

    def step(name: str) -> None:
        logger.info("trial step: %s", name)
        report(name)

    log = TrialLog(on_event=on_event)
    recorder = recorder_factory(
        list(camera_sources),
        out_dir,
        names=names,
        params=params,
        labels=dict(labels or {}),
        **dict(camera_timeouts or {}),
    )
    try:
        step("cameras")
        recorder.open()
        start = log.pose("start", arm)

        step("grasp")
        log.event("grasp", force_n=params.grasp_force_n, part_width_mm=params.part_width_mm)
        gripper.grip(params.grasp_force_n, params.part_width_mm, params.grasp_speed_mm_s)
        log.gripper(gripper, "grasped")

        step("lift")
        lifted = _offset(start, 2, params.lift_mm * 1e-3)
        log.event("lift")
        arm.move_linear(lifted, params.lift_speed_m_s, params.lift_acceleration_m_s2)
        lifted = log.pose("lifted", arm)
        _wait(params.settle_s, lambda: None)

        step("record")
        recorder.start()
        log.event("recording")
        _wait(params.pre_push_s, recorder.check)

        step("push")
        target = _offset(lifted, axis, params.push_distance_mm * 1e-3)
        push_start = log.event("push", distance_mm=params.push_distance_mm)
        arm.move_linear(target, params.push_speed_m_s, params.push_acceleration_m_s2)
        push_end = log.event("pushed")
        pushed = log.pose("pushed", arm)

        step("hold")
        hold_end = push_end + params.hold_s
        while True:
            recorder.check()
            reading = log.gripper(gripper, "holding")
            if reading["grip_state"] != gcl.HOLDING:
                state = reading["grip_state"]
                raise DeviceError(
                    f"the gripper stopped holding the bottle during the hold (GRIPSTATE="
                    f"{state} {gcl.GRIP_STATES.get(state, '?')})"
                )
            log.pose(f"hold_{len(log.gripper_readings)}", arm)
            remaining = hold_end - time.monotonic()
            if remaining <= 0:
                break
            _wait(min(params.log_interval_s, remaining), recorder.check)

        step("stop")
        summary = recorder.stop()
        log.event("stopped")

        step("lower")
        log.event("lower")
        arm.move_linear(
            _offset(pushed, 2, -params.lift_mm * 1e-3),
            params.lift_speed_m_s,
            params.lift_acceleration_m_s2,
        )
        log.pose("lowered", arm)

        step("release")
        gripper.release(params.release_mm, params.release_speed_mm_s)
        log.gripper(gripper, "released")
        log.event("released")

        step("write")
        origin = _recording_origin(summary)
        meta: dict[str, Any] = {
            "push_start_s": push_start - origin,
            "push_end_s": push_end - origin,
            "protocol": params.model_dump(mode="json"),
            "acquisition": {
                "clock": "time.monotonic",
                "origin_t_s": origin,
                "gripper": getattr(gripper, "url", None),
                "arm": getattr(arm, "url", None),
                "cameras": [str(s) for s in camera_sources],
                **log.to_dict(),
            },
            **dict(extra_meta or {}),
        }
        trial_dir = recorder.finish(meta)
    except BaseException as exc:
        logger.info(
            "the trial failed (%s): stopping the arm, aborting the recording; the gripper "
            "keeps holding the bottle",
            exc or type(exc).__name__,
        )
        failures: list[str] = []
        _safe(arm.stop, failures, "stopping the arm")
        _safe(recorder.abort, failures, "aborting the recording")
        # the gripper is deliberately left alone: it keeps holding the bottle
        if failures:
            logger.warning("clean-up after the failed trial: %s", "; ".join(failures))
        try:
            where = write_failed_run(out_dir, log, exc, clean_up_failures=failures)
            logger.warning("the failed run's record: %s", where)
        except OSError as write_error:
            logger.warning("could not write the failed run's record: %s", write_error)
        raise
    return TrialRun(
        trial_dir=Path(trial_dir),
        summary=summary,
        log=log,
        push_start_s=push_start - origin,
        push_end_s=push_end - origin,
    )


def _recording_origin(summary: Any) -> float:
    """The recording's time zero [s, monotonic]: its first frame (what extraction's clock
    starts at), else when capturing started."""
    starts = [
        s.start_t_s
        for s in getattr(summary, "sensors", {}).values()
        if getattr(s, "start_t_s", None) is not None and math.isfinite(s.start_t_s)
    ]
    return min(starts) if starts else float(summary.start_t_s)
