"""The nuisances of a real bench that the clean simulator leaves out: :class:`Realism`.

``Realism.clean()`` (every nuisance off) is the simulator as it always was, bit for
bit: the nuisances draw their randomness from their own streams
(``numpy.random.default_rng([seed, 0xBEEF, k])``, one ``k`` per nuisance), so the
clean draws are untouched and a trial with one nuisance switched on differs from
the clean trial of the same seed by that nuisance alone. ``Realism.lab()`` switches
all of them on at the default strengths below; :meth:`Realism.only` and
:meth:`Realism.scaled` build the single-nuisance worlds of ``benchmarks/sim/nuisances.py``.

The clean simulator already varies what a careful lab varies
(:mod:`liquidtouch.sim.variability`: lab temperature N(21, 1.5) °C, fill error
0.4 mm, sugar weighing 2 %, contact placement, grip force U(10, 16) N, push
spread, three weak arm modes, smooth slip, frame-clock jitter 1.5 ms and 1 %
drops); the lab nuisances come **on top of** those. Each default is taken from
the source given, not tuned to any result; those marked *(choice)* have no
measurement behind them and are a plausible magnitude stated as such.

Camera (GelSight Mini over USB/UVC)
    ``frame_rate_loss`` 0.4 — the achieved frame rate is drawn per trial from
    U(1 − loss, 1) × nominal, i.e. 15–25 fps for the Mini's nominal 25: users
    report 15 fps and "18 fps at most" on Ubuntu (V4L2) against 25 on Windows
    (gelsightinc/gsrobotics issue #6), and "sometimes 10, sometimes 18" when
    saving (issue #24).
    ``timestamp_jitter_s`` 0.004 s — the recorded time of a frame is its host
    arrival time, not its exposure: N(0, 4 ms) between the two *(choice: USB
    video-class transfer and OS scheduling latencies of a few ms)*.
    ``burst_drop_probability`` 0.03 — extra dropped frames, in bursts (burst
    length geometric, mean 2), on top of the profile's independent 1 %
    (issue #24: irregular rates).
    ``stall_rate_hz`` 0.03 with stalls of U(0.2, 0.6) s — the stream stops
    now and then (USB bandwidth contention, a busy host) *(choice)*.
    ``exposure_drift`` 0.03 — auto-exposure and LED output drift: a linear
    brightness ramp of N(0, 3 %) over the trial plus one auto-exposure step of
    N(0, 1.5 %) settling in 0.3 s *(choice: LED flux falls ~0.3 %/°C of junction
    warming, a few % after switch-on; UVC cameras ship with auto-exposure on)*.
    ``pixel_noise_rgb`` (1.32, 1.06, 1.69) grey levels, ``pixel_noise_corr_px``
    0.9 px — measured on the still key frames (frames 0–48, every 12th) of the
    real GelSight Mini recording ``gelsight_mini_press.avi``
    (``docs/real_data.md``): per-channel temporal std (R, G, B) 1.32, 1.06,
    1.69, neighbour-pixel correlation 0.59–0.72 at 1 px and 0.30–0.47 at 2 px
    (demosaicing), modelled as white noise blurred by a Gaussian of 0.9 px
    (correlation 0.73 / 0.29 at 1 / 2 px) and rescaled to those stds. The clean
    ``mini`` profile has white noise of 1.0 per channel.

Gel
    ``gel_creep_fraction`` 0.10, ``gel_creep_time_s`` 2.0 s — viscoelastic
    creep of the silicone: a delayed compliance of 10 % of the instantaneous one
    with a 2 s time constant (a standard linear solid), so the markers keep
    creeping after the push *(choice within the 5–20 % creep over seconds
    reported for soft silicone elastomers; uncertain)*.
    ``gel_hysteresis_tan_delta`` 0.07 — the gel's loss tangent near the slosh
    band (hysteresis of the load-displacement loop), a second relaxation branch
    at 2.5 Hz with peak loss tangent 0.07 *(PDMS/silicone gels: tan δ ~0.05–0.1
    at 1–10 Hz; uncertain)*.
    ``marker_missing_fraction`` 0.03, ``marker_faint_fraction`` 0.10 — worn
    gels lose markers (ink rubbed off) and others fade to 40–70 % of their ink
    *(choice: after some thousands of contacts)*.

Grasp
    ``slip_rate_hz`` 0.05, ``slip_step_n`` 0.01 N — stick-slip of one finger
    during the hold: Poisson events (≈0.5 per 13 s trial), each moving N(0, 10
    mN) of the vertical load from one finger to the other and N(0, 5 mN) of
    lateral shear, over 30 ms *(choice)*.
    ``finger_imbalance`` 0.08 — unequal contact of the two fingers: the left
    finger's load share gets an extra N(0, 0.08) (clipped 0.2–0.8) and the two
    grip forces differ by a factor exp(N(0, 0.08)) *(choice: parallel-jaw
    fingers misaligned by a fraction of a mm on a stiff bottle)*.
    ``grip_force_rel_sd`` 0.15 — grip force × exp(N(0, 0.15)) between trials
    (support stiffness ∝ force^(1/3), contact radius likewise) *(choice: a
    position-controlled or current-limited gripper on a compliant gel)*.

Bottle and liquid
    ``wall_compliance_m_per_n`` 1.7e-4 m/N — the container wall flexes under
    the grip: a series spring of 6 kN/m (× exp(N(0, 0.2)) per trial) in the
    lateral support *(choice: a thin-walled plastic container)*.
    ``temperature_offset_c`` 3.0 °C — the liquid's temperature during the trial
    differs from the one its viscosity label was measured at by U(−3, +3) °C;
    the physics uses the trial's temperature (ν changes by the catalogue's
    slope: −2.4 %/°C for water to −5 %/°C at 60 % sucrose, oils ~−4 %/°C,
    :mod:`liquidtouch._core.liquids`), the labels stay the measured ones.
    ``fill_error_mm`` 0.7 mm — fill height read by eye from a ruler: ±0.5 mm
    reading resolution and a wall meniscus of 1–2 mm (capillary length of
    water 2.7 mm); true height = label + N(0, 0.7) mm on top of the clean 0.4.
    ``concentration_error_rel`` 0.03 — sugar weighed on a kitchen scale (±1 g
    in 100–200 g batches, ~1 %) and water evaporating from open containers over
    a session (1–2 %) *(choice)*: true concentration × exp(N(0, 0.03)).

Arm
    ``push_variation_rel`` 0.10 — push distance and duration × exp(N(0, 0.10))
    each (a re-programmed or differently tuned push between sessions, speed
    scaling on the teach pendant) *(choice)*.
    ``arm_vibration_m_s2`` 0.05 m/s² — two more structural modes at U(10, 30) Hz
    with amplitude U(0.5, 1.5) × 0.05 m/s² during the whole trial (collaborative
    arms have structural modes at ~5–40 Hz: Vibration 2022 5(3):585 (FEA 4.4–41.6
    Hz), Sensors 2023 23(3):1629 (wrist vibration of a six-axis cobot); the
    amplitude is a choice).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields, replace
from typing import Any

import numpy as np

from liquidtouch.errors import LiquidTouchError

__all__ = ["NUISANCES", "REALISM_WORLDS", "Realism", "get_realism"]

REALISM_WORLDS = ("clean", "lab")
STREAM_TAG = 0xBEEF
"""Second word of every nuisance's random stream: ``default_rng([seed, STREAM_TAG, k])``."""

NUISANCES: dict[str, tuple[str, ...]] = {
    # name -> the Realism fields it sets (scaled together by Realism.scaled)
    "frame_rate": ("frame_rate_loss",),
    "timestamp_jitter": ("timestamp_jitter_s",),
    "frame_drops": ("burst_drop_probability",),
    "stalls": ("stall_rate_hz",),
    "exposure_drift": ("exposure_drift",),
    "pixel_noise": ("pixel_noise_rgb",),
    "gel_creep": ("gel_creep_fraction",),
    "gel_hysteresis": ("gel_hysteresis_tan_delta",),
    "marker_wear": ("marker_missing_fraction", "marker_faint_fraction"),
    "finger_slip": ("slip_rate_hz",),
    "finger_imbalance": ("finger_imbalance",),
    "grip_force": ("grip_force_rel_sd",),
    "wall_compliance": ("wall_compliance_m_per_n",),
    "temperature": ("temperature_offset_c",),
    "fill_error": ("fill_error_mm",),
    "concentration_error": ("concentration_error_rel",),
    "push_variation": ("push_variation_rel",),
    "arm_vibration": ("arm_vibration_m_s2",),
}
"""Each nuisance of :class:`Realism` and the fields that make it (module doc: sources)."""

CAMERA_NUISANCES = ("frame_rate", "timestamp_jitter", "frame_drops", "stalls")


@dataclass(frozen=True)
class Realism:
    """The strengths of the bench's nuisances; 0 switches one off (module doc: sources).

    ``world`` names the setting (``"clean"``, ``"lab"``, or a derived name such as
    ``"lab:gel_creep×2"``); it is recorded in ``meta.json`` with every field.
    """

    world: str = "lab"
    # camera
    frame_rate_loss: float = 0.4  # achieved rate ~ U(1 − loss, 1) × nominal
    timestamp_jitter_s: float = 0.004  # [s] recorded − exposure time, sd
    burst_drop_probability: float = 0.03  # probability a drop burst starts at a frame
    stall_rate_hz: float = 0.03  # [1/s] stream stalls, each U(0.2, 0.6) s
    exposure_drift: float = 0.03  # relative brightness ramp sd over a trial
    pixel_noise_rgb: tuple[float, float, float] = (1.32, 1.06, 1.69)  # [grey levels]
    pixel_noise_corr_px: float = 0.9  # [px] Gaussian blur of the noise (demosaicing)
    # gel
    gel_creep_fraction: float = 0.10  # delayed / instantaneous compliance
    gel_creep_time_s: float = 2.0  # [s]
    gel_hysteresis_tan_delta: float = 0.07  # peak loss tangent at 2.5 Hz
    marker_missing_fraction: float = 0.03
    marker_faint_fraction: float = 0.10
    # grasp
    slip_rate_hz: float = 0.05  # [1/s] slip events during the hold
    slip_step_n: float = 0.01  # [N] sd of the load moved per slip
    finger_imbalance: float = 0.08  # sd of the extra left share; log-sd of the force ratio
    grip_force_rel_sd: float = 0.15  # log-sd of the grip force between trials
    # bottle and liquid
    wall_compliance_m_per_n: float = 1.0 / 6000.0  # [m/N] series compliance of the wall
    temperature_offset_c: float = 3.0  # [°C] half-range of trial − label temperature
    fill_error_mm: float = 0.7  # [mm] sd of the fill-height reading
    concentration_error_rel: float = 0.03  # log-sd of true / labelled concentration
    # arm
    push_variation_rel: float = 0.10  # log-sd of push distance and duration
    arm_vibration_m_s2: float = 0.05  # [m/s²] amplitude scale of two extra modes

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name == "world":
                if not isinstance(value, str) or not value:
                    raise LiquidTouchError("Realism.world must be a non-empty name")
                continue
            values = value if isinstance(value, tuple) else (value,)
            for v in values:
                if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                    raise LiquidTouchError(f"Realism.{f.name} must be a finite number, got {v!r}")
                if v < 0:
                    raise LiquidTouchError(f"Realism.{f.name} must not be negative, got {v!r}")
        if self.frame_rate_loss >= 1.0:
            raise LiquidTouchError(
                f"Realism.frame_rate_loss {self.frame_rate_loss:g} leaves no frames; use 0-0.9"
            )
        if self.marker_missing_fraction + self.marker_faint_fraction > 1.0:
            raise LiquidTouchError("Realism: missing + faint marker fractions exceed 1")
        if self.gel_creep_time_s <= 0 or self.pixel_noise_corr_px < 0:
            raise LiquidTouchError("Realism.gel_creep_time_s must be positive")

    @classmethod
    def clean(cls) -> Realism:
        """Every nuisance off: the simulator as before, bit for bit."""
        off = {name: _zero(getattr(cls, name)) for f in NUISANCES.values() for name in f}
        return cls(world="clean", **off)

    @classmethod
    def lab(cls) -> Realism:
        """Every nuisance at its default (cited) strength."""
        return cls(world="lab")

    @classmethod
    def only(cls, name: str, factor: float = 1.0) -> Realism:
        """The clean world with nuisance ``name`` alone, at ``factor`` × its default."""
        fields_of = _nuisance_fields(name)
        lab = cls.lab()
        values = {f: _scale(getattr(lab, f), factor) for f in fields_of}
        suffix = "" if factor == 1 else f"×{factor:g}"
        return replace(cls.clean(), world=f"only:{name}{suffix}", **values)

    def scaled(self, name: str, factor: float) -> Realism:
        """This world with nuisance ``name`` at ``factor`` × its strength here."""
        values = {f: _scale(getattr(self, f), factor) for f in _nuisance_fields(name)}
        return replace(self, world=f"{self.world}:{name}×{factor:g}", **values)

    def active(self, name: str) -> bool:
        """Whether nuisance ``name`` is switched on."""
        return any(_nonzero(getattr(self, f)) for f in _nuisance_fields(name))

    @property
    def is_clean(self) -> bool:
        """True when no nuisance is on."""
        return not any(self.active(n) for n in NUISANCES)

    def rng(self, seed: int, name: str) -> np.random.Generator:
        """The random stream of nuisance ``name`` for the trial of ``seed``."""
        return np.random.default_rng([seed, STREAM_TAG, list(NUISANCES).index(name)])

    def to_dict(self) -> dict[str, Any]:
        """The JSON form stored in ``meta.json`` (``realism.parameters``)."""
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(self).items()}


def _zero(value: object) -> object:
    return tuple(0.0 for _ in value) if isinstance(value, tuple) else 0.0


def _scale(value: object, factor: float) -> object:
    if isinstance(value, tuple):
        return tuple(float(v) * factor for v in value)
    return float(value) * factor


def _nonzero(value: object) -> bool:
    return any(v != 0 for v in value) if isinstance(value, tuple) else value != 0


def _nuisance_fields(name: str) -> tuple[str, ...]:
    try:
        return NUISANCES[name]
    except KeyError:
        raise LiquidTouchError(
            f"unknown nuisance {name!r}; use one of: {', '.join(NUISANCES)}"
        ) from None


def get_realism(realism: str | Realism | None) -> Realism:
    """``realism`` as a :class:`Realism`: ``None`` or ``"clean"`` → clean, ``"lab"`` → lab."""
    if realism is None:
        return Realism.clean()
    if isinstance(realism, Realism):
        return realism
    if realism == "clean":
        return Realism.clean()
    if realism == "lab":
        return Realism.lab()
    raise LiquidTouchError(f"unknown realism {realism!r}; use one of: {', '.join(REALISM_WORLDS)}")
