"""One trial on the robot: grasp, lift, record, push, hold, stop, lower, release.

:func:`run_trial` drives a :class:`~liquidtouch.acquire.grippers.Gripper`, an
:class:`~liquidtouch.acquire.arms.Arm` and the GelSight cameras (through
:class:`~liquidtouch.acquire.recording.Recorder`) through the paper's protocol
(Huang, Guo, Yuan, RSS 2022: the gripper grasps the bottle with about 25 N, the
arm lifts it, gives it a short lateral push and holds still while the sensors
record the sloshing), with the parameters of :class:`ProtocolParameters` (a TOML
file: :func:`load_protocol`):

0. ``check``: the gripper's and the arm's state are read (``GRIPSTATE?``, ``POS?``, the
   pose) and anything but the start state — fingers open, no part held, no fault, the
   arm at its start pose — is refused before anything moves, or mended with ``recover``
   (:mod:`liquidtouch.acquire.start_state`);
1. ``cameras``: opened and warmed up (a camera that does not deliver stops the trial
   before the robot moves);
2. ``grasp``: ``GRIP`` with ``grasp_force_n`` on a part of ``part_width_mm``; the gripper
   must report that it holds the part;
3. ``lift`` by ``lift_mm`` (``moveL`` straight up), wait ``settle_s``;
4. ``record``: start recording, wait ``pre_push_s``;
5. ``push``: ``moveL`` by ``push_distance_mm`` along the base ``push_axis`` at
   ``push_speed_m_s`` / ``push_acceleration_m_s2`` (a trapezoidal speed profile);
6. ``hold`` still ``hold_s`` while recording (the gripper must keep holding; its
   readings and the arm's pose are logged every ``log_interval_s``); with
   ``max_pushes`` > 1, the hold ends with a ``hold_end`` event and ``decide(k)`` (the
   live estimate's combined answer after push ``k``: every target met, or "cannot tell
   here") says whether to ``push`` and ``hold`` again — each push goes back the way the
   previous one came, so the bottle never leaves one push's distance of where it was
   lifted — while the gripper's hold and the recording are still checked;
7. ``stop`` recording; ``return``: carry the bottle back over its start (at the lifted
   height); ``lower`` it to the start pose; ``release`` (``RELEASE`` by ``release_mm``):
   the trial ends where it started, so the next one starts from there;
8. ``write`` the trial: meta.json (last) gets the parameters, the push's times on
   the recording's clock, the arm's poses and the gripper's readings.

The order is :data:`STEPS`, each step a method of :class:`TrialSteps`.

**Safety.** On any error or Ctrl-C, at any step: the arm is stopped, the gripper
is left holding (it is never opened, so a lifted bottle is not dropped) and the
recording is aborted, so no trial directory appears (nothing looks complete). The
next trial then refuses to start (step 0) until the bottle is put down: by hand, or by
``run-trial --recover``.
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
from liquidtouch.acquire.start_state import check_start_state, recover_start_state
from liquidtouch.errors import DeviceError
from liquidtouch.protocols import gcl

__all__ = [
    "AXES",
    "PUSH_STEPS",
    "STEPS",
    "TrialLog",
    "TrialRun",
    "TrialSteps",
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
    """A finished trial: its directory, the recording's summary and the log; the first
    push's times and every push's (``pushes``: ``push_start_s``, ``push_end_s``,
    ``distance_mm``, on the recording's clock [s])."""

    trial_dir: Path
    summary: Any
    log: TrialLog
    push_start_s: float
    push_end_s: float
    pushes: list[dict[str, float]] = field(default_factory=list)


#: how long the protocol waits after a hold for ``decide`` to judge the ring-down [s]: the
#: live estimate's final fit needs ~2 s of signal after the hold (its guard, settle time
#: and trusted edge) and a few seconds of fitting on a loaded machine; past it the bottle
#: is pushed again (more data, as without an estimate)
DECISION_TIMEOUT_S = 20.0
#: how often ``decide`` is asked meanwhile [s]
DECISION_POLL_S = 0.1


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


#: the protocol's steps in order (:class:`TrialSteps` has a method of each name, ``return``
#: is ``return_``); a protocol of several pushes repeats :data:`PUSH_STEPS`
STEPS = (
    "check", "cameras", "grasp", "lift", "record", "push", "hold", "stop", "return",
    "lower", "release", "write",
)  # fmt: skip
#: the steps of one push and its ring-down
PUSH_STEPS = ("push", "hold")


class TrialSteps:
    """The protocol's steps on one gripper, arm and recorder (module docstring), each a
    method named as in :data:`STEPS`; what a step finds (poses, times, the summary) is
    kept for the next ones and for the trial's meta.json."""

    def __init__(self, gripper, arm, recorder, params: ProtocolParameters, log: TrialLog, *,
                 recover: bool = False,
                 decide: Callable[[int], bool | None] | None = None) -> None:  # fmt: skip
        self.gripper, self.arm, self.recorder = gripper, arm, recorder
        self.params, self.log, self.recover = params, log, recover
        self.decide = decide
        self.pushes: list[dict[str, float]] = []  # [s, monotonic]
        self.axis = AXES[params.push_axis]
        self.start: list[float] = []
        self.lifted: list[float] = []
        self.push_start = self.push_end = math.nan
        self.summary: Any = None
        self.trial_dir: Path | None = None

    def method(self, name: str) -> Callable[[], None]:
        return getattr(self, "return_" if name == "return" else name)

    def check(self) -> None:
        """Read the gripper's and arm's state; refuse (or, ``recover``, mend) a wrong one."""
        fix = recover_start_state if self.recover else check_start_state
        state = fix(self.gripper, self.arm, self.params)
        self.start = list(state.start)
        self.log.poses["start_pose"] = list(state.start)

    def cameras(self) -> None:
        self.recorder.open()

    def grasp(self) -> None:
        p = self.params
        self.log.pose("start", self.arm)
        self.log.event("grasp", force_n=p.grasp_force_n, part_width_mm=p.part_width_mm)
        try:
            self.gripper.grip(p.grasp_force_n, p.part_width_mm, p.grasp_speed_mm_s)
        except DeviceError as exc:
            raise DeviceError(
                f"{exc}: is the bottle standing between the open fingers at the start pose, "
                f"and about part_width_mm = {p.part_width_mm:g} mm wide?"
            ) from None
        self.log.gripper(self.gripper, "grasped")

    def lift(self) -> None:
        p = self.params
        self.log.event("lift")
        self.arm.move_linear(
            _offset(self.start, 2, p.lift_mm * 1e-3), p.lift_speed_m_s, p.lift_acceleration_m_s2
        )
        self.lifted = self.log.pose("lifted", self.arm)
        _wait(p.settle_s, lambda: None)

    def record(self) -> None:
        self.recorder.start()
        self.log.event("recording")
        _wait(self.params.pre_push_s, self.recorder.check)

    def push(self) -> None:
        """Push along the axis; every second push goes back the way the first came."""
        p = self.params
        k = len(self.pushes) + 1
        distance = p.push_distance_mm if k % 2 else -p.push_distance_mm
        here = self.arm.get_pose()
        target = _offset(here, self.axis, distance * 1e-3)
        start = self.log.event("push", distance_mm=distance, push=k)
        self.arm.move_linear(target, p.push_speed_m_s, p.push_acceleration_m_s2)
        end = self.log.event("pushed", push=k)
        self.log.pose("pushed" if k == 1 else f"pushed_{k}", self.arm)
        self.pushes.append({"push_start": start, "push_end": end, "distance_mm": distance})
        if k == 1:
            self.push_start, self.push_end = start, end

    def _still_holding(self) -> None:
        """The recording runs and the gripper holds the bottle (else :class:`DeviceError`)."""
        self.recorder.check()
        reading = self.log.gripper(self.gripper, "holding")
        if reading["grip_state"] != gcl.HOLDING:
            state = reading["grip_state"]
            raise DeviceError(
                f"the gripper stopped holding the bottle during the hold (GRIPSTATE="
                f"{state} {gcl.GRIP_STATES.get(state, '?')})"
            )

    def hold(self) -> None:
        hold_end = self.pushes[-1]["push_end"] + self.params.hold_s
        while True:
            self._still_holding()
            self.log.pose(f"hold_{len(self.log.gripper_readings)}", self.arm)
            remaining = hold_end - time.monotonic()
            if remaining <= 0:
                return
            _wait(min(self.params.log_interval_s, remaining), self.recorder.check)

    def again(self) -> bool:
        """After a hold: push again? (``max_pushes``; ``decide(k)``, polled while the gripper's
        hold and the recording are checked, up to :data:`DECISION_TIMEOUT_S`)."""
        k = len(self.pushes)
        if k >= self.params.max_pushes:
            return False
        self.log.event("hold_end", push=k)
        deadline = time.monotonic() + DECISION_TIMEOUT_S
        verdict = None if self.decide is not None else True
        while verdict is None and time.monotonic() < deadline:
            verdict = self.decide(k)
            if verdict is None:
                self._still_holding()
                _wait(DECISION_POLL_S, self.recorder.check)
        again = True if verdict is None else bool(verdict)
        self.log.event("decided", push=k, push_again=again, timed_out=verdict is None)
        return again

    def stop(self) -> None:
        self.summary = self.recorder.stop()
        self.log.event("stopped")

    def return_(self) -> None:
        """Carry the bottle back over its start, at the lifted height (pushes moved it)."""
        p = self.params
        self.log.event("return")
        over_start = [*self.start[:2], self.arm.get_pose()[2], *self.start[3:]]
        self.arm.move_linear(over_start, p.lift_speed_m_s, p.lift_acceleration_m_s2)

    def lower(self) -> None:
        p = self.params
        self.log.event("lower")
        self.arm.move_linear(self.start, p.lift_speed_m_s, p.lift_acceleration_m_s2)
        self.log.pose("lowered", self.arm)

    def release(self) -> None:
        self.gripper.release(self.params.release_mm, self.params.release_speed_mm_s)
        self.log.gripper(self.gripper, "released")
        self.log.event("released")

    def write(self, meta: Mapping[str, object]) -> None:
        self.trial_dir = Path(self.recorder.finish(dict(meta)))

    def pushes_on(self, origin: float) -> list[dict[str, float]]:
        """Every push's start and end on the recording's clock [s] and its distance [mm]."""
        return [
            {"push_start_s": q["push_start"] - origin, "push_end_s": q["push_end"] - origin,
             "distance_mm": q["distance_mm"]}
            for q in self.pushes
        ]  # fmt: skip

    def meta(self, camera_sources: Sequence[str], extra_meta: Mapping[str, object]) -> dict:
        """meta.json's protocol fields: the push on the recording's clock, the log."""
        origin = _recording_origin(self.summary)
        return {
            "push_start_s": self.push_start - origin,
            "push_end_s": self.push_end - origin,
            "pushes": self.pushes_on(origin),
            "protocol": self.params.model_dump(mode="json"),
            "acquisition": {
                "clock": "time.monotonic",
                "origin_t_s": origin,
                "gripper": getattr(self.gripper, "url", None),
                "arm": getattr(self.arm, "url", None),
                "cameras": [str(s) for s in camera_sources],
                **self.log.to_dict(),
            },
            **dict(extra_meta),
        }


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
    recorder: Any = None,
    recover: bool = False,
    decide: Callable[[int], bool | None] | None = None,
) -> TrialRun:
    """Run one trial (module docstring: the steps and the safety rules); return it.

    ``camera_sources`` go to the :class:`~liquidtouch.acquire.recording.Recorder`
    (``names``: the sensors' names, default ``left``, ``right``); ``labels`` become
    meta.json labels; ``extra_meta`` adds meta.json fields. ``on_step(name)`` is
    called as each step begins (for progress output); ``on_event(name, t_s)`` as each
    event is logged [s, :func:`time.monotonic`] (the live estimate takes the push and the
    end of the hold from them). ``camera_timeouts`` (``open_timeout_s``,
    ``read_timeout_s``, ``warmup_timeout_s`` [s]) go to ``recorder_factory``
    (:func:`make_recorder`), unless a ``recorder`` made by it is given (so its checks
    ran before the devices were connected). ``recover``: mend an unexpected start state
    (:func:`~liquidtouch.acquire.start_state.recover_start_state`) instead of refusing it.
    ``decide(k)``: after push ``k`` (of at most ``params.max_pushes``), ``True`` to push
    again, ``False`` to end, ``None`` while it cannot tell yet (module docstring, step 6);
    without it every push up to ``max_pushes`` is made.
    The trial directory ``out_dir`` appears only when everything succeeded; a failed run
    writes ``DIR.failed/run.json`` (:func:`write_failed_run`).
    """
    params = ProtocolParameters() if params is None else params
    report = on_step or (lambda _name: None)
    log = TrialLog(on_event=on_event)
    if recorder is None:
        recorder = recorder_factory(
            list(camera_sources),
            out_dir,
            names=names,
            params=params,
            labels=dict(labels or {}),
            **dict(camera_timeouts or {}),
        )
    steps = TrialSteps(gripper, arm, recorder, params, log, recover=recover, decide=decide)
    try:  # refused or mended before anything is recorded: no failed run to write
        report(STEPS[0])
        steps.check()
    except BaseException:
        if recover:
            _safe(arm.stop, [], "stopping the arm")
        _safe(recorder.abort, [], "aborting the recording")
        raise
    try:
        for name in STEPS[1:]:
            logger.info("trial step: %s", name)
            report(name)
            if name == "write":
                steps.write(steps.meta(camera_sources, extra_meta or {}))
            else:
                steps.method(name)()
            while name == PUSH_STEPS[-1] and steps.again():  # another push and its hold
                for again in PUSH_STEPS:
                    report(again)
                    steps.method(again)()
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
    origin = _recording_origin(steps.summary)
    return TrialRun(
        trial_dir=steps.trial_dir,
        summary=steps.summary,
        log=log,
        push_start_s=steps.push_start - origin,
        push_end_s=steps.push_end - origin,
        pushes=steps.pushes_on(origin),
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
