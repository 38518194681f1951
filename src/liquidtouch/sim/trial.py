"""One simulated trial: draw the trial's conditions, run the dynamics, build the loads.

A trial is a lift, a lateral minimum-jerk push and a hold
(:mod:`liquidtouch.sim.activation`) of a container of liquid
(:mod:`liquidtouch._core.liquids`, :mod:`liquidtouch._core.containers`) whose
sloshing (:mod:`liquidtouch.sim.slosh`) loads the gels and the wrist
(:mod:`liquidtouch.sim.grasp`). The random conditions of a trial and their
calibration are described in :mod:`liquidtouch.sim.variability`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from functools import partial

import numpy as np

from liquidtouch._core.containers import get_container
from liquidtouch._core.liquids import MAX_SUGAR_CONCENTRATION, get_liquid
from liquidtouch.errors import CatalogueError, LiquidTouchError
from liquidtouch.io.dataset import LABEL_COLUMNS, TRUTH_COLUMNS
from liquidtouch.sim.activation import min_jerk_acceleration
from liquidtouch.sim.grasp import finger_loads, net_loads, wrist_wrench
from liquidtouch.sim.loads import FingerLoads
from liquidtouch.sim.nuisances import finger_slips, perturb_parameters, unequal_grip
from liquidtouch.sim.realism import Realism, get_realism
from liquidtouch.sim.slosh import integrate, sinusoid_response, slosh_system
from liquidtouch.sim.variability import TrialParameters, Variability, draw_parameters

__all__ = ["SimulatedTrial", "simulate_trial"]

SAMPLE_RATE_HZ = 240.0
DURATION_S = 13.0
CAMERA_FPS = 30.0
MIN_DURATION_S = 3.0
MAX_DURATION_S = 120.0
"""Longest trial [s]: the paper's trials last 13 s; longer ones only cost memory and time."""
MIN_SAMPLE_RATE_HZ = 60.0
MAX_SAMPLE_RATE_HZ = 2000.0
"""Highest load sample rate [Hz] (the slosh lives below 5 Hz; the default is 240 Hz)."""
FILL_MARGIN_MM = 1.0
"""A trial's fill height stays this far from empty and from full [mm]: below, the liquid
is a film and above, the container is brim-full; the slosh model holds for neither."""
MAX_SEED = 2**63 - 1
"""Largest seed: seeds are stored as 64-bit integers in meta.json and the manifest."""


def _check_range(
    what: str, value: object, unit: str, low: float, high: float, words: tuple[str, str]
) -> None:
    allowed = f"use {low:g}-{high:g} {unit}"
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise LiquidTouchError(f"{what} must be a number of {unit}, got {value!r}; {allowed}")
    if not math.isfinite(value):
        raise LiquidTouchError(f"{what} {value} {unit} is not a finite number; {allowed}")
    if value < low:
        raise LiquidTouchError(f"{what} {value:g} {unit} is {words[0]}; {allowed}")
    if value > high:
        raise LiquidTouchError(f"{what} {value:g} {unit} is {words[1]}; {allowed}")


def check_seed(seed: object) -> int:
    """Return ``seed`` as an int; :class:`LiquidTouchError` unless an integer in 0..2**63-1."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
        raise LiquidTouchError(f"the seed must be a non-negative integer, got {seed!r}")
    if not 0 <= int(seed) <= MAX_SEED:
        raise LiquidTouchError(
            f"seed {seed} is out of range; use a non-negative integer up to 2**63-1"
        )
    return int(seed)


def _replace_parameters(params: TrialParameters, values: Mapping[str, float]) -> TrialParameters:
    """``params`` with the scalar fields in ``values`` replaced; raise if one is bad."""
    scalars = {
        f.name for f in fields(TrialParameters) if isinstance(getattr(params, f.name), float)
    }
    for name, value in values.items():
        if name not in scalars:
            raise LiquidTouchError(
                f"unknown trial parameter {name!r}; use one of: {', '.join(sorted(scalars))}"
            )
        if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
            raise LiquidTouchError(f"trial parameter {name} must be a number, got {value!r}")
        if not math.isfinite(value):
            raise LiquidTouchError(f"trial parameter {name} must be finite, got {value!r}")
    if values.get("push_duration_s", params.push_duration_s) <= 0:
        raise LiquidTouchError("trial parameter push_duration_s must be positive")
    return replace(params, **{name: float(v) for name, v in values.items()})


@dataclass(frozen=True)
class SimulatedTrial:
    """A simulated trial: loads on the fingers, wrist wrench, labels and ground truth."""

    loads: FingerLoads
    wrench: np.ndarray  # (n, 6): fx, fy, fz [N], tx, ty, tz [N·m], world-aligned at the wrist
    liquid: str
    container: str
    height_mm: float
    sugar_concentration: float | None
    viscosity_cst: float
    log10_viscosity_cst: float
    temperature_c: float
    true_decay_rate: float
    true_angular_frequency: float
    seed: int
    params: TrialParameters
    extra: dict[str, float] = field(default_factory=dict)
    realism: Realism = field(default_factory=Realism.clean)
    realism_drawn: dict[str, object] = field(default_factory=dict)
    """What the nuisances drew for this trial (``meta.json``: ``realism.drawn``)."""
    push_axis: str = "x"
    """World axis of the push (``x``: along the container's length)."""

    def __repr__(self) -> str:
        """One line: the liquid, fill, container, seed, span and the true λ, ω (no arrays)."""
        return (
            f"SimulatedTrial({self.liquid!r}, height_mm={self.height_mm:g}, "
            f"container={self.container!r}, seed={self.seed}, {len(self.t_s)} samples over "
            f"{float(self.t_s[-1] - self.t_s[0]):.3g} s, true_decay_rate="
            f"{self.true_decay_rate:.5g} 1/s, true_angular_frequency="
            f"{self.true_angular_frequency:.5g} rad/s, realism={self.realism.world!r})"
        )

    def realism_record(self) -> dict[str, object]:
        """The ``realism`` object of ``meta.json``: world, every parameter, the draws."""
        return {
            "world": self.realism.world,
            "parameters": self.realism.to_dict(),
            "drawn": self.realism_drawn,
        }

    @property
    def t_s(self) -> np.ndarray:
        """Sample times [s]."""
        return self.loads.t_s

    def labels(self) -> dict[str, object]:
        """The dataset's label and ground-truth columns (``LABEL_COLUMNS``, ``TRUTH_COLUMNS``)."""
        return {name: getattr(self, name) for name in (*LABEL_COLUMNS, *TRUTH_COLUMNS)}

    def slosh_force_n(self) -> np.ndarray:
        """Total lateral (x) force on both gels [N], the simplest 1-D slosh signal."""
        return self.loads.shear_force_n[:, :, 0].sum(axis=1)


def simulate_trial(
    liquid: str,
    *,
    height_mm: float,
    container: str = "grooved-cuboid",
    sugar_concentration: float | None = None,
    seed: int = 0,
    temperature_c: float | None = None,
    duration_s: float = DURATION_S,
    sample_rate_hz: float = SAMPLE_RATE_HZ,
    variability: Variability | None = None,
    parameters: Mapping[str, float] | None = None,
    realism: Realism | str | None = None,
    push_axis: str = "x",
    noise_seed: int | None = None,
) -> SimulatedTrial:
    """Simulate one trial: lift, lateral push, hold; return loads, wrench and ground truth.

    ``liquid`` and ``container`` are catalogue names (``water``, ``olive-oil``,
    ``corn-oil``, ``mirin``, ``detergent``, ``sugar-water`` with
    ``sugar_concentration`` in g sugar per 100 g water; ``grooved-cuboid``,
    ``cuboid``, ``cylinder``, ``glass``). ``height_mm`` is the nominal fill
    height; ``temperature_c`` defaults to a draw around 21 °C. Deterministic
    given ``seed``. The ground truth ``true_decay_rate`` [1/s] and
    ``true_angular_frequency`` [rad/s] are the small-amplitude slow mode of the
    coupled liquid-container-grasp system (eigenvalue of the linearised model).
    ``variability`` sets the calibrated spreads and noise (default
    :class:`Variability`). ``parameters`` replaces drawn :class:`TrialParameters`
    fields by name after the draw (the random stream is unchanged, so everything
    else stays as the seed made it), e.g. ``{"push_distance_mm": 12.0,
    "push_duration_s": 0.25}`` for a push that a (simulated) arm commanded.
    ``realism`` adds the nuisances of a real bench (:class:`~liquidtouch.sim.realism.Realism`,
    or ``"clean"``/``"lab"``; default clean, bit-identical to the simulator
    without it); the physical ones act here, after ``parameters``, the gel and
    camera ones when the videos are written. ``push_axis``: the world axis of the push,
    ``"x"`` (the container's length, the paper's) or ``"y"`` (across it,
    :meth:`~liquidtouch._core.containers.Container.along`). ``noise_seed``: another
    draw of the contact and wrist noise for the same bottle and conditions (a repeated
    push of one bottle); ``None`` keeps the seed's own. Labels stay the nominal, measured
    values: under ``temperature`` the viscosity label is the one at the recorded
    temperature while the liquid sloshes at another.

    Limits: ``height_mm`` at least 1 mm from empty and from full
    (:data:`FILL_MARGIN_MM`); ``seed`` an integer in 0..2**63-1; ``duration_s`` within
    3-120 s (:data:`MAX_DURATION_S`); ``sample_rate_hz`` within 60-2000 Hz
    (:data:`MAX_SAMPLE_RATE_HZ`); ``temperature_c`` within 0-60 °C. Anything
    else raises :class:`~liquidtouch.errors.LiquidTouchError` before any work.
    """
    var = Variability() if variability is None else variability
    world = get_realism(realism)
    seed = check_seed(seed)
    box = get_container(container)
    box.along(push_axis)  # validate the axis early
    if noise_seed is not None:
        noise_seed = check_seed(noise_seed)
    get_liquid(liquid, sugar_concentration=sugar_concentration)  # validate names early
    box.check_height(height_mm)
    if not FILL_MARGIN_MM <= height_mm <= box.depth_mm - FILL_MARGIN_MM:
        raise CatalogueError(
            f"fill height {height_mm:g} mm does not fit container {container!r}: use "
            f"{FILL_MARGIN_MM:g}-{box.depth_mm - FILL_MARGIN_MM:g} mm (the slosh model needs "
            "more than a film of liquid and some free space above it)"
        )
    if temperature_c is not None:
        get_liquid(liquid, sugar_concentration=sugar_concentration, temperature_c=temperature_c)
    _check_range(
        "duration", duration_s, "s", MIN_DURATION_S, MAX_DURATION_S, ("too short", "too long")
    )
    _check_range(
        "sample rate",
        sample_rate_hz,
        "Hz",
        MIN_SAMPLE_RATE_HZ,
        MAX_SAMPLE_RATE_HZ,
        ("too low", "too high"),
    )
    rng = np.random.default_rng(seed)
    params = draw_parameters(rng, height_mm, box.wall_factor, box.contact_line_damping, var)
    if temperature_c is not None:
        params = replace(params, temperature_c=float(temperature_c))
    if parameters:
        params = _replace_parameters(params, parameters)
    drawn: dict[str, object] = {}
    if not world.is_clean:
        params, drawn = perturb_parameters(params, world, seed, container_depth_mm=box.depth_mm)
    true_height = float(np.clip(params.true_height_mm, 0.5, box.depth_mm - 0.5))
    true_conc = sugar_concentration
    if liquid == "sugar-water" and sugar_concentration:
        true_conc = min(sugar_concentration * params.concentration_factor, MAX_SUGAR_CONCENTRATION)
    props = get_liquid(liquid, sugar_concentration=true_conc, temperature_c=params.temperature_c)
    label_props = props
    if "liquid_temperature_c" in drawn:  # the liquid is warmer or colder than when measured
        props = get_liquid(
            liquid, sugar_concentration=true_conc, temperature_c=drawn["liquid_temperature_c"]
        )
    system = slosh_system(
        props,
        box,
        true_height,
        wall_factor=params.wall_factor,
        contact_line_damping=params.contact_line_damping,
        support_stiffness_n_m=params.support_stiffness_n_m,
        axis=push_axis,
    )
    true_lambda, true_omega = system.slow_mode()

    n = round(duration_s * sample_rate_hz) + 1
    t = np.arange(n) / sample_rate_hz
    push = partial(
        min_jerk_acceleration,
        distance_m=params.push_distance_mm * 1e-3,
        start_s=params.push_start_s,
        duration_s=params.push_duration_s,
    )
    y0 = np.zeros(2 + 2 * len(system.modes))
    y0[2] = params.initial_slosh_mm * 1e-3 * math.cos(params.initial_phase_rad)
    y0[3] = -params.initial_slosh_mm * 1e-3 * math.sin(params.initial_phase_rad)
    y0[3] *= system.modes[0].natural_frequency
    state = integrate(system, t, push, y0)
    vib_state, vib_hand = sinusoid_response(
        system,
        t,
        np.array(params.vibration_hz),
        np.array(params.vibration_m_s2),
        np.array(params.vibration_phase_rad),
    )
    state = state + vib_state
    hand_acc = push(t) + vib_hand

    net = net_loads(system, state, t, params, box.depth_mm)
    if noise_seed is not None:  # the same bottle and conditions, the noise drawn afresh
        rng = np.random.default_rng([seed, noise_seed])
    loads = finger_loads(t, net, params, rng, var)
    wrench = wrist_wrench(t, net, hand_acc, rng, var)
    if "grip_ratio_left_right" in drawn:
        loads = unequal_grip(loads, float(drawn["grip_ratio_left_right"]))
    if world.active("finger_slip"):
        loads, drawn["slips"] = finger_slips(loads, params.push_end_s, world, seed)
    finite = (loads.shear_force_n, loads.twist_moment_nmm, wrench, [true_lambda, true_omega])
    if not all(np.isfinite(np.asarray(a, dtype=float)).all() for a in finite):
        raise LiquidTouchError(
            f"the simulation of {liquid} at {height_mm:g} mm in {container!r} diverged "
            "(non-finite loads); choose a fill height further from empty or full"
        )
    return SimulatedTrial(
        loads=loads,
        wrench=wrench,
        liquid=liquid,
        container=container,
        height_mm=float(height_mm),
        sugar_concentration=(
            float(sugar_concentration)
            if sugar_concentration is not None
            else props.sugar_concentration
        ),
        viscosity_cst=label_props.viscosity_cst,
        log10_viscosity_cst=label_props.log10_viscosity_cst,
        temperature_c=params.temperature_c,
        true_decay_rate=true_lambda,
        true_angular_frequency=true_omega,
        seed=int(seed),
        params=params,
        extra={
            "density_kg_m3": props.density_kg_m3,
            "liquid_mass_g": system.liquid_mass_kg * 1e3,
            "true_height_mm": true_height,
            "true_sugar_concentration": props.sugar_concentration,
            "fill_fraction": box.fill_fraction(true_height),
            "natural_frequency": system.modes[0].natural_frequency,
            "push_start_s": params.push_start_s,
            "push_end_s": params.push_end_s,
        },
        realism=world,
        realism_drawn=drawn,
        push_axis=push_axis,
    )
