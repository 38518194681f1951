"""Choosing the push: the direction and strength that let a target reach its ±.

How much one push can tell depends on the container and the fill (issue 40): the slosh
frequency's sensitivity to the height, ``dω/dh`` from ``ω² = g k tanh(k h)``, collapses
as the fill deepens, faster the shorter the slosh length ``π/k``. :func:`plan_push`
weighs, for a container (catalogue name, or a :class:`~liquidtouch._core.containers.Container`)
and each horizontal push axis it allows:

- **direction**: at each planned fill, the small-amplitude (λ, ω) of the slosh along
  that axis (the simulator's physics, :func:`~liquidtouch.sim.slosh.slosh_system`, for
  water: ω hardly depends on the liquid), and through the property model — when one is
  given — the best ± any number of pushes of that kind gives
  (:meth:`~liquidtouch.models.property_model.PropertyModel.reach`: the model's own ±,
  the fit's floor through the model's slope, the training range); without a model,
  the height's own floor ``FIT_FLOOR_ω · ω / (dω/dh)``.
- **strength**: the fit's random error shrinks as the ring-down's amplitude grows (a
  push twice as strong is worth about four repeats), until the slosh turns
  non-linear. Over the protocol's limits (distance, speed, acceleration) the planner
  simulates the push's slosh at the middle fill and keeps the strongest whose wave
  steepness after the push stays within that of the protocol's default push on the
  paper's container at the middle of its fills (:func:`reference_steepness`): the
  firmest slosh the fit's benchmarks measure it on (beyond, the damping grows with the
  amplitude ever more, :mod:`liquidtouch.sim.slosh`).

The axis chosen is the one whose fills are reachable (then the one with the smaller
floor); :attr:`PushPlan.reachable` is false when no axis reaches the target at some
fill, and :attr:`PushPlan.reason` names the fills no push of this container's kind can
resolve. ``run-trial --plan`` prints it; ``PushPlan.protocol_values()`` are the protocol
file's push fields.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import cache, partial

import numpy as np

from liquidtouch._core.containers import Container, get_container
from liquidtouch._core.liquids import get_liquid
from liquidtouch.acquire.arms import linear_move_duration
from liquidtouch.acquire.protocol_params import ProtocolParameters
from liquidtouch.errors import LiquidTouchError
from liquidtouch.models.reach import FIT_FLOOR
from liquidtouch.sim.activation import min_jerk_acceleration
from liquidtouch.sim.slosh import integrate, slosh_system

__all__ = ["AxisPlan", "PushPlan", "plan_push", "reference_steepness"]

#: the paper's container and the middle of its fills (16-40 mm): where the reference push
#: is measured (:func:`reference_steepness`)
REFERENCE_CONTAINER, REFERENCE_FILL_MM = "grooved-cuboid", 28.0
#: the push strengths tried: distances [mm], speeds [m/s], accelerations [m/s²] within the
#: protocol's limits (acquire.protocol_params.ProtocolParameters), from gentle to firm
DISTANCES_MM = (10.0, 15.0, 20.0, 30.0, 40.0)
SPEEDS_M_S = (0.1, 0.2, 0.3)
ACCELERATIONS_M_S2 = (1.0, 2.0, 3.0, 5.0)
#: the simulated span after the push in which the slosh's amplitude is read [s]
_SPAN_S = 1.5


@dataclass(frozen=True)
class AxisPlan:
    """One push axis: its push, the slosh it makes and the ± it can reach at each fill.

    ``fills_mm`` and, per fill, ``angular_frequency`` [rad/s], ``decay_rate`` [1/s] (water)
    and ``limit_std`` (the target's best ± any number of such pushes gives; NaN: no model
    target); ``reachable`` per fill; ``steepness`` (wave steepness after the push) and
    ``amplitude_mm`` (the slosh's wall elevation then) at the middle fill.
    """

    axis: str
    slosh_length_mm: float
    distance_mm: float
    speed_m_s: float
    acceleration_m_s2: float
    steepness: float
    amplitude_mm: float
    fills_mm: tuple[float, ...]
    angular_frequency: tuple[float, ...]
    decay_rate: tuple[float, ...]
    limit_std: tuple[float, ...]
    reachable: tuple[bool, ...]

    def to_dict(self) -> dict[str, object]:
        """JSON-ready."""
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in self.__dict__.items()}


@dataclass(frozen=True)
class PushPlan:
    """The proposed push (:attr:`chosen`) and every axis considered (module docstring)."""

    container: str
    target: str
    asked_std: float
    axes: tuple[AxisPlan, ...]
    chosen: AxisPlan
    reachable: bool
    reason: str = ""
    notes: list[str] = field(default_factory=list)

    def protocol_values(self) -> dict[str, object]:
        """The chosen push as protocol-file fields (``push_axis``, distance, speed, ...)."""
        c = self.chosen
        return {
            "push_axis": c.axis,
            "push_distance_mm": c.distance_mm,
            "push_speed_m_s": c.speed_m_s,
            "push_acceleration_m_s2": c.acceleration_m_s2,
        }

    def to_dict(self) -> dict[str, object]:
        """JSON-ready."""
        return {
            "container": self.container,
            "target": self.target,
            "asked_std": self.asked_std,
            "reachable": self.reachable,
            "reason": self.reason,
            "protocol": self.protocol_values(),
            "axes": [a.to_dict() for a in self.axes],
        }

    def lines(self) -> list[str]:
        """Human-readable lines: one per axis, then the proposal."""
        out = []
        for a in self.axes:
            cells = ", ".join(
                f"{h:g} mm: ±{s:.3g}" + ("" if ok else " (cannot tell)")
                for h, s, ok in zip(a.fills_mm, a.limit_std, a.reachable, strict=True)
            )
            out.append(
                f"axis {a.axis} (slosh over {a.slosh_length_mm:g} mm): push "
                f"{a.distance_mm:g} mm at {a.speed_m_s:g} m/s, {a.acceleration_m_s2:g} m/s² "
                f"(steepness {a.steepness:.2f}); best {self.target} ± by fill: {cells}"
            )
        verdict = "reachable" if self.reachable else f"NOT reachable everywhere: {self.reason}"
        out.append(f"proposed: push along {self.chosen.axis} ({verdict})")
        return out


def plan_push(
    container: str | Container,
    target: str = "height_mm",
    asked_std: float = 0.5,
    *,
    model: object | None = None,
    fills_mm: Sequence[float] | None = None,
    limits: Mapping[str, float] | None = None,
) -> PushPlan:
    """Propose the push for ``target`` to reach ``asked_std`` in ``container`` (module docstring).

    ``model``: a regression :class:`~liquidtouch.models.property_model.PropertyModel`
    (its :meth:`reach` judges each fill; it must predict ``target``); without one only
    ``height_mm`` can be planned (the physics' own floor). ``fills_mm``: the fills to plan
    for (default 25, 50 and 75 % of the container's inner height). ``limits``: the
    largest ``push_distance_mm``, ``push_speed_m_s``, ``push_acceleration_m_s2`` allowed
    (default: the grid's largest). Raises :class:`LiquidTouchError` for a bad request.
    """
    box = get_container(container) if isinstance(container, str) else container
    if not 0 < asked_std < math.inf:
        raise LiquidTouchError(f"the asked std of {target} must be a number > 0, got {asked_std}")
    if model is None and target != "height_mm":
        raise LiquidTouchError(f"planning for {target!r} needs a property model (--model)")
    if model is not None and target not in getattr(model, "regressors", {}):
        raise LiquidTouchError(f"the model does not predict {target!r}")
    fills = tuple(float(h) for h in (fills_mm or [box.depth_mm * f for f in (0.25, 0.5, 0.75)]))
    for h in fills:
        box.check_height(h)
    limits = dict(limits or {})
    axes = tuple(
        _axis_plan(box, axis, fills, target, asked_std, model, limits) for axis in box.axes()
    )
    ok = [a for a in axes if all(a.reachable)]
    chosen = min(ok or axes, key=lambda a: (-sum(a.reachable), float(np.nanmax(a.limit_std))))
    reason = ""
    if not ok:
        lost = [h for h, r in zip(chosen.fills_mm, chosen.reachable, strict=True) if not r]
        reason = (
            f"at {', '.join(f'{h:g}' for h in lost)} mm of fill no push of this container's kind "
            f"reaches ±{asked_std:g} on {target} (best ±{np.nanmax(chosen.limit_std):.3g})"
        )
    return PushPlan(box.name, target, float(asked_std), axes, chosen, bool(ok), reason)


def _axis_plan(
    box: Container,
    axis: str,
    fills: tuple[float, ...],
    target: str,
    asked: float,
    model: object | None,
    limits: Mapping[str, float],
) -> AxisPlan:
    water = get_liquid("water")
    modes = [slosh_system(water, box, h, axis=axis).slow_mode() for h in fills]
    lam = tuple(m[0] for m in modes)
    omega = tuple(m[1] for m in modes)
    if model is not None:
        X = np.array([lam, omega]).T
        reach = [model.reach(X[i : i + 1], None, {target: asked})[target] for i in range(len(X))]
        # outside the training range the model's ± would be an extrapolation: out of reach
        limit = tuple(math.inf if r.reason == "domain" else r.limit_std for r in reach)
    else:
        limit = tuple(_height_floor(box, axis, h, w) for h, w in zip(fills, omega, strict=True))
    push = _strongest_push(box, axis, fills[len(fills) // 2], limits)
    return AxisPlan(
        axis=axis,
        slosh_length_mm=box.along(axis).length_mm,
        **push,
        fills_mm=fills,
        angular_frequency=omega,
        decay_rate=lam,
        limit_std=limit,
        reachable=tuple(bool(s < asked) for s in limit),
    )


def _height_floor(box: Container, axis: str, height_mm: float, omega: float) -> float:
    """The height's best std [mm] from ω's fit floor: ``FIT_FLOOR_ω · ω / |dω/dh|``."""
    water = get_liquid("water")
    step = min(0.5, 0.25 * height_mm, 0.25 * (box.depth_mm - height_mm))
    hi = slosh_system(water, box, height_mm + step, axis=axis).slow_mode()[1]
    lo = slosh_system(water, box, height_mm - step, axis=axis).slow_mode()[1]
    slope = abs(hi - lo) / (2 * step)
    return FIT_FLOOR[1] * omega / slope if slope > 0 else math.inf


@cache
def reference_steepness() -> float:
    """Wave steepness after the protocol's default push on the paper's container (water,
    at :data:`REFERENCE_FILL_MM`): the firmest push the planner proposes."""
    p = ProtocolParameters()
    system = slosh_system(
        get_liquid("water"), get_container(REFERENCE_CONTAINER), REFERENCE_FILL_MM
    )
    return _slosh_after(system, p.push_distance_mm, p.push_speed_m_s, p.push_acceleration_m_s2)[0]


def _slosh_after(system, distance_mm: float, speed: float, acceleration: float):
    """(steepness, wall elevation [mm]) of the first mode after a push (simulated)."""
    mode = system.modes[0]
    duration = linear_move_duration(distance_mm * 1e-3, speed, acceleration)
    t = np.linspace(0.0, duration + _SPAN_S, int((duration + _SPAN_S) * 200) + 1)
    push = partial(
        min_jerk_acceleration, distance_m=distance_mm * 1e-3, start_s=0.0, duration_s=duration
    )
    state = integrate(system, t, push, np.zeros(2 + 2 * len(system.modes)))
    after = t > duration
    amp = float(np.max(np.hypot(state[2][after], state[3][after] / mode.natural_frequency)))
    steepness = amp * mode.steepness_per_m
    return steepness, steepness / mode.wavenumber_1_m * 1e3


def _strongest_push(
    box: Container, axis: str, height_mm: float, limits: Mapping[str, float]
) -> dict[str, float]:
    """The push of the grid with the largest slosh within :func:`reference_steepness`
    (the gentlest of the grid when every push is steeper)."""
    system = slosh_system(get_liquid("water"), box, height_mm, axis=axis)
    ceiling = reference_steepness()
    options = []
    for d in DISTANCES_MM:
        for v in SPEEDS_M_S:
            for a in ACCELERATIONS_M_S2:
                if (
                    d > limits.get("push_distance_mm", math.inf)
                    or v > limits.get("push_speed_m_s", math.inf)
                    or a > limits.get("push_acceleration_m_s2", math.inf)
                ):
                    continue
                steepness, amplitude = _slosh_after(system, d, v, a)
                options.append(
                    {
                        "distance_mm": d,
                        "speed_m_s": v,
                        "acceleration_m_s2": a,
                        "steepness": steepness,
                        "amplitude_mm": amplitude,
                    }
                )
    if not options:
        raise LiquidTouchError("the protocol's limits leave no push to plan")
    within = [o for o in options if o["steepness"] <= ceiling * (1 + 1e-9)]
    if within:
        return max(within, key=lambda o: o["steepness"])
    return min(options, key=lambda o: o["steepness"])
