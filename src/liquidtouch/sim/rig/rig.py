"""The simulated lab rig: a bottle of liquid, a WSG-50 gripper, an arm and two GelSight cameras.

The rig stands in for the paper's robot (a UR5e arm, a Weiss WSG-50 gripper, two
GelSight sensors at 640 × 480 and 30 fps) so that the lab path -- ``liquidtouch
run-trial`` with its gripper, arm and camera clients -- can be run end to end on one
machine. :class:`Rig` is the physical state and reacts to commands;
:class:`RigServer` puts it on the network: the gripper as a GCL server
(:mod:`~liquidtouch.sim.rig.gcl_server`, the WSG's real protocol), the arm as a JSON
line endpoint (:mod:`~liquidtouch.sim.rig.arm_server`) and the two sensors as MJPEG
streams (:class:`~liquidtouch.sim.rig.mjpeg.MjpegServer`).

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
  container's length, the slosh direction), duration = the move's (a UR-style
  trapezoidal profile; the simulator moves the hand by a minimum-jerk profile of
  that length and duration). Time alignment: the wall-clock moment the push starts
  is the trial's ``push_start_s``, so a frame captured at wall time t shows the
  loads at trial time ``push_start_s + (t − t_push)``, averaged over the camera's
  exposure as in the simulator's videos. Before the push the gel shows the
  lifted grasp at rest (the trial's state just before its push); after the end of
  the simulated span (:data:`TRIAL_DURATION_S`) the last state stays.
- **The truth**: the simulator's small-amplitude slow slosh mode (λ, ω), the same
  for every push (:meth:`Rig.truth`).

Not simulated: the arm's dynamics and limits beyond a sanity check, a gripper force
other than the simulator's drawn grasp (the commanded force is reported by
``FORCE?`` but the physics keeps its own), a second push restarting from the
sloshing state (each push restarts the simulated trial from rest), and a stopped
push (the simulated push always completes).
"""

from __future__ import annotations

import contextlib
import math
import threading
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.lib.stride_tricks import as_strided

from liquidtouch.sim.containers import get_container
from liquidtouch.sim.gelsight import (
    SENSOR_NAMES,
    contact_geometry,
    contact_offsets,
    marker_positions,
    marker_rest_positions,
)
from liquidtouch.sim.loads import FingerLoads
from liquidtouch.sim.render import iter_frames, make_background
from liquidtouch.sim.rig.arm_server import ArmError, ArmMove, ArmServer
from liquidtouch.sim.rig.gcl_server import GclError, GclServer, Motion
from liquidtouch.sim.sensors import get_sensor_profile
from liquidtouch.sim.trial import SimulatedTrial, simulate_trial

OPEN_WIDTH_MM = 110.0
"""The WSG-50's full opening [mm]."""
WALL_MM = 2.0
"""The simulated container's wall thickness [mm]: outer width = inner width + 2 walls."""
CLAMP_TRAVEL_MM = 10.0
"""GRIP finds the part if it lies within this distance of the commanded width [mm]."""
LIFT_OFF_MM = 5.0
"""The bottle's weight is fully on the fingers after this much lift [mm]."""
TRIAL_DURATION_S = 30.0
"""Simulated span of a push [s]; after it the gel keeps its last state."""
HOME_POSE = (0.40, 0.0, 0.20, 0.0, math.pi, 0.0)
"""The arm's starting tool pose: above the bottle, fingers down [m, rad]."""
REACH_M = 0.85
"""The UR5e's reach [m]: targets farther from the base are refused."""
HOME_SPEED_MM_S = 100.0
MAX_GRIP_FORCE_N = 80.0
_FRAME_BLOCK = 108_000
"""Frames rendered per renderer set-up (an hour at 30 fps), then it is set up again."""


def _ramp_distance(t_s: float, distance: float, speed: float, accel: float) -> float:
    """Distance covered after ``t_s`` by a trapezoidal-speed move of ``distance``."""
    if distance <= 0 or t_s <= 0:
        return 0.0
    if distance >= speed * speed / accel:
        t_acc = speed / accel
        total = distance / speed + t_acc
    else:
        t_acc = math.sqrt(distance / accel)
        total = 2.0 * t_acc
        speed = accel * t_acc
    if t_s >= total:
        return distance
    if t_s < t_acc:
        return 0.5 * accel * t_s * t_s
    if t_s <= total - t_acc:
        return 0.5 * accel * t_acc * t_acc + speed * (t_s - t_acc)
    return distance - 0.5 * accel * (total - t_s) ** 2


def move_duration(distance: float, speed: float, accel: float) -> float:
    """Duration [s] of a trapezoidal-speed move (accelerate, cruise, decelerate)."""
    if distance <= 0:
        return 0.0
    if distance >= speed * speed / accel:
        return distance / speed + speed / accel
    return 2.0 * math.sqrt(distance / accel)


@dataclass
class _ArmMotion:
    start: list[float]
    target: list[float]
    t0: float
    distance: float
    speed: float
    accel: float
    duration: float

    def pose_at(self, now: float) -> list[float]:
        if self.distance <= 0:
            fraction = 1.0 if now >= self.t0 + self.duration else 0.0
        else:
            fraction = _ramp_distance(now - self.t0, self.distance, self.speed, self.accel)
            fraction /= self.distance
        return [a + fraction * (b - a) for a, b in zip(self.start, self.target, strict=True)]


@dataclass
class _FingerMotion:
    start_mm: float
    target_mm: float
    t0: float
    duration: float
    speed: float

    def width_at(self, now: float) -> float:
        if self.duration <= 0 or now >= self.t0 + self.duration:
            return self.target_mm
        fraction = max(now - self.t0, 0.0) / self.duration
        return self.start_mm + fraction * (self.target_mm - self.start_mm)


class _LiveSensor:
    """Renders one GelSight sensor's current frame on demand.

    Uses :func:`~liquidtouch.sim.render.iter_frames` with stride-0 position and
    offset arrays: every frame reads the single (N, 2) buffer this class writes just
    before asking for the frame (the generator reads row ``i`` of its inputs only when
    drawing frame ``i``), so the renderer's set-up (background padding, marker
    look-up table, noise tile) is done once per :data:`_FRAME_BLOCK` frames.
    """

    def __init__(self, index: int, profile, rest_px: np.ndarray, seed: int, geometry):
        self.index, self.profile, self.rest = index, profile, rest_px
        self.seed, self.geometry = seed, geometry
        self.background = make_background(profile, np.random.default_rng([seed, index + 1]))
        self._lock = threading.Lock()
        self._positions = rest_px.astype(np.float64).copy()
        self._offset = np.zeros(2)
        self._frames: dict[bool, tuple[Any, int]] = {}

    def _generator(self, contact: bool):
        positions = as_strided(
            self._positions,
            shape=(_FRAME_BLOCK, *self._positions.shape),
            strides=(0, *self._positions.strides),
        )
        offsets = as_strided(self._offset, shape=(_FRAME_BLOCK, 2), strides=(0, 8))
        # the same seed for both generators: identical marker sizes and ink
        rng = np.random.default_rng([self.seed, self.index + 1, 7])
        kwargs: dict[str, Any] = {"background": self.background}
        if contact:
            kwargs.update(
                contact_center_px=self.geometry.center_px[self.index],
                contact_radius_px=float(self.geometry.radius_px[self.index]),
                contact_offsets_px=offsets,
            )
        return iter_frames(positions, self.profile, rng, **kwargs)

    def prepare(self) -> None:
        """Set up both renderers now (about a second) rather than at the first frame."""
        with self._lock:
            for contact in (False, True):
                if contact not in self._frames:
                    self._frames[contact] = (self._generator(contact), 0)

    def render(self, positions: np.ndarray, offset: np.ndarray, contact: bool) -> np.ndarray:
        """The BGR frame (H, W, 3) with markers at ``positions`` and the imprint if ``contact``."""
        import cv2

        with self._lock:
            generator, used = self._frames.get(contact, (None, _FRAME_BLOCK))
            if generator is None or used >= _FRAME_BLOCK:
                generator, used = self._generator(contact), 0
            self._positions[:] = positions
            self._offset[:] = offset
            frame = cv2.cvtColor(next(generator), cv2.COLOR_RGB2BGR)  # a new array
            self._frames[contact] = (generator, used + 1)
        return frame


class Rig:
    """The simulated rig's physical state (module docstring: what it simulates).

    ``liquid``, ``height_mm``, ``container``, ``sugar_concentration``, ``seed`` and
    ``temperature_c`` are those of :func:`~liquidtouch.sim.trial.simulate_trial`
    (checked now: a bad value raises :class:`~liquidtouch.errors.LiquidTouchError`);
    ``sensor`` is the GelSight profile (``default`` 640 × 480 at 30 fps, ``mini``).
    ``gripper_time_scale`` scales the duration of finger motions (1: real time).
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
        self.grip_state = 0
        self.holding = False
        self.fast_stop = False
        self._finger_motion: _FingerMotion | None = None
        # arm and bottle
        self._pose = list(HOME_POSE)
        self._arm_motion: _ArmMotion | None = None
        self.grasp_z: float | None = None
        self.dropped = False
        # trial clock
        self.trial: SimulatedTrial = self.base_trial
        self._lifted_since: float | None = None
        self._push_at: float | None = None
        self.pushes: list[dict[str, float]] = []
        # rendering
        rng = np.random.default_rng([self.seed, 0])
        self._rests = [marker_rest_positions(self.profile, rng) for _ in SENSOR_NAMES]
        self._geometry = contact_geometry(self.base_trial.loads, self.profile)
        self._sensors: list[_LiveSensor | None] = [None, None]

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
        """Validate a ``moveL`` and return the move (``arm_server.ArmModel``)."""
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
            dx = pose[0] - start[0]
            push = (
                self.holding
                and not self.dropped
                and self._weight(start[2]) >= 1.0
                and abs(pose[2] - start[2]) < 0.001
                and abs(dx) >= 0.0005
            )
        motion = _ArmMotion(start, list(pose), 0.0, distance, speed, acceleration, duration)
        cancel = threading.Event()

        def run(cancelled: threading.Event) -> list[float]:
            trial = None
            if push:
                trial = simulate_trial(
                    self.liquid,
                    **self._sim_args,
                    parameters={"push_distance_mm": dx * 1e3, "push_duration_s": duration},
                )
            with self._lock:
                if cancel.is_set() or cancelled.is_set():
                    return list(self._pose)
                now = time.monotonic()
                motion.t0 = now
                self._arm_motion = motion
                if trial is not None:
                    self.trial, self._push_at = trial, now
                    if self._lifted_since is None:
                        self._lifted_since = now
                    self.pushes.append(
                        {
                            "push_distance_mm": dx * 1e3,
                            "push_duration_s": duration,
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

    def _end_move(self, motion: _ArmMotion) -> list[float]:
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

    # -- gripper (gcl_server.GripperModel) ---------------------------------------------

    def _width(self, now: float) -> float:
        motion = self._finger_motion
        return motion.width_at(now) if motion is not None else self.width_mm

    def begin(self, command: str, args: list[float]) -> Motion:
        """Validate and start a finger motion (``HOME``, ``GRIP``, ``RELEASE``, ``MOVE``)."""
        with self._lock:
            if self.fast_stop:
                raise GclError("E_ACCESS_DENIED", "FAST STOP: acknowledge it with FSACK()")
            if self._finger_motion is not None:
                raise GclError("E_ALREADY_RUNNING", "the fingers are moving")
            now = time.monotonic()
            width = self._width(now)
            if command == "HOME":
                target, speed, on_done = OPEN_WIDTH_MM, HOME_SPEED_MM_S, self._opened
                self._open_now(now)
            elif command == "GRIP":
                target, speed, on_done = self._begin_grip(args, width)
            elif command == "RELEASE":
                pullback = _arg(args, 0, None, 0.1, OPEN_WIDTH_MM, "pullback")
                speed = _arg(args, 1, 50.0, 0.1, 420.0, "speed")
                target, on_done = min(width + pullback, OPEN_WIDTH_MM), self._opened
                self._open_now(now)
                self.grip_state = 5
            elif command == "MOVE":
                if self.holding:
                    raise GclError("E_ACCESS_DENIED", "a part is held: RELEASE() it first")
                target = _arg(args, 0, None, 0.0, OPEN_WIDTH_MM, "width")
                speed = _arg(args, 1, 50.0, 0.1, 420.0, "speed")
                if target < self.bottle_width_mm and width >= self.bottle_width_mm:
                    raise GclError("E_AXIS_BLOCKED", "the fingers are blocked by the bottle")
                on_done = self._opened
                self.grip_state = 6
            else:
                raise GclError("E_CMD_UNKNOWN", command)
            duration = abs(target - width) / speed * self.gripper_time_scale
            motion = _FingerMotion(width, target, now, duration, speed)
            self._finger_motion = motion

        def run(cancelled: threading.Event) -> None:
            end = motion.t0 + motion.duration
            while not cancelled.is_set():
                remaining = end - time.monotonic()
                if remaining <= 0:
                    break
                cancelled.wait(min(remaining, 0.02))
            with self._lock:
                if self._finger_motion is motion:
                    self.width_mm = motion.width_at(time.monotonic())
                    self._finger_motion = None
                if cancelled.is_set():
                    return
                on_done()

        return Motion(run=run, cancel=lambda: self._cancel_fingers(motion))

    def _begin_grip(self, args: list[float], width: float):
        if not args:
            raise GclError("E_NOT_ENOUGH_PARAMS", "GRIP(force, width, speed)")
        force = _arg(args, 0, None, 5.0, MAX_GRIP_FORCE_N, "force")
        part = _arg(args, 1, self.bottle_width_mm, 0.0, OPEN_WIDTH_MM, "width")
        speed = _arg(args, 2, 50.0, 0.1, 420.0, "speed")
        if self.holding:
            self.grip_force_n = force
            return width, speed, lambda: None
        self.grip_state = 1
        found = (
            not self.dropped
            and width >= self.bottle_width_mm
            and abs(part - self.bottle_width_mm) <= CLAMP_TRAVEL_MM
        )
        if found:

            def on_done() -> None:
                self.holding, self.grip_force_n, self.grip_state = True, force, 4
                self.grasp_z = self._pose[2] if self._arm_motion is None else None

            return self.bottle_width_mm, speed, on_done

        def no_part() -> None:
            self.grip_state = 2
            raise GclError("E_CMD_FAILED", "no part found")

        target = max(part - CLAMP_TRAVEL_MM, 0.0)
        if width >= self.bottle_width_mm and not self.dropped:
            target = max(target, self.bottle_width_mm)  # the fingers stop at the bottle
        return target, speed, no_part

    def _open_now(self, now: float) -> None:
        """The fingers start opening: a held bottle is let go (and falls if lifted)."""
        if self.holding:
            if self._weight(self.pose(now)[2]) > 0.0:
                self.dropped = True
            self.holding, self.grip_force_n, self.grasp_z = False, 0.0, None
            self._set_down()

    def _opened(self) -> None:
        self.grip_state = 0

    def _cancel_fingers(self, motion: _FingerMotion) -> None:
        with self._lock:
            if self._finger_motion is motion:
                self.width_mm = motion.width_at(time.monotonic())
                self._finger_motion = None

    def query(self, key: str) -> float:
        with self._lock:
            now = time.monotonic()
            if key == "POS":
                return round(self._width(now), 3)
            if key == "FORCE":
                return round(self.grip_force_n, 3)
            if key == "SPEED":
                motion = self._finger_motion
                return motion.speed if motion is not None else 0.0
            if key == "GRIPSTATE":
                return float(7 if self.fast_stop else self.grip_state)
        raise GclError("E_CMD_UNKNOWN", key)

    def acknowledge(self) -> None:
        with self._lock:
            self.fast_stop = False

    def raise_fast_stop(self) -> None:
        """A client left without ``BYE()``: motion commands are refused until ``FSACK()``."""
        with self._lock:
            self.fast_stop = True

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

    def sensor(self, index: int) -> _LiveSensor:
        """The live renderer of sensor ``index`` (0 left, 1 right), set up on first use."""
        with self._lock:
            sensor = self._sensors[index]
            if sensor is None:
                sensor = _LiveSensor(
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
        loads = _loads_near(trial.loads, t)
        times = np.array([t])
        moved = marker_positions(loads, self.profile, times, rest_px=rest)[index, 0]
        offset = contact_offsets(loads, self.profile, times)[index, 0]
        return rest + weight * (moved - rest), weight * offset, contact

    def frame(self, index: int) -> np.ndarray:
        """Sensor ``index``'s image now, BGR uint8 (H, W, 3) as a camera delivers it."""
        positions, offset, contact = self.marker_state(index)
        return self.sensor(index).render(positions, offset, contact)

    def status(self) -> dict[str, Any]:
        """The rig's state: gripper, arm, bottle and trial clock."""
        now = time.monotonic()
        trial, t, weight, contact = self.trial_time(now)
        with self._lock:
            return {
                "gripper": {
                    "width_mm": round(self._width(now), 3),
                    "force_n": self.grip_force_n,
                    "grip_state": 7 if self.fast_stop else self.grip_state,
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
                "trial": {
                    "time_s": t,
                    "pushed": self._push_at is not None,
                    "push_start_s": trial.params.push_start_s,
                    "pushes": list(self.pushes),
                },
            }


def _arg(args: list[float], i: int, default: float | None, low: float, high: float, what: str):
    if i >= len(args):
        if default is None:
            raise GclError("E_NOT_ENOUGH_PARAMS", f"missing {what}")
        return default
    value = args[i]
    if not (math.isfinite(value) and low <= value <= high):
        raise GclError("E_RANGE_ERROR", f"{what} {value:g} outside {low:g}-{high:g}")
    return value


def _loads_near(loads: FingerLoads, t_s: float, margin_s: float = 0.25) -> FingerLoads:
    """The samples of ``loads`` within ``margin_s`` of ``t_s``: a frame's exposure needs no
    more, and the per-frame work no longer grows with the trial's length."""
    t = loads.t_s
    lo = max(int(np.searchsorted(t, t_s - margin_s)) - 1, 0)
    hi = min(int(np.searchsorted(t, t_s + margin_s)) + 1, len(t))
    hi = max(hi, lo + 2)
    return FingerLoads(
        t_s=t[lo:hi],
        shear_force_n=loads.shear_force_n[lo:hi],
        twist_moment_nmm=loads.twist_moment_nmm[lo:hi],
        normal_force_n=loads.normal_force_n,
        contact_center_mm=loads.contact_center_mm,
    )


def _plain(value: Any) -> Any:
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    return value


class RigGripper:
    """The rig's gripper as the GCL server sees it (``gcl_server.GripperModel``)."""

    def __init__(self, rig: Rig):
        self.rig = rig

    def begin(self, command: str, args: list[float]) -> Motion:
        return self.rig.begin(command, args)

    def query(self, key: str) -> float:
        return self.rig.query(key)

    def acknowledge(self) -> None:
        self.rig.acknowledge()

    def fast_stop(self) -> None:
        self.rig.raise_fast_stop()


class RigArmModel:
    """The rig's arm as the arm server sees it (``arm_server.ArmModel``)."""

    def __init__(self, rig: Rig):
        self.rig = rig

    def begin_move(self, pose: list[float], speed: float, acceleration: float) -> ArmMove:
        return self.rig.begin_move(pose, speed, acceleration)

    def pose(self) -> list[float]:
        return self.rig.pose()

    def stop(self) -> None:
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
        self.streams: list[Any] = []
        if cameras:
            from liquidtouch.sim.rig.mjpeg import MjpegServer

            self.streams = [
                MjpegServer(
                    (lambda i=i: rig.frame(i)),
                    fps=rig.profile.fps,
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
        except BaseException:
            self.stop()
            raise
        return self

    def stop(self) -> None:
        for stream in self.streams:
            with contextlib.suppress(Exception):
                stream.stop()
        self.arm.stop()
        self.gcl.stop()

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
