"""The result of the oscillation fit: :class:`OscillationFit` (λ, ω, their std, the curve)."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from liquidtouch._core.numbers import fixed, with_uncertainty
from liquidtouch.fit.amplitude import amplitude_damped_cosine
from liquidtouch.fit.drifting_line import drifting_cosine
from liquidtouch.fit.model import N_QUADRATIC, cosine_drift, damped_cosine, quadratic_drift

__all__ = ["OscillationFit"]


@dataclass(frozen=True, repr=False)
class OscillationFit:
    """Result of :func:`fit_oscillation`. Rates in 1/s, angular frequencies in rad/s.

    Amplitudes are in the unit of ``u`` and, like the phases [rad] and the drift
    coefficients ``drift_c0`` [u], ``drift_c1`` [u/s], ``drift_c2`` [u/s²], refer
    to time measured from ``t0`` (the first time stamp). On a record long enough to hold
    them (:func:`~liquidtouch.fit.model.drift_turns`), ``drift_cosines`` [u] are the
    amplitudes of the drift's slow cosines ``cos(jπτ/T)``, ``j = 3, 4, ...`` (``T`` =
    ``duration_s``; empty otherwise). Fast-mode fields are NaN when the single-mode model
    was used.

    ``model == "amplitude"`` (:mod:`liquidtouch.fit.amplitude`): the decay rate
    depends on the amplitude, ``λ(A) = λ0 (1 + κ A^p)``; ``decay_rate`` is the
    small-amplitude λ0, ``amplitude`` A at ``t0``, ``damping_gain`` κ [1/u^p]
    (0 when the data do not support a gain: then λ0 is the single-mode λ),
    ``damping_gain_std`` its standard error and ``damping_exponent`` p (fitted, 1 to 2).
    All three are NaN for the other models. ``model == "amplitude-two-mode"``: that
    mode plus a second, exponentially damped one (``fast_*``). ``model == "drifting-line"``
    (:mod:`liquidtouch.fit.drifting_line`): damping and frequency both move with the
    amplitude, ``λ(A) = λ0 (1 + κ A²)``, ``ω(A) = ω0 (1 + η A²)``; ``decay_rate`` and
    ``angular_frequency`` are the small-amplitude λ0 and ω0, ``damping_gain`` κ
    (``damping_exponent`` 2), ``frequency_shift`` ``f = η A0² = ω(A0)/ω0 − 1`` at ``t0``
    (negative: a softening line), ``frequency_shift_std`` its standard error, and
    ``harmonic_amplitude`` [u], ``harmonic_phase`` [rad] the mode's third harmonic at ``t0``
    (NaN for the other models).

    Model averaging (:mod:`liquidtouch.fit.selection`): ``decay_rate``,
    ``angular_frequency`` and their std are the criterion-weighted mean over the models
    the criterion cannot tell apart, with the law of total variance (the ± holds the
    spread between them); ``model`` is the one of most weight, ``model_weight`` its
    weight (1: no other model counts; ``model_reason`` lists the weights), and the
    other fields (amplitude, phase, fast mode, drift, gain) are that model's.

    Which model and why (:mod:`liquidtouch.fit.selection`): ``model`` is the model
    fitted, ``model_reason`` one line on why (asked for, or the candidates by their
    information criterion), ``delta_bic_single_mode``, ``delta_bic_two_mode``,
    ``delta_bic_amplitude``, ``delta_bic_drifting_line`` and
    ``delta_bic_amplitude_two_mode`` each candidate's BIC
    minus the chosen one's (0 for the chosen model, NaN when not fitted; over 6:
    strong evidence against it) and
    ``n_effective`` the effective number of independent noise samples the
    criterion used. Gaps: ``gap_share`` is the share of the fitted time span with
    no samples (0-1), ``gap_before_start_s`` [s] the gap that ends where the fitted
    window starts (0 when there is none; set by
    :meth:`~liquidtouch.extraction.fit_settings.FitSettings.fit`: the ring-down may have
    started inside it), ``ring_down_gap_share`` the share (0-1) of the ring-down
    above the noise (from ``t0`` for ``ln(|amplitude| / noise_std) / decay_rate``)
    that lies in gaps (also set by ``FitSettings.fit``; from a half on, the gap
    swallowed the ring-down: :func:`~liquidtouch.extraction.fit_settings.ring_down_swallowed`).

    Its repr is one short line: λ and ω rounded to their std, the model and R².
    """

    decay_rate: float
    angular_frequency: float
    amplitude: float
    phase: float
    fast_decay_rate: float
    fast_angular_frequency: float
    fast_amplitude: float
    fast_phase: float
    drift_c0: float
    drift_c1: float
    drift_c2: float
    drift_cosines: tuple[float, ...]
    decay_rate_std: float
    angular_frequency_std: float
    fast_decay_rate_std: float
    fast_angular_frequency_std: float
    r2: float
    noise_std: float
    loss: str
    delta: float
    model: str
    t0: float
    n_samples: int
    duration_s: float
    damping_gain: float = math.nan
    damping_gain_std: float = math.nan
    damping_exponent: float = math.nan
    model_reason: str = ""
    delta_bic_single_mode: float = math.nan
    delta_bic_two_mode: float = math.nan
    delta_bic_amplitude: float = math.nan
    delta_bic_amplitude_two_mode: float = math.nan
    n_effective: float = math.nan
    delta_bic_drifting_line: float = math.nan
    model_weight: float = 1.0
    frequency_shift: float = math.nan
    frequency_shift_std: float = math.nan
    harmonic_amplitude: float = math.nan
    harmonic_phase: float = math.nan
    gap_share: float = 0.0
    gap_before_start_s: float = 0.0
    ring_down_gap_share: float = 0.0

    def __repr__(self) -> str:
        return (
            f"OscillationFit(decay_rate={with_uncertainty(self.decay_rate, self.decay_rate_std)}"
            " 1/s, angular_frequency="
            f"{with_uncertainty(self.angular_frequency, self.angular_frequency_std)} rad/s, "
            f"model={self.model!r}, r2={fixed(self.r2)})"
        )

    @property
    def frequency_hz(self) -> float:
        """Slow-mode frequency ω / 2π [Hz]."""
        return self.angular_frequency / (2 * math.pi)

    def modes(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The slow mode, the fast mode (zeros if unused) and the drift at times ``t`` [s]."""
        tau = np.asarray(t, dtype=float) - self.t0
        if self.model == "drifting-line":
            slow = drifting_cosine(
                tau,
                self.amplitude,
                self.decay_rate,
                self.angular_frequency,
                self.phase,
                self.damping_gain,
                self.frequency_shift,
                self.harmonic_amplitude,
                self.harmonic_phase,
            )
        elif self.model in ("amplitude", "amplitude-two-mode"):
            slow = amplitude_damped_cosine(
                tau,
                self.amplitude,
                self.decay_rate,
                self.angular_frequency,
                self.phase,
                self.damping_gain,
                self.damping_exponent,
            )
        else:
            slow = damped_cosine(
                tau, self.amplitude, self.decay_rate, self.angular_frequency, self.phase
            )
        if self.model in ("two-mode", "amplitude-two-mode"):
            fast = damped_cosine(
                tau,
                self.fast_amplitude,
                self.fast_decay_rate,
                self.fast_angular_frequency,
                self.fast_phase,
            )
        else:
            fast = np.zeros_like(tau)
        drift = quadratic_drift(tau, self.drift_c0, self.drift_c1, self.drift_c2)
        drift += cosine_drift(tau, np.array(self.drift_cosines), self.duration_s)
        return slow, fast, drift

    def curve(self, t: np.ndarray) -> np.ndarray:
        """The fitted signal û at times ``t`` [s]."""
        slow, fast, drift = self.modes(t)
        return slow + fast + drift

    def to_dict(self) -> dict[str, float | int | str | None]:
        """JSON-ready dict with the CLI's key names (NaN becomes ``None``); the drift's
        cosines flat, as ``drift_cos3``, ``drift_cos4``, ... (a table's columns)."""
        out: dict[str, float | int | str | None] = {}
        fields = asdict(self)
        cosines = fields.pop("drift_cosines")
        fields.update({f"drift_cos{j}": a for j, a in enumerate(cosines, N_QUADRATIC)})
        for key, value in fields.items():
            if isinstance(value, float) and not math.isfinite(value):
                out[key] = None
            elif isinstance(value, str | int):
                out[key] = value
            else:
                out[key] = float(value)
        return out
