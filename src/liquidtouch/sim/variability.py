"""Trial-to-trial variation: the random conditions of one simulated trial.

All drawn from ``numpy.random.default_rng(seed)``; the distributions are
choices meant to match a careful lab, not measured:

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
- contact noise on the gel loads: white, 1.5 mN and 0.05 N·mm per sample at 240 Hz;
- wrist force-torque noise: 1.2 N and 0.06 N·m per sample (:mod:`liquidtouch.sim.grasp`).

Calibration: the spreads above were set once, by running the paper's method on
the simulator's force signal (``benchmarks/sim/sim_calibration.py``: 3 Hz low-pass,
30 fps, ``fit_oscillation``, GPR with RBF + white noise on standardised λ, ω,
full ``sugar`` preset) and widening the physically motivated spreads (fill,
wetting, temperature, weighing) — never the estimator — until the force-level
test errors were ~55-65 % of the paper's GPR errors (0.56 mm, 15.3 g/100 g water, 0.16 in
log10 cSt), leaving room for the GelSight stage (marker noise, tracking),
which adds its own error on top. Result: 0.36 mm, 8.2 g/100 g, 0.088 (quadratic
model: 0.42, 8.9, 0.097).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Variability:
    """Spread of the calibrated trial-to-trial variations and noise (defaults: see module doc).

    Pass ``Variability(...)`` to :func:`~liquidtouch.sim.trial.simulate_trial` to
    study or re-calibrate them; ``Variability.none()`` gives the clean physics (no
    label noise, no contact or wrist noise; the push and grasp still vary with the seed).
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
    """The random conditions of one trial (module docstring: the distributions)."""

    temperature_c: float
    true_height_mm: float
    wall_factor: float
    contact_line_damping: float  # [1/s]
    placement_mm: tuple[float, float]  # contact centre on the container (x, y)
    gel_contact_mm: tuple[tuple[float, float], tuple[float, float]]  # per finger (x, y)
    left_share: float  # fraction of the loads on the left finger
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


def draw_parameters(
    rng: np.random.Generator,
    height_mm: float,
    base_wall_factor: float,
    base_contact_line: float,
    variability: Variability | None = None,
) -> TrialParameters:
    """Draw one trial's random conditions (module docstring: the distributions).

    ``height_mm`` is the nominal fill height [mm]; ``base_wall_factor`` and
    ``base_contact_line`` [1/s] are the container's catalogue values.
    """
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
