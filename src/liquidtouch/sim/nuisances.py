"""What each bench nuisance of :class:`~liquidtouch.sim.realism.Realism` does to a trial.

The strengths and their sources are in :mod:`liquidtouch.sim.realism`; this module
applies them, each from its own random stream (``Realism.rng(seed, name)``) and
only when it is switched on, so a clean world never reaches any of this code.

- :func:`perturb_parameters`: the physical nuisances, on the drawn
  :class:`~liquidtouch.sim.variability.TrialParameters` (fill, concentration,
  temperature, grip force, finger imbalance, wall compliance, push, arm modes);
- :func:`finger_slips`, :func:`unequal_grip`: the grasp, on the finger loads;
- :func:`gel_response`: the gel's creep and hysteresis, on the loads the markers see;
- :func:`camera_times`: frame rate, drops, stalls and timestamp jitter;
- :func:`brightness_gains`, :func:`marker_ink`: auto-exposure drift and marker wear
  for the renderer.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np

from liquidtouch.sim.encode import PTS_RATE_HZ
from liquidtouch.sim.loads import FingerLoads
from liquidtouch.sim.realism import Realism
from liquidtouch.sim.sensors import SensorProfile
from liquidtouch.sim.variability import TrialParameters

__all__ = [
    "brightness_gains",
    "camera_times",
    "finger_slips",
    "gel_response",
    "marker_ink",
    "perturb_parameters",
    "unequal_grip",
]

SUPPORT_STIFFNESS_REF_N_M = 2500.0
"""Lateral support stiffness at the reference grip force (``sim/variability.py``)."""
GRIP_FORCE_REF_N = 13.0
HYSTERESIS_HZ = 2.5
"""Centre of the gel's loss peak [Hz] (the slosh band)."""


def perturb_parameters(
    params: TrialParameters, realism: Realism, seed: int, *, container_depth_mm: float
) -> tuple[TrialParameters, dict[str, Any]]:
    """The trial's conditions with the physical nuisances applied, and what was drawn.

    Returns the new parameters and a dict of the drawn values worth recording
    (``meta.json``: ``realism.drawn``), e.g. ``liquid_temperature_c``.
    """
    drawn: dict[str, Any] = {}
    new: dict[str, Any] = {}
    if realism.active("fill_error"):
        err = float(realism.rng(seed, "fill_error").normal(0.0, realism.fill_error_mm))
        new["true_height_mm"] = float(
            np.clip(params.true_height_mm + err, 0.5, container_depth_mm - 0.5)
        )
        drawn["fill_error_mm"] = err
    if realism.active("concentration_error"):
        g = realism.rng(seed, "concentration_error")
        factor = math.exp(g.normal(0.0, realism.concentration_error_rel))
        new["concentration_factor"] = params.concentration_factor * factor
        drawn["concentration_factor"] = factor
    if realism.active("temperature"):
        g = realism.rng(seed, "temperature")
        offset = float(g.uniform(-realism.temperature_offset_c, realism.temperature_offset_c))
        drawn["temperature_offset_c"] = offset
        drawn["liquid_temperature_c"] = float(np.clip(params.temperature_c + offset, 0.0, 60.0))
    force = params.normal_force_n
    if realism.active("grip_force"):
        g = realism.rng(seed, "grip_force")
        force = float(force * math.exp(g.normal(0.0, realism.grip_force_rel_sd)))
        force = float(np.clip(force, 2.0, 40.0))
        new["normal_force_n"] = force
        drawn["grip_force_n"] = force
    stiffness = params.support_stiffness_n_m
    if "normal_force_n" in new:
        stiffness = SUPPORT_STIFFNESS_REF_N_M * (force / GRIP_FORCE_REF_N) ** (1.0 / 3.0)
    if realism.active("wall_compliance"):
        g = realism.rng(seed, "wall_compliance")
        compliance = realism.wall_compliance_m_per_n * math.exp(g.normal(0.0, 0.2))
        stiffness = 1.0 / (1.0 / stiffness + compliance)
        drawn["wall_compliance_m_per_n"] = compliance
    if stiffness != params.support_stiffness_n_m:
        new["support_stiffness_n_m"] = float(stiffness)
    if realism.active("finger_imbalance"):
        g = realism.rng(seed, "finger_imbalance")
        share = params.left_share + g.normal(0.0, realism.finger_imbalance)
        new["left_share"] = float(np.clip(share, 0.2, 0.8))
        drawn["grip_ratio_left_right"] = float(math.exp(g.normal(0.0, realism.finger_imbalance)))
    if realism.active("push_variation"):
        g = realism.rng(seed, "push_variation")
        d, t = np.exp(g.normal(0.0, realism.push_variation_rel, 2))
        new["push_distance_mm"] = float(np.clip(params.push_distance_mm * d, 4.0, 30.0))
        new["push_duration_s"] = float(np.clip(params.push_duration_s * t, 0.12, 0.7))
    if realism.active("arm_vibration"):
        g = realism.rng(seed, "arm_vibration")
        hz = g.uniform(10.0, 30.0, 2)
        amp = realism.arm_vibration_m_s2 * g.uniform(0.5, 1.5, 2)
        phase = g.uniform(0.0, 2.0 * math.pi, 2)
        new["vibration_hz"] = (*params.vibration_hz, *map(float, hz))
        new["vibration_m_s2"] = (*params.vibration_m_s2, *map(float, amp))
        new["vibration_phase_rad"] = (*params.vibration_phase_rad, *map(float, phase))
    return (replace(params, **new) if new else params), drawn


def _smooth_step(t_s: np.ndarray, at_s: float, width_s: float) -> np.ndarray:
    """0 before ``at_s``, 1 after ``at_s + width_s``, a raised cosine between."""
    x = np.clip((t_s - at_s) / width_s, 0.0, 1.0)
    return 0.5 - 0.5 * np.cos(np.pi * x)


def finger_slips(
    loads: FingerLoads, push_end_s: float, realism: Realism, seed: int
) -> tuple[FingerLoads, list[dict[str, float]]]:
    """Stick-slip of one finger during the hold: load steps moved between the fingers.

    Events are Poisson (``slip_rate_hz``) from 0.5 s after the push to the end;
    each moves N(0, ``slip_step_n``) of vertical shear from one finger to the
    other and changes the slipping finger's lateral shear by N(0, step/2), over 30 ms.
    """
    g = realism.rng(seed, "finger_slip")
    t = loads.t_s
    start, end = push_end_s + 0.5, float(t[-1])
    n = int(g.poisson(realism.slip_rate_hz * max(end - start, 0.0)))
    shear = loads.shear_force_n.copy()
    events = []
    for _ in range(n):
        at = float(g.uniform(start, end))
        finger = int(g.integers(0, 2))
        dy, dx = g.normal(0.0, realism.slip_step_n), g.normal(0.0, realism.slip_step_n / 2)
        step = _smooth_step(t, at, 0.03)
        shear[:, finger, 1] += dy * step
        shear[:, 1 - finger, 1] -= dy * step
        shear[:, finger, 0] += dx * step
        events.append({"t_s": at, "finger": finger, "dy_n": float(dy), "dx_n": float(dx)})
    return replace(loads, shear_force_n=shear), events


def unequal_grip(loads: FingerLoads, ratio: float) -> FingerLoads:
    """The two fingers' grip forces differing by ``ratio`` (left/right), same total."""
    total = float(np.sum(loads.normal_force_n))
    left = total * ratio / (1.0 + ratio)
    return replace(loads, normal_force_n=np.array([left, total - left]))


def _relaxation(x: np.ndarray, dt_s: float, time_constant_s: float) -> np.ndarray:
    """First-order low-pass of the columns of ``x`` starting at rest at ``x[0]`` (exact)."""
    a = math.exp(-dt_s / time_constant_s)
    b = 1.0 - a
    y = np.empty_like(x, dtype=float)
    state = a * x[0]  # steady state at the first sample
    for i, row in enumerate(x):  # y[i] = b·x[i] + a·y[i−1], as scipy's lfilter (no SciPy import)
        y[i] = b * row + state
        state = a * y[i]
    return y


def gel_response(loads: FingerLoads, realism: Realism) -> FingerLoads:
    """The loads as the markers respond to them: gel creep and hysteresis (linear).

    The gel is a standard linear solid per branch: displacement ∝ F + Σ β·LP_τ(F),
    with creep (β = ``gel_creep_fraction``, τ = ``gel_creep_time_s``) and a
    hysteresis branch at :data:`HYSTERESIS_HZ` whose loss tangent peaks at
    ``gel_hysteresis_tan_delta`` (β = 2 tan δ, τ = 1/(2π f)). Compliances are
    renormalised so that the instantaneous response is unchanged.
    """
    t = loads.t_s
    dt = float(t[1] - t[0])
    n = len(t)
    x = np.column_stack([loads.shear_force_n.reshape(n, 4), loads.twist_moment_nmm])
    y = x.copy()
    if realism.gel_creep_fraction > 0:
        y += realism.gel_creep_fraction * _relaxation(x, dt, realism.gel_creep_time_s)
    if realism.gel_hysteresis_tan_delta > 0:
        tau = 1.0 / (2.0 * math.pi * HYSTERESIS_HZ)
        y += 2.0 * realism.gel_hysteresis_tan_delta * _relaxation(x, dt, tau)
    return replace(loads, shear_force_n=y[:, :4].reshape(n, 2, 2), twist_moment_nmm=y[:, 4:].copy())


def camera_times(
    duration_s: float, profile: SensorProfile, realism: Realism, seed: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
    """Recorded times [s], exposure times [s] and frame indices of a real-camera recording.

    The achieved rate is ``profile.fps × rate_factor × U(1 − frame_rate_loss, 1)``;
    exposures keep the profile's clock jitter and independent drops, plus drop
    bursts and stalls; the recorded (host) timestamps add N(0,
    ``timestamp_jitter_s``), kept increasing. Recorded times are on the video
    time base (1/90000 s). Also returns the drawn values (``fps``, ``stalls``).
    """
    g_rate = realism.rng(seed, "frame_rate")
    factor = 1.0 - float(g_rate.uniform(0.0, realism.frame_rate_loss))
    fps = profile.fps * profile.rate_factor * factor
    period = 1.0 / fps
    n = int(np.floor(duration_s / period + 1e-9)) + 1
    index = np.arange(n)
    t = index * period
    if profile.jitter_std_s > 0:
        noise = g_rate.normal(0.0, profile.jitter_std_s, n)
        noise[0] = 0.0
        t = np.clip(t + np.clip(noise, -0.3 * period, 0.3 * period), 0.0, duration_s)
    keep = g_rate.random(n) >= profile.drop_probability
    if realism.burst_drop_probability > 0:
        g = realism.rng(seed, "frame_drops")
        starts = np.flatnonzero(g.random(n) < realism.burst_drop_probability)
        lengths = g.geometric(0.5, len(starts))
        for s, length in zip(starts, lengths, strict=True):
            keep[s : s + length] = False
    stalls = []
    if realism.stall_rate_hz > 0:
        g = realism.rng(seed, "stalls")
        for _ in range(int(g.poisson(realism.stall_rate_hz * duration_s))):
            at, length = float(g.uniform(0.0, duration_s)), float(g.uniform(0.2, 0.6))
            keep &= ~((t >= at) & (t < at + length))
            stalls.append([at, length])
    keep[0] = True
    t, index = t[keep], index[keep]
    recorded = t
    if realism.timestamp_jitter_s > 0:
        g = realism.rng(seed, "timestamp_jitter")
        lag = np.clip(g.normal(0.0, realism.timestamp_jitter_s, len(t)), -0.4 * period, None)
        lag = np.minimum(lag, 0.4 * period)
        recorded = np.clip(t + lag, 0.0, None)
    recorded = np.round(recorded * PTS_RATE_HZ) / PTS_RATE_HZ
    order = np.concatenate([[True], np.diff(recorded) > 0])
    while not order.all():  # a rare inversion: drop the later frame
        recorded, t, index = recorded[order], t[order], index[order]
        order = np.concatenate([[True], np.diff(recorded) > 0])
    return recorded, t, index, {"fps": fps, "stalls": stalls, "n_frames": len(t)}


def brightness_gains(times_s: np.ndarray, realism: Realism, seed: int, sensor: int) -> np.ndarray:
    """Per-frame brightness gain from LED and auto-exposure drift (1 = none).

    A linear ramp of N(0, ``exposure_drift``) over the recording plus one
    auto-exposure step of N(0, drift/2) at a random time, settling with 0.3 s.
    """
    g = np.random.default_rng([seed, 0xBEEF, 100 + sensor])
    span = max(float(times_s[-1] - times_s[0]), 1e-9)
    ramp = g.normal(0.0, realism.exposure_drift) * (times_s - times_s[0]) / span
    at = g.uniform(times_s[0], times_s[-1])
    step = g.normal(0.0, realism.exposure_drift / 2)
    settle = np.where(times_s >= at, 1.0 - np.exp(-(times_s - at) / 0.3), 0.0)
    return 1.0 + ramp + step * settle


def marker_ink(n_markers: int, realism: Realism, seed: int, sensor: int) -> np.ndarray:
    """Per-marker ink scale (1 intact, 0.4-0.7 faint, 0 missing) of a worn gel."""
    g = np.random.default_rng([seed, 0xBEEF, 200 + sensor])
    u = g.random(n_markers)
    ink = np.ones(n_markers)
    missing = u < realism.marker_missing_fraction
    faint = ~missing & (u < realism.marker_missing_fraction + realism.marker_faint_fraction)
    ink[missing] = 0.0
    ink[faint] = g.uniform(0.4, 0.7, int(faint.sum()))
    return ink
