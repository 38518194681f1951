"""What the container exerts on the grasp: the gel loads on each finger and the wrist signal.

Net loads (world frame, at the contact centre): the lateral force is the grasp
support's spring-damper force, the vertical one the weight of container and
liquid, and the twist the moment about the gels' common normal,
``Σ y_i m_i a_i − g Σ m_i x_i`` over the container shell, the rigid liquid and
the slosh masses (positions relative to the contact centre). The grasp's slip
drift (:func:`liquidtouch.sim.activation.slip_profile`) is added after the
push. The left finger carries ``left_share`` of the loads, the right the rest,
each with white contact noise.

The wrist force-torque signal is that of a UR5e-class built-in sensor (data
sheet: force precision 3.5 N, torque 0.2 N·m): white noise σ = 1.2 N and
0.06 N·m per sample plus a random-walk bias (0.05 N/√s, 2.5 mN·m/√s), on top of
the gel loads and the gripper's (0.9 kg) inertia and weight.
"""

from __future__ import annotations

import math

import numpy as np

from liquidtouch.sim.activation import slip_profile
from liquidtouch.sim.loads import FingerLoads
from liquidtouch.sim.slosh import GRAVITY_M_S2, SloshSystem, accelerations
from liquidtouch.sim.variability import TrialParameters, Variability

GRIPPER_MASS_KG = 0.9
WRIST_TO_CONTACT_M = 0.15


def twist_moment_nm(
    system: SloshSystem, state: np.ndarray, params: TrialParameters, depth_m: float
) -> np.ndarray:
    """Moment about the gels' common normal (world z) that the container exerts [N·m].

    ``state`` is the dynamics' state ``(n_states, n)``; ``depth_m`` the container's
    inner height [m] (module docstring: the formula).
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


def net_loads(
    system: SloshSystem,
    state: np.ndarray,
    t_s: np.ndarray,
    params: TrialParameters,
    depth_mm: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Net lateral (x) and vertical (y) force [N] and twist [N·mm] on the grasp, with slip."""
    force_x = system.support_stiffness_n_m * state[0] + system.support_damping_n_s_m * state[1]
    weight = system.total_mass_kg * GRAVITY_M_S2
    twist = twist_moment_nm(system, state, params, depth_mm * 1e-3) * 1e3  # N·mm
    drift = slip_profile(t_s, params.push_end_s, params.slip_time_constant_s)
    dx, dy, dtw = params.slip_drift
    return force_x + dx * drift, -weight - dy * drift, twist + dtw * drift


def finger_loads(
    t_s: np.ndarray,
    net: tuple[np.ndarray, np.ndarray, np.ndarray],
    params: TrialParameters,
    rng: np.random.Generator,
    variability: Variability,
) -> FingerLoads:
    """Split the :func:`net_loads` ``net`` over the two gels and add contact noise."""
    total_x, total_y, total_twist = net
    n = t_s.size
    share = np.array([params.left_share, 1.0 - params.left_share])
    shear = np.empty((n, 2, 2))
    shear[:, :, 0] = total_x[:, None] * share[None, :]
    shear[:, :, 1] = total_y[:, None] * share[None, :]
    shear += rng.normal(0.0, 1.0, shear.shape) * variability.contact_noise_n
    # left gel on the -z side: its normal-aligned twist is +τz, the right gel's −τz
    moment = total_twist[:, None] * (share * np.array([1.0, -1.0]))[None, :]
    moment += rng.normal(0.0, 1.0, moment.shape) * variability.contact_noise_nmm
    return FingerLoads(
        t_s=t_s,
        shear_force_n=shear,
        twist_moment_nmm=moment,
        normal_force_n=np.full(2, params.normal_force_n),
        contact_center_mm=np.array(params.gel_contact_mm),
    )


def wrist_wrench(
    t_s: np.ndarray,
    net: tuple[np.ndarray, np.ndarray, np.ndarray],
    hand_acc_m_s2: np.ndarray,
    rng: np.random.Generator,
    variability: Variability,
) -> np.ndarray:
    """The wrist F/T signal ``(n, 6)``: fx, fy, fz [N], tx, ty, tz [N·m], world-aligned.

    The :func:`net_loads` ``net`` plus the gripper's inertia (hand acceleration
    ``hand_acc_m_s2``) and weight, with the sensor's noise and bias drift.
    """
    total_x, total_y, total_twist = net
    n = t_s.size
    grip_x = total_x - GRIPPER_MASS_KG * hand_acc_m_s2
    grip_y = total_y - GRIPPER_MASS_KG * GRAVITY_M_S2
    tz = total_twist * 1e-3 + WRIST_TO_CONTACT_M * grip_x
    wrench = np.column_stack([grip_x, grip_y, np.zeros(n), np.zeros(n), np.zeros(n), tz])
    rate_hz = 1.0 / (t_s[1] - t_s[0])
    bias = np.cumsum(rng.normal(0.0, 1.0, (n, 6)), axis=0) / math.sqrt(rate_hz)  # per √s
    f_sd, t_sd = variability.wrist_force_noise_n, variability.wrist_torque_noise_nm
    sd = np.array([f_sd, f_sd, f_sd, t_sd, t_sd, t_sd])
    wrench += bias * sd / 24.0
    wrench += rng.normal(0.0, 1.0, (n, 6)) * sd
    return wrench
