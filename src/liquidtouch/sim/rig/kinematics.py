"""The rig's motions in time: trapezoidal arm moves and linear finger moves.

Part of the simulated rig (:mod:`liquidtouch.sim.rig.rig`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass


def ramp_distance(t_s: float, distance: float, speed: float, accel: float) -> float:
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
class ArmMotion:
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
            fraction = ramp_distance(now - self.t0, self.distance, self.speed, self.accel)
            fraction /= self.distance
        return [a + fraction * (b - a) for a, b in zip(self.start, self.target, strict=True)]


@dataclass
class FingerMotion:
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
