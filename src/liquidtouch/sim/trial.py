"""One simulated trial: draw the trial's random conditions, run the dynamics, build the loads.

Trial-to-trial variation (all drawn from ``numpy.random.default_rng(seed)``;
distributions are choices meant to match a careful lab, not measured):

- lab temperature ~ N(21, 1.5) °C, clipped to 18-25 °C (unless given);
- fill error: the true fill height is the nominal one + N(0, 0.4) mm
  (volume dosing, meniscus, container tolerance); labels keep the nominal height;
- sugar weighing/evaporation: true concentration = nominal × exp(N(0, 0.02));
  the label keeps the nominal concentration, the viscosity label is the true one
  (the paper measured each solution's viscosity);
- wall wetting (film drainage, air trapped in grooves, surface contamination
  between fills): wall factor × exp(N(0, 0.12)); contact-line term × U(0.5, 3);
- placement of the contact on the container: N(0, 3) mm along x, N(0, 2) mm
  along y; contact centre on each gel N(0, 1) mm per axis; load share of the
  left finger 0.5 + N(0, 0.03);
- grasp: normal force per finger U(10, 16) N; the lateral support stiffness
  scales as (normal force)^(1/3) around 2500 N/m;
- push: min-jerk lateral move of N(15, 2) mm (clipped 10-20) over U(0.25, 0.35) s
  starting at 1.0 ± 0.1 s; residual slosh from the lift, amplitude U(0, 0.5) mm;
- arm vibration: three structural modes at U(8, 30) Hz, 0.01-0.03 m/s² each;
- in-hand slip: after the push the loads drift (creep/slip of the grasp) as
  ``1 − exp(−t/τ)``, τ ~ U(2, 8) s, by U(0, 0.03) N in y, N(0, 5) mN in x and
  N(0, 0.5) N·mm in twist;
- contact noise on the gel loads: white, 1.5 mN and 0.05 N·mm per sample at 240 Hz.

Calibration: the spreads above were set once, by running the paper's method on
the simulator's force signal (``benchmarks/sim_calibration.py``: 3 Hz low-pass,
30 fps, ``fit_oscillation``, GPR with RBF + white noise on standardised λ, ω,
full ``sugar`` preset) and widening the physically motivated spreads (fill,
wetting, temperature, weighing) — never the estimator — until the force-level
test errors were ~55-65 % of the paper's GPR errors (0.56 mm, 15.3 wt%, 0.16 in
log10 cSt), leaving room for the GelSight stage (marker noise, tracking),
which adds its own error on top. Result: 0.36 mm, 8.2 wt%, 0.088 (quadratic
model: 0.42, 8.9, 0.097).

The wrist force-torque signal is that of a UR5e-class built-in sensor (data sheet:
force precision 3.5 N, torque 0.2 N·m): white noise σ = 1.2 N and 0.06 N·m per
sample plus a random-walk bias (0.05 N/√s, 2.5 mN·m/√s), on top of the gel loads and the gripper's
(0.9 kg) inertia and weight.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

from liquidtouch.errors import LiquidTouchError
from liquidtouch.sim.containers import get_container
from liquidtouch.sim.liquids import MAX_SUGAR_CONCENTRATION, get_liquid
from liquidtouch.sim.loads import FingerLoads
from liquidtouch.sim.slosh import (
    GRAVITY_M_S2,
    SloshSystem,
    accelerations,
    integrate,
    sinusoid_response,
    slosh_system,
)

SAMPLE_RATE_HZ = 240.0
DURATION_S = 13.0
CAMERA_FPS = 30.0
GRIPPER_MASS_KG = 0.9
WRIST_TO_CONTACT_M = 0.15


@dataclass(frozen=True)
class Variability:
    """Spread of the calibrated trial-to-trial variations and noise (defaults: see module doc).

    Pass ``Variability(...)`` to :func:`simulate_trial` to study or re-calibrate
    them; ``Variability.none()`` gives the clean physics (no label noise, no
    contact or wrist noise; the push and grasp still vary with the seed).
    """

    temperature_sd_c: float = 1.5
    fill_error_sd_mm: float = 0.4
    wall_factor_log_sd: float = 0.12
    contact_line_range: tuple[float, float] = (0.5, 3.0)
    concentration_rel_sd: float = 0.02
    contact_noise_n: float = 1.5e-3
    contact_noise_nmm: float = 0.05
    wrist_force_noise_n: float = 1.2
    wrist_torque_noise_nm: float = 0.06

    @classmethod
    def none(cls) -> Variability:
        """No label noise and no sensor noise."""
        return cls(0.0, 0.0, 0.0, (1.0, 1.0), 0.0, 0.0, 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class TrialParameters:
    """The random conditions of one trial (see the module docstring for distributions)."""

    temperature_c: float
    true_height_mm: float
    wall_factor: float
    contact_line_damping: float
    placement_mm: tuple[float, float]
    gel_contact_mm: tuple[tuple[float, float], tuple[float, float]]
    left_share: float
    normal_force_n: float
    support_stiffness_n_m: float
    push_distance_mm: float
    push_duration_s: float
    push_start_s: float
    initial_slosh_mm: float
    initial_phase_rad: float
    vibration_hz: tuple[float, ...]
    vibration_m_s2: tuple[float, ...]
    vibration_phase_rad: tuple[float, ...]
    slip_time_constant_s: float
    slip_drift: tuple[float, float, float]  # x [N], y [N], twist [N·mm]
    concentration_factor: float = 1.0  # true / nominal sugar concentration

    @property
    def push_end_s(self) -> float:
        """End of the lateral push [s]; free sloshing follows."""
        return self.push_start_s + self.push_duration_s


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

    @property
    def t_s(self) -> np.ndarray:
        """Sample times [s]."""
        return self.loads.t_s

    def labels(self) -> dict[str, object]:
        """Label and ground-truth columns (DESIGN.md names)."""
        return {
            "liquid": self.liquid,
            "container": self.container,
            "height_mm": self.height_mm,
            "sugar_concentration": self.sugar_concentration,
            "viscosity_cst": self.viscosity_cst,
            "log10_viscosity_cst": self.log10_viscosity_cst,
            "temperature_c": self.temperature_c,
            "true_decay_rate": self.true_decay_rate,
            "true_angular_frequency": self.true_angular_frequency,
        }

    def slosh_force_n(self) -> np.ndarray:
        """Total lateral (x) force on both gels [N], the simplest 1-D slosh signal."""
        return self.loads.shear_force_n[:, :, 0].sum(axis=1)


def draw_parameters(
    rng: np.random.Generator,
    height_mm: float,
    base_wall_factor: float,
    base_contact_line: float,
    variability: Variability | None = None,
) -> TrialParameters:
    """Draw one trial's random conditions (module docstring: the distributions)."""
    var = Variability() if variability is None else variability
    normal = float(rng.uniform(10.0, 16.0))
    return TrialParameters(
        temperature_c=float(np.clip(rng.normal(21.0, var.temperature_sd_c), 18.0, 25.0)),
        true_height_mm=float(height_mm + rng.normal(0.0, var.fill_error_sd_mm)),
        wall_factor=float(base_wall_factor * math.exp(rng.normal(0.0, var.wall_factor_log_sd))),
        contact_line_damping=float(base_contact_line * rng.uniform(*var.contact_line_range)),
        placement_mm=(float(rng.normal(0.0, 3.0)), float(rng.normal(0.0, 2.0))),
        gel_contact_mm=tuple(tuple(float(v) for v in rng.normal(0.0, 1.0, 2)) for _ in range(2)),
        left_share=float(np.clip(0.5 + rng.normal(0.0, 0.03), 0.4, 0.6)),
        normal_force_n=normal,
        support_stiffness_n_m=float(2500.0 * (normal / 13.0) ** (1.0 / 3.0)),
        push_distance_mm=float(np.clip(rng.normal(15.0, 2.0), 10.0, 20.0)),
        push_duration_s=float(rng.uniform(0.25, 0.35)),
        push_start_s=float(1.0 + rng.uniform(-0.1, 0.1)),
        initial_slosh_mm=float(rng.uniform(0.0, 0.5)),
        initial_phase_rad=float(rng.uniform(0.0, 2.0 * math.pi)),
        vibration_hz=tuple(float(v) for v in rng.uniform(8.0, 30.0, 3)),
        vibration_m_s2=tuple(float(v) for v in rng.uniform(0.01, 0.03, 3)),
        vibration_phase_rad=tuple(float(v) for v in rng.uniform(0.0, 2.0 * math.pi, 3)),
        slip_time_constant_s=float(rng.uniform(2.0, 8.0)),
        slip_drift=(
            float(rng.normal(0.0, 0.005)),
            float(rng.uniform(0.0, 0.03)),
            float(rng.normal(0.0, 0.5)),
        ),
        concentration_factor=float(math.exp(rng.normal(0.0, var.concentration_rel_sd))),
    )


def _min_jerk_acceleration(distance_m: float, start_s: float, duration_s: float):
    """Acceleration [m/s²] of a minimum-jerk move, as a scalar function of time."""
    scale = distance_m / duration_s**2

    def acc(t: float) -> float:
        tau = (t - start_s) / duration_s
        if tau <= 0.0 or tau >= 1.0:
            return 0.0
        return scale * (60.0 * tau - 180.0 * tau * tau + 120.0 * tau * tau * tau)

    return acc


def _twist_nm(system: SloshSystem, state: np.ndarray, params: TrialParameters, depth_m: float):
    """Moment about the gels' common normal (world z) that the container exerts [N·m].

    ``Σ y_i m_i a_i − g Σ m_i x_i`` over the container shell, the rigid liquid and
    the slosh masses, with positions relative to the contact centre.
    """
    acc, rel = accelerations(system, state)
    dx, dy = params.placement_mm[0] * 1e-3, params.placement_mm[1] * 1e-3
    centre_y = depth_m / 2.0 + dy
    sloshing = sum(m.mass_kg for m in system.modes)
    rigid_liquid = system.liquid_mass_kg - sloshing
    twist = system.container_mass_kg * ((depth_m / 2.0 - centre_y) * acc + GRAVITY_M_S2 * dx)
    twist = twist + rigid_liquid * ((system.rigid_height_m - centre_y) * acc + GRAVITY_M_S2 * dx)
    for i, mode in enumerate(system.modes):
        x = state[2 + 2 * i]
        twist = twist + mode.mass_kg * (
            (mode.height_m - centre_y) * (acc + rel[i]) - GRAVITY_M_S2 * (x - dx)
        )
    return twist


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
    :class:`Variability`).
    """
    var = Variability() if variability is None else variability
    box = get_container(container)
    get_liquid(liquid, sugar_concentration=sugar_concentration)  # validate names early
    box.check_height(height_mm)
    if not (math.isfinite(duration_s) and duration_s >= 3.0):
        raise LiquidTouchError(f"duration {duration_s} s is too short; use at least 3 s")
    if not (math.isfinite(sample_rate_hz) and sample_rate_hz >= 60.0):
        raise LiquidTouchError(f"sample rate {sample_rate_hz} Hz is too low; use >= 60 Hz")
    rng = np.random.default_rng(seed)
    params = draw_parameters(rng, height_mm, box.wall_factor, box.contact_line_damping, var)
    if temperature_c is not None:
        params = _replace(params, temperature_c=float(temperature_c))
    true_height = float(np.clip(params.true_height_mm, 0.5, box.depth_mm - 0.5))
    true_conc = sugar_concentration
    if liquid == "sugar-water" and sugar_concentration:
        true_conc = min(sugar_concentration * params.concentration_factor, MAX_SUGAR_CONCENTRATION)
    props = get_liquid(liquid, sugar_concentration=true_conc, temperature_c=params.temperature_c)
    system = slosh_system(
        props,
        box,
        true_height,
        wall_factor=params.wall_factor,
        contact_line_damping=params.contact_line_damping,
        support_stiffness_n_m=params.support_stiffness_n_m,
    )
    true_lambda, true_omega = system.slow_mode()

    n = round(duration_s * sample_rate_hz) + 1
    t = np.arange(n) / sample_rate_hz
    push = _min_jerk_acceleration(
        params.push_distance_mm * 1e-3, params.push_start_s, params.push_duration_s
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
    tau = np.clip((t - params.push_start_s) / params.push_duration_s, 0.0, 1.0)
    push_acc = params.push_distance_mm * 1e-3 / params.push_duration_s**2
    hand_acc = push_acc * (60.0 * tau - 180.0 * tau**2 + 120.0 * tau**3) + vib_hand

    loads, wrench = _loads_and_wrench(system, state, t, hand_acc, params, box.depth_mm, rng, var)
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
        viscosity_cst=props.viscosity_cst,
        log10_viscosity_cst=props.log10_viscosity_cst,
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
    )


def _replace(params: TrialParameters, **changes: object) -> TrialParameters:
    values = asdict(params)
    values.update(changes)
    return TrialParameters(**values)


def _drift(t: np.ndarray, start_s: float, tau_s: float) -> np.ndarray:
    rel = np.clip(t - start_s, 0.0, None)
    return 1.0 - np.exp(-rel / tau_s)


def _loads_and_wrench(
    system: SloshSystem,
    state: np.ndarray,
    t: np.ndarray,
    hand_acc: np.ndarray,
    params: TrialParameters,
    depth_mm: float,
    rng: np.random.Generator,
    var: Variability,
) -> tuple[FingerLoads, np.ndarray]:
    n = t.size
    force_x = system.support_stiffness_n_m * state[0] + system.support_damping_n_s_m * state[1]
    weight = system.total_mass_kg * GRAVITY_M_S2
    twist = _twist_nm(system, state, params, depth_mm * 1e-3) * 1e3  # N·mm
    drift = _drift(t, params.push_start_s + params.push_duration_s, params.slip_time_constant_s)
    dx, dy, dtw = params.slip_drift
    total_x = force_x + dx * drift
    total_y = -weight - dy * drift
    total_twist = twist + dtw * drift

    share = np.array([params.left_share, 1.0 - params.left_share])
    shear = np.empty((n, 2, 2))
    shear[:, :, 0] = total_x[:, None] * share[None, :]
    shear[:, :, 1] = total_y[:, None] * share[None, :]
    shear += rng.normal(0.0, 1.0, shear.shape) * var.contact_noise_n
    # left gel on the -z side: its normal-aligned twist is +τz, the right gel's −τz
    moment = total_twist[:, None] * (share * np.array([1.0, -1.0]))[None, :]
    moment += rng.normal(0.0, 1.0, moment.shape) * var.contact_noise_nmm
    loads = FingerLoads(
        t_s=t,
        shear_force_n=shear,
        twist_moment_nmm=moment,
        normal_force_n=np.full(2, params.normal_force_n),
        contact_center_mm=np.array(params.gel_contact_mm),
    )

    # wrist sensor: gel loads + gripper inertia and weight, UR5e-class noise
    grip_x = total_x - GRIPPER_MASS_KG * hand_acc
    grip_y = total_y - GRIPPER_MASS_KG * GRAVITY_M_S2
    tz = total_twist * 1e-3 + WRIST_TO_CONTACT_M * grip_x
    wrench = np.column_stack([grip_x, grip_y, np.zeros(n), np.zeros(n), np.zeros(n), tz])
    rate_hz = 1.0 / (t[1] - t[0])
    bias = np.cumsum(rng.normal(0.0, 1.0, (n, 6)), axis=0) / math.sqrt(rate_hz)  # per √s
    f_sd, t_sd = var.wrist_force_noise_n, var.wrist_torque_noise_nm
    wrench += bias * np.array([f_sd, f_sd, f_sd, t_sd, t_sd, t_sd]) / 24.0
    wrench += rng.normal(0.0, 1.0, (n, 6)) * np.array([f_sd, f_sd, f_sd, t_sd, t_sd, t_sd])
    return loads, wrench
