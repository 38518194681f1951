"""A trial from device URLs: every input checked before the first command to a device.

:func:`run_trial_at` (its parameters:
:func:`~liquidtouch.acquire.protocol_params.trial_parameters`) checks the camera sources and
makes the recorder (which checks the trial directory, the sensor names, the labels and the
camera options), then connects to the gripper and the arm and
runs :func:`~liquidtouch.acquire.protocol.run_trial` — whose first step reads the
devices' state and refuses (or, ``recover``, mends) an unexpected one. A bad input is a
:class:`~liquidtouch.errors.LiquidTouchError` before anything is connected, so nothing
moves (``run-trial``, issue 41).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from liquidtouch.acquire.arms import RigArm, open_arm
from liquidtouch.acquire.cameras.sources import check_distinct_sources
from liquidtouch.acquire.grippers import open_gripper
from liquidtouch.acquire.protocol import TrialRun, make_recorder, run_trial
from liquidtouch.acquire.protocol_params import ProtocolParameters
from liquidtouch.errors import LiquidTouchError

__all__ = ["run_trial_at"]


def run_trial_at(
    gripper_url: str,
    arm_url: str,
    cameras: Sequence[str],
    out_dir: str | Path,
    params: ProtocolParameters,
    labels: Mapping[str, object] | None = None,
    *,
    names: Sequence[str] | None = None,
    recover: bool = False,
    on_step: Callable[[str], None] | None = None,
    on_frame: Callable[..., None] | None = None,
    on_event: Callable[[str, float], None] | None = None,
    camera_timeouts: Mapping[str, float] | None = None,
    decide: Callable[[int], bool | None] | None = None,
) -> TrialRun:
    """Check the inputs, connect, run one trial (module docstring); the finished trial.

    ``on_frame(sensor, frame)`` gets every captured frame (the live estimate), the other
    arguments are :func:`~liquidtouch.acquire.protocol.run_trial`'s. The simulated rig's
    truth (λ, ω) goes into meta.json.
    """
    if names and len(names) != len(cameras):
        raise LiquidTouchError(f"{len(cameras)} --camera but {len(names)} --name")
    check_distinct_sources([str(c) for c in cameras])  # a mistyped camera, before connecting
    recorder = make_recorder(
        list(cameras),
        out_dir,
        names=list(names) if names else None,
        params=params,
        labels=dict(labels or {}),
        on_frame=on_frame,
        **dict(camera_timeouts or {}),
    )
    try:
        with open_gripper(gripper_url) as gripper, open_arm(arm_url) as arm:
            extra: dict[str, Any] = {}
            if isinstance(arm, RigArm):  # the simulated rig knows the truth
                truth = arm.truth()
                extra = {
                    "true_decay_rate": truth["true_decay_rate"],
                    "true_angular_frequency": truth["true_angular_frequency"],
                    "simulated_rig": truth,
                }
            return run_trial(
                gripper,
                arm,
                cameras,
                out_dir,
                params,
                labels,
                names=list(names) if names else None,
                extra_meta=extra,
                on_step=on_step,
                on_event=on_event,
                recorder=recorder,
                recover=recover,
                decide=decide,
            )
    finally:
        recorder.abort()  # no-op once finished; frees the writers of a trial that never ran
