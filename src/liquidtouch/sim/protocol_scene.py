"""A whole push-and-hold protocol at the marker level, as the simulated rig shows it.

:func:`protocol_scene` gives the two gels' marker positions over a camera span that may
start before the grasp or late (inside the ring-down) and run past the release: rest,
grasp (contact: the gel is squeezed by ``grasp_px``), lift (the bottle's weight comes
onto the fingers over the first :data:`~liquidtouch.sim.rig.state.LIFT_OFF_MM`), the push
(the simulator run with the push the arm commands, as :class:`~liquidtouch.sim.rig.state.Rig`
does), the hold, the lowering (the weight goes off) and the release (contact ends). It
follows the rig's rules (:mod:`liquidtouch.sim.rig.state`) without rendering or the
network, so the segmentation can be measured on many random protocols in seconds
(``benchmarks/ring_down/segmentation.py``) and the streaming estimator fed marker
positions directly.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from liquidtouch.sim.gelsight import marker_positions, marker_rest_positions
from liquidtouch.sim.rig.kinematics import move_duration
from liquidtouch.sim.rig.state import LIFT_OFF_MM
from liquidtouch.sim.sensors import get_sensor_profile
from liquidtouch.sim.trial import simulate_trial

__all__ = ["ProtocolScene", "ProtocolTimings", "protocol_scene"]


@dataclass(frozen=True)
class ProtocolTimings:
    """When each step starts [s, on the scene's clock] and how the arm moves.

    The defaults are :class:`~liquidtouch.acquire.protocol_params.ProtocolParameters`'
    (25 N grasp, 50 mm lift at 0.05 m/s, 15 mm push at 0.1 m/s and 1 m/s², 13 s hold).
    """

    grasp_s: float = 1.0
    grasp_duration_s: float = 0.4
    lift_s: float = 2.0
    lift_mm: float = 50.0
    lift_speed_m_s: float = 0.05
    lift_acceleration_m_s2: float = 0.5
    push_s: float = 5.0
    push_distance_mm: float = 15.0
    push_speed_m_s: float = 0.1
    push_acceleration_m_s2: float = 1.0
    hold_s: float = 13.0
    lower_after_s: float = 0.3
    release_after_s: float = 0.3

    @property
    def lift_duration_s(self) -> float:
        return move_duration(self.lift_mm * 1e-3, self.lift_speed_m_s, self.lift_acceleration_m_s2)

    @property
    def push_duration_s(self) -> float:
        return move_duration(
            abs(self.push_distance_mm) * 1e-3, self.push_speed_m_s, self.push_acceleration_m_s2
        )

    pushes: int = 1
    """Pushes of the same bottle (``run-trial --max-pushes``): each after the previous hold
    and ``between_s``, back and forth (every other push goes the other way)."""
    between_s: float = 3.0
    """Wait between a hold's end and the next push [s]: ``run-trial`` waits for the live
    estimate's final fit of the ring-down, which needs ~2 s of signal after the hold
    (``live.estimator.SETTLE_S`` after the guard, behind the trusted edge)."""

    def event_sequence(self) -> list[tuple[str, float]]:
        """The protocol's events in time order [s], as ``run_trial`` logs them; a hold that
        another push follows ends with ``hold_end``, the last with ``stopped``."""
        out = [("grasp", self.grasp_s), ("lift", self.lift_s)]
        push = self.push_s
        for k in range(self.pushes):
            pushed = push + self.push_duration_s
            out += [("push", push), ("pushed", pushed)]
            if k + 1 < self.pushes:
                out.append(("hold_end", pushed + self.hold_s))
                push = pushed + self.hold_s + self.between_s
        stopped = pushed + self.hold_s
        lower = stopped + self.lower_after_s
        lowered = lower + self.lift_duration_s
        return [
            *out,
            ("stopped", stopped),
            ("lower", lower),
            ("release", lowered + self.release_after_s),
        ]

    def events(self) -> dict[str, float]:
        """The protocol's events [s]: the last of each name (:meth:`event_sequence`)."""
        return dict(self.event_sequence())

    def push_starts(self) -> list[float]:
        """When each push starts [s]."""
        return [t for name, t in self.event_sequence() if name == "push"]


@dataclass
class ProtocolScene:
    """Marker positions over the camera span: ``t`` (T,) [s], ``positions`` (2, T, N, 2) [px]
    (left, right), the ``events`` [s] and the liquid's true λ [1/s], ω [rad/s]."""

    t: np.ndarray
    positions: np.ndarray
    events: dict[str, float]
    true_decay_rate: float
    true_angular_frequency: float
    extra: dict[str, float] = field(default_factory=dict)
    event_sequence: list[tuple[str, float]] = field(default_factory=list)
    """Every event in time order (several pushes: ``ProtocolTimings.pushes``)."""


def _weight_fraction(now: np.ndarray, move_s: float, duration_s: float, mm: float) -> np.ndarray:
    """Fraction of the lift (0-1) done; the weight is on after ``LIFT_OFF_MM`` of it."""
    done = np.clip((now - move_s) / duration_s, 0.0, 1.0) * mm
    return np.clip(done / LIFT_OFF_MM, 0.0, 1.0)


def protocol_scene(
    liquid: str,
    *,
    height_mm: float,
    seed: int = 0,
    sensor: str = "mini",
    timings: ProtocolTimings | None = None,
    camera_start_s: float = 0.0,
    camera_end_s: float | None = None,
    grasp_px: float = 0.6,
    noise_px: float = 0.02,
    sugar_concentration: float | None = None,
    container: str = "grooved-cuboid",
) -> ProtocolScene:
    """The markers of both gels through a whole protocol (module docstring).

    ``camera_start_s``/``camera_end_s`` [s]: the span the cameras see (default: to 2 s
    after the release); frames at the sensor's nominal rate. ``grasp_px``: how far the
    grasp squeezes the markers [px] (the rig shows none; a real gel moves); ``noise_px``:
    the tracker's noise per marker coordinate [px].
    """
    timings = ProtocolTimings() if timings is None else timings
    profile = get_sensor_profile(sensor)
    events = timings.events()
    end = events["release"] + 2.0 if camera_end_s is None else float(camera_end_s)
    t = np.arange(float(camera_start_s), end, 1.0 / profile.fps)
    args = {
        "height_mm": height_mm,
        "seed": seed,
        "sugar_concentration": sugar_concentration,
        "container": container,
    }
    base = simulate_trial(liquid, **args, duration_s=30.0)
    starts = timings.push_starts()
    pushed = [
        simulate_trial(
            liquid,
            **args,
            duration_s=max(30.0, timings.hold_s + 5.0),
            parameters={
                "push_distance_mm": timings.push_distance_mm * (-1) ** k,
                "push_duration_s": timings.push_duration_s,
            },
            noise_seed=k + 1 if k else None,  # a repeated push: the contact noise drawn afresh
        )
        for k in range(len(starts))
    ]
    rng = np.random.default_rng([base.seed, 7])
    rests = np.stack([marker_rest_positions(profile, rng) for _ in range(2)])
    # the weight on the fingers: on over the lift, off over the end of the lowering
    up = _weight_fraction(t, events["lift"], timings.lift_duration_s, timings.lift_mm)
    down_done = np.clip((t - events["lower"]) / timings.lift_duration_s, 0.0, 1.0)
    down = np.clip((timings.lift_mm * (1 - down_done)) / LIFT_OFF_MM, 0.0, 1.0)
    weight = np.where(t < events["lower"], up, down)
    contact = (t >= events["grasp"]) & (t < events["release"])
    squeeze = np.clip((t - events["grasp"]) / timings.grasp_duration_s, 0.0, 1.0) * contact
    # the trial clock: the base trial's lifted rest before the first push, each pushed
    # trial from its push on (each push restarts the simulation from rest, as the rig)
    which = np.searchsorted(starts, t, side="right") - 1  # -1: before the first push
    spans = [(base, which < 0, np.minimum(np.maximum(t - events["lift"], 0.0),
                                         base.params.push_start_s - 1e-3))]  # fmt: skip
    for k, trial in enumerate(pushed):
        spans.append((trial, which == k, trial.params.push_start_s + (t - starts[k])))
    positions = np.repeat(rests[:, None], len(t), axis=1)
    for trial, mask, trial_t in spans:
        if mask.any():
            at = np.clip(trial_t[mask], 0.0, float(trial.t_s[-1]) - 0.1)
            for s in range(2):
                moved = marker_positions(trial.loads, profile, at, rest_px=rests[s])[s]
                positions[s, mask] = rests[s] + weight[mask, None, None] * (moved - rests[s])
    positions[..., 1] += grasp_px * squeeze[None, :, None]
    positions = positions + rng.normal(0.0, noise_px, positions.shape)
    return ProtocolScene(
        t=t,
        positions=positions,
        events=events,
        true_decay_rate=float(pushed[0].true_decay_rate),
        true_angular_frequency=float(pushed[0].true_angular_frequency),
        extra={"push_duration_s": timings.push_duration_s},
        event_sequence=timings.event_sequence(),
    )
