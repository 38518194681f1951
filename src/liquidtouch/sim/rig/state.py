"""The simulated lab rig's physical state: a bottle of liquid, a WSG-50 gripper, an arm, two gels.

The rig stands in for the paper's robot (a UR5e arm, a Weiss WSG-50 gripper, two
GelSight sensors at 640 × 480 and 30 fps) so that the lab path -- ``liquidtouch
run-trial`` with its gripper, arm and camera clients -- can be run end to end on one
machine. :class:`Rig` is the physical state and reacts to commands (the gripper's and
the arm's, as their servers pass them on); :class:`~liquidtouch.sim.rig.rig.RigServer`
puts it on the network, :mod:`~liquidtouch.sim.rig.live_sensor` renders its gels.

What the rig simulates:

- **The bottle** stands on the table between the open fingers (``container``'s
  width plus 2 mm walls). ``GRIP`` finds it when the commanded part width is within
  :data:`CLAMP_TRAVEL_MM` of it, closes at the commanded speed (a real-time motion)
  and holds it: the gels show the contact imprint. Opening the fingers while the
  bottle is off the table drops it (``status``: ``dropped``).
- **The weight** moves onto the fingers over the first :data:`LIFT_OFF_MM` of a lift
  (the gel shear grows from zero to the trial's static load), and off again when the
  bottle is set down. The arm refuses to push a held bottle into the table.
- **The push**: a horizontal ``moveL`` of a lifted bottle runs the simulator
  (:func:`~liquidtouch.sim.trial.simulate_trial`, same liquid, seed and drawn
  conditions) with the push it commands: distance = the move along base x (the
  container's length, the slosh direction) or y (across it: the container's
  width; :meth:`~liquidtouch._core.containers.Container.along`), whichever the move
  is mostly along; any strength the arm accepts; duration = the move's (a UR-style
  trapezoidal profile; the simulator moves the hand by a minimum-jerk profile of
  that length and duration). Time alignment: the wall-clock moment the push starts
  is the trial's ``push_start_s``, so a frame captured at wall time t shows the
  loads at trial time ``push_start_s + (t − t_push)``, averaged over the camera's
  exposure as in the simulator's videos. Before the push the gel shows the
  lifted grasp at rest (the trial's state just before its push); after the end of
  the simulated span (:data:`TRIAL_DURATION_S`) the last state stays.
- **The truth**: the simulator's small-amplitude slow slosh mode (λ, ω) of a push
  along x (:meth:`Rig.truth`; a push along y sloshes across the container, and its
  truth is in :attr:`Rig.pushes`).
- **Repeated pushes** of the same bottle: every push restarts the simulated trial from
  rest with the same conditions and fresh contact noise (``noise_seed`` = the push's
  number), so their ring-downs are independent measurements of one liquid.

Not simulated: the arm's dynamics and limits beyond a sanity check, a gripper force
other than the simulator's drawn grasp (the commanded force is reported by
``FORCE?`` but the physics keeps its own), a second push restarting from the
sloshing state (each push restarts the simulated trial from rest), and a stopped
push (the simulated push always completes).
"""

from __future__ import annotations

import logging
import math
import threading
import time
from typing import Any

import numpy as np

from liquidtouch._core.containers import get_container
from liquidtouch.protocols import gcl
from liquidtouch.protocols.arm import ArmError
from liquidtouch.sim.gelsight import (
    SENSOR_NAMES,
    contact_geometry,
    contact_offsets,
    gel_loads_px,
    marker_positions,
    marker_rest_positions,
)
from liquidtouch.sim.rig.fingers import OPEN_WIDTH_MM, FingerCommands
from liquidtouch.sim.rig.interfaces import ArmMove
from liquidtouch.sim.rig.kinematics import ArmMotion, FingerMotion, move_duration
from liquidtouch.sim.rig.live_sensor import LiveSensor, loads_near
from liquidtouch.sim.sensors import get_sensor_profile
from liquidtouch.sim.trial import SimulatedTrial, simulate_trial

__all__ = ["HOME_POSE", "LIFT_OFF_MM", "REACH_M", "TRIAL_DURATION_S", "WALL_MM", "Rig"]

logger = logging.getLogger(__name__)

WALL_MM = 2.0
"""The simulated container's wall thickness [mm]: outer width = inner width + 2 walls."""
LIFT_OFF_MM = 5.0
"""The bottle's weight is fully on the fingers after this much lift [mm]."""
TRIAL_DURATION_S = 30.0
"""Simulated span of a push [s]; after it the gel keeps its last state."""
HOME_POSE = (0.40, 0.0, 0.20, 0.0, math.pi, 0.0)
"""The arm's starting tool pose: above the bottle, fingers down [m, rad]."""
REACH_M = 0.85
"""The UR5e's reach [m]: targets farther from the base are refused."""


class Rig(FingerCommands):
    """The simulated rig's physical state (module docstring: what it simulates).

    ``liquid``, ``height_mm``, ``container``, ``sugar_concentration``, ``seed`` and
    ``temperature_c`` are those of :func:`~liquidtouch.sim.trial.simulate_trial`
    (checked now: a bad value raises :class:`~liquidtouch.errors.LiquidTouchError`);
    ``sensor`` is the GelSight profile (``default`` 640 × 480 at 30 fps, ``mini``).
    ``gripper_time_scale`` scales the duration of finger motions (1: real time).
    The gripper's commands are :class:`~liquidtouch.sim.rig.fingers.FingerCommands`.
    """

    def __init__(
        self,
        liquid: str,
        *,
        height_mm: float,
        container: str = "grooved-cuboid",
        sugar_concentration: float | None = None,
        seed: int = 0,
        temperature_c: float | None = None,
        sensor: str = "default",
        gripper_time_scale: float = 1.0,
        trial_duration_s: float = TRIAL_DURATION_S,
    ):
        self.profile = get_sensor_profile(sensor)
        self._sim_args: dict[str, Any] = {
            "height_mm": height_mm,
            "container": container,
            "sugar_concentration": sugar_concentration,
            "seed": seed,
            "temperature_c": temperature_c,
            "duration_s": trial_duration_s,
        }
        self.liquid = liquid
        self.base_trial = simulate_trial(liquid, **self._sim_args)
        self.seed = self.base_trial.seed
        self.bottle_width_mm = get_container(container).width_mm + 2.0 * WALL_MM
        self.gripper_time_scale = float(gripper_time_scale)
        self._lock = threading.RLock()
        # gripper
        self.width_mm = OPEN_WIDTH_MM
        self.grip_force_n = 0.0
        self.grip_state = gcl.IDLE
        self.holding = False
        self.fast_stop = False
        self._finger_motion: FingerMotion | None = None
        # arm and bottle
        self._pose = list(HOME_POSE)
        self._arm_motion: ArmMotion | None = None
        self.grasp_z: float | None = None
        self.dropped = False
        # trial clock
        self.trial: SimulatedTrial = self.base_trial
        self._lifted_since: float | None = None
        self._push_at: float | None = None
        self.pushes: list[dict[str, Any]] = []
        # rendering
        rng = np.random.default_rng([self.seed, 0])
        self._rests = [marker_rest_positions(self.profile, rng) for _ in SENSOR_NAMES]
        self._geometry = contact_geometry(self.base_trial.loads, self.profile)
        self._sensors: list[LiveSensor | None] = [None, None]
        #: every command that reached the gripper or the arm over the network, in order
        #: (``"gripper GRIP"``, ``"gripper GRIPSTATE?"``, ``"arm moveL"``, ...)
        self.commands: list[str] = []

    def note(self, command: str) -> None:
        """Log a command that reached the rig (:attr:`commands`; ``rig serve -v`` shows them)."""
        with self._lock:
            self.commands.append(command)
        logger.info("rig: %s", command)

    # -- the truth ------------------------------------------------------------------------

    def truth(self) -> dict[str, Any]:
        """The simulated liquid: labels and the ground truth λ [1/s], ω [rad/s]."""
        trial = self.base_trial
        return {
            **{k: _plain(v) for k, v in trial.labels().items()},
            "seed": trial.seed,
            "sensor": self.profile.name,
            "true_height_mm": trial.extra["true_height_mm"],
            "natural_frequency": trial.extra["natural_frequency"],
        }

    # -- arm ------------------------------------------------------------------------------

    def pose(self, now: float | None = None) -> list[float]:
        """The tool pose at ``now`` (default: now)."""
        now = time.monotonic() if now is None else now
        with self._lock:
            motion = self._arm_motion
            return motion.pose_at(now) if motion is not None else list(self._pose)

    def begin_move(self, pose: list[float], speed: float, acceleration: float) -> ArmMove:
        """Validate a ``moveL`` and return the move (``interfaces.ArmModel``); refusals raise
        :class:`~liquidtouch.protocols.arm.ArmError`."""
        if not all(math.isfinite(v) for v in pose):
            raise ArmError("the pose must be 6 finite numbers")
        if not (0 < speed <= 3.0 and 0 < acceleration <= 150.0):
            raise ArmError("speed must be in (0, 3] m/s and acceleration in (0, 150] m/s²")
        if math.dist(pose[:3], (0.0, 0.0, 0.0)) > REACH_M:
            raise ArmError(f"the target is out of reach (more than {REACH_M} m from the base)")
        with self._lock:
            if self._arm_motion is not None:
                raise ArmError("the arm is moving")
            start = list(self._pose)
            if self.holding and self.grasp_z is not None and pose[2] < self.grasp_z - 0.001:
                raise ArmError(
                    "refused: the move would push the held bottle into the table "
                    f"(z {pose[2]:.4f} m below the grasp height {self.grasp_z:.4f} m)"
                )
            distance = math.dist(start[:3], pose[:3])
            duration = move_duration(distance, speed, acceleration)
            dx, dy = pose[0] - start[0], pose[1] - start[1]
            axis, along = ("x", dx) if abs(dx) >= abs(dy) else ("y", dy)
            push = (
                self.holding
                and not self.dropped
                and self._weight(start[2]) >= 1.0
                and abs(pose[2] - start[2]) < 0.001
                and abs(along) >= 0.0005
            )
            number = len(self.pushes) + 1
        motion = ArmMotion(start, list(pose), 0.0, distance, speed, acceleration, duration)
        cancel = threading.Event()

        def run(cancelled: threading.Event) -> list[float]:
            trial = None
            if push:
                trial = simulate_trial(
                    self.liquid,
                    **self._sim_args,
                    parameters={"push_distance_mm": along * 1e3, "push_duration_s": duration},
                    push_axis=axis,
                    noise_seed=number if number > 1 else None,
                )
            with self._lock:
                if cancel.is_set() or cancelled.is_set():
                    return list(self._pose)
                now = time.monotonic()
                motion.t0 = now
                self._arm_motion = motion
                if trial is not None:
                    logger.info(
                        "rig: push %d of %.1f mm along %s over %.3f s starts the simulated trial",
                        number,
                        along * 1e3,
                        axis,
                        duration,
                    )
                    self.trial, self._push_at = trial, now
                    if self._lifted_since is None:
                        self._lifted_since = now
                    self.pushes.append(
                        {
                            "push_distance_mm": along * 1e3,
                            "push_axis": axis,
                            "push_duration_s": duration,
                            "true_decay_rate": trial.true_decay_rate,
                            "true_angular_frequency": trial.true_angular_frequency,
                            "push_start_trial_s": trial.params.push_start_s,
                            "t_monotonic": now,
                        }
                    )
            end = motion.t0 + duration
            while not (cancel.is_set() or cancelled.is_set()):
                remaining = end - time.monotonic()
                if remaining <= 0:
                    break
                cancelled.wait(min(remaining, 0.02))
            return self._end_move(motion)

        return ArmMove(run=run, cancel=cancel.set)

    def _end_move(self, motion: ArmMotion) -> list[float]:
        with self._lock:
            now = time.monotonic()
            if self._arm_motion is motion:
                self._pose = motion.pose_at(now)
                self._arm_motion = None
            if self.holding and self._weight(self._pose[2]) <= 0.0:
                self._set_down()
            return list(self._pose)

    def stop_arm(self) -> None:
        """Stop the arm where it is."""
        with self._lock:
            motion = self._arm_motion
            if motion is not None:
                self._pose = motion.pose_at(time.monotonic())
                self._arm_motion = None

    def _weight(self, z: float) -> float:
        """Fraction (0-1) of the bottle's weight on the fingers with the tool at height ``z``."""
        if not self.holding or self.dropped or self.grasp_z is None:
            return 0.0
        return float(np.clip((z - self.grasp_z) * 1e3 / LIFT_OFF_MM, 0.0, 1.0))

    def _set_down(self) -> None:
        """The bottle stands on the table again: the trial clock restarts."""
        self.trial, self._push_at, self._lifted_since = self.base_trial, None, None

    # -- what the cameras see ------------------------------------------------------------

    def trial_time(self, now: float | None = None) -> tuple[SimulatedTrial, float, float, bool]:
        """(trial, trial time [s], weight on the fingers 0-1, contact) at ``now``."""
        now = time.monotonic() if now is None else now
        with self._lock:
            contact = self.holding and not self.dropped
            weight = self._weight(self.pose(now)[2]) if contact else 0.0
            trial = self.trial
            push_start = trial.params.push_start_s
            if weight >= 1.0 and self._lifted_since is None:
                self._lifted_since = now
            if self._push_at is not None:
                t = push_start + (now - self._push_at)
            elif self._lifted_since is not None:
                t = min(now - self._lifted_since, push_start - 1e-3)
            else:
                t = 0.0
            t = float(np.clip(t, 0.0, float(trial.t_s[-1])))
        return trial, t, weight, contact

    def sensor(self, index: int) -> LiveSensor:
        """The live renderer of sensor ``index`` (0 left, 1 right), set up on first use."""
        with self._lock:
            sensor = self._sensors[index]
            if sensor is None:
                sensor = LiveSensor(
                    index, self.profile, self._rests[index], self.seed, self._geometry
                )
                self._sensors[index] = sensor
        return sensor

    def marker_state(self, index: int, now: float | None = None):
        """Sensor ``index``'s marker positions (N, 2) [px], imprint offset (2,) [px], contact."""
        trial, t, weight, contact = self.trial_time(now)
        rest = self._rests[index]
        if not contact or weight <= 0.0:
            return rest, np.zeros(2), contact
        loads = loads_near(trial.loads, t)
        times = np.array([t])
        moved = marker_positions(loads, self.profile, times, rest_px=rest)[index, 0]
        offset = contact_offsets(loads, self.profile, times)[index, 0]
        return rest + weight * (moved - rest), weight * offset, contact

    def gel_field(self, index: int, now: float | None = None) -> np.ndarray:
        """A plain gel's field now: shear at the contact centre (x, y) [px] and twist [rad]."""
        trial, t, weight, contact = self.trial_time(now)
        if not contact or weight <= 0.0:
            return np.zeros(3)
        shear, twist = gel_loads_px(loads_near(trial.loads, t), self.profile, np.array([t]))
        return weight * np.array([*shear[index, 0], twist[index, 0]])

    def frame(self, index: int, now: float | None = None) -> np.ndarray:
        """Sensor ``index``'s image at ``now`` (default: now), BGR uint8 (H, W, 3) as a
        camera delivers it."""
        now = time.monotonic() if now is None else now
        positions, offset, contact = self.marker_state(index, now)
        field = self.gel_field(index, now) if self.profile.gel == "plain" else None
        return self.sensor(index).render(positions, offset, contact, field)

    def status(self) -> dict[str, Any]:
        """The rig's state: gripper, arm, bottle and trial clock."""
        now = time.monotonic()
        trial, t, weight, contact = self.trial_time(now)
        with self._lock:
            return {
                "gripper": {
                    "width_mm": round(self._width(now), 3),
                    "force_n": self.grip_force_n,
                    "grip_state": gcl.ERROR if self.fast_stop else self.grip_state,
                    "holding": self.holding,
                    "fast_stop": self.fast_stop,
                },
                "arm": {"pose": self.pose(now), "moving": self._arm_motion is not None},
                "bottle": {
                    "weight_on_fingers": weight,
                    "contact": contact,
                    "dropped": self.dropped,
                    "width_mm": self.bottle_width_mm,
                },
                "commands": len(self.commands),
                "trial": {
                    "time_s": t,
                    "pushed": self._push_at is not None,
                    "push_start_s": trial.params.push_start_s,
                    "pushes": list(self.pushes),
                },
            }


def _plain(value: Any) -> Any:
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    return value
