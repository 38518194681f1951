"""How a tactile signal is fitted: :class:`FitSettings` (the fit's options, where it starts).

Shared by ``extract``, ``features`` and ``fit``: the options of
:func:`~liquidtouch.fit.oscillation.fit_oscillation` (loss, model, band [Hz],
noise) and the start of the fitted window (:func:`fit_window`: ``"auto"``, the
free decay after the push, or a time [s] on the signal's clock).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from liquidtouch._core.checks import as_number
from liquidtouch.errors import NoOscillationError, SignalError, SwallowedRingDownError
from liquidtouch.fit.choices import DEFAULT_MODEL, DEFAULT_NOISE, LOSSES, MODELS, NOISE_MODELS
from liquidtouch.fit.oscillation import GAP_STEPS, MIN_DURATION_S, fit_oscillation, validate_signal
from liquidtouch.fit.result import OscillationFit
from liquidtouch.ring_down import free_decay

#: a gap covering this share of the ring-down above the noise or more swallowed it: λ and ω
#: then come from its tail (or from noise) and are reported as such
SWALLOWED_SHARE = 0.5
#: a refused fit names the gaps within this long after the window's start [s]: the
#: ring-down of the most damped liquid (detergent) is above the noise for ~0.7 s
SWALLOW_WINDOW_S = 1.0

AUTO = "auto"
"""``FitSettings.start`` value: fit from the start of the free decay (:func:`free_decay`)."""


@dataclass(frozen=True)
class FitSettings:
    """How a signal is fitted: the options of ``fit_oscillation`` and where the fit starts.

    ``loss``, ``model``, ``band_hz`` [Hz] and ``noise`` are passed to
    :func:`~liquidtouch.fit.oscillation.fit_oscillation`. ``start`` is ``"auto"``
    (the free decay after the push: :func:`~liquidtouch.ring_down.free_decay`) or a
    time [s] on the signal's clock: the samples from then on are fitted. The
    defaults are what ``extract``, ``features``, ``fit`` and ``fit_oscillation``
    use: the paper's loss and the model the data choose
    (:data:`~liquidtouch.fit.choices.DEFAULT_MODEL`, ``"auto"``: single-mode,
    the paper's two modes, amplitude-dependent damping or both together, by an
    information criterion; :mod:`liquidtouch.fit.selection`). ``model="two-mode"``
    is the paper's model. Raises :class:`~liquidtouch.errors.SignalError` for a bad
    option.
    """

    loss: str = "paper"
    model: str = DEFAULT_MODEL
    band_hz: tuple[float, float] = (0.3, 5.0)
    noise: str = DEFAULT_NOISE
    start: float | str = AUTO

    def __post_init__(self) -> None:

        for name, value, choices in (
            ("loss", self.loss, LOSSES),
            ("model", self.model, MODELS),
            ("noise", self.noise, NOISE_MODELS),
        ):
            if value not in choices:
                raise SignalError(f"unknown {name} {value!r}; choose one of {', '.join(choices)}")
        try:
            low, high = (as_number(v) for v in self.band_hz)
        except (TypeError, ValueError):
            raise SignalError(
                f"band_hz must be a pair (low, high) in Hz, got {self.band_hz!r}"
            ) from None
        if not 0 < low < high < math.inf:
            raise SignalError(
                f"the frequency band must satisfy 0 < low < high in Hz, got {low:g}–{high:g} Hz"
            )
        object.__setattr__(self, "band_hz", (float(low), float(high)))
        if self.start != AUTO:
            start = as_number(self.start)
            if not -math.inf < start < math.inf:
                raise SignalError(
                    f"the fit start must be 'auto' or a time in seconds, got {self.start!r}"
                )
            object.__setattr__(self, "start", float(start))

    def to_dict(self) -> dict[str, object]:
        """JSON-ready: ``loss``, ``model``, ``band_hz`` [low, high], ``noise``, ``start``."""
        return {
            "loss": self.loss,
            "model": self.model,
            "band_hz": list(self.band_hz),
            "noise": self.noise,
            "start": self.start,
        }

    def window(self, t: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The samples to fit: from ``start`` on (see :func:`fit_window`)."""
        return fit_window(t, u, self.start)

    def fit_options(self) -> dict[str, object]:
        """Keyword arguments of ``fit_oscillation``: ``loss``, ``model``, ``band_hz``, ``noise``."""
        return {
            "loss": self.loss,
            "model": self.model,
            "band_hz": self.band_hz,
            "noise": self.noise,
        }

    def fit(self, t: np.ndarray, u: np.ndarray) -> OscillationFit:
        """:func:`~liquidtouch.fit.oscillation.fit_oscillation` of :meth:`window` of ``(t, u)``.

        The result's ``gap_before_start_s`` is the gap [s] in ``t`` that ends where
        the window starts (0 when none): the ring-down may have started in it; its
        ``ring_down_gap_share`` the share of the ring-down above the noise that lies
        in gaps (:func:`ring_down_swallowed`).
        """

        t_fit, u_fit = self.window(t, u)
        try:
            fit = fit_oscillation(t_fit, u_fit, **self.fit_options())
        except NoOscillationError as exc:
            gap_s = gap_before(t, float(t_fit[0])) + gap_within(t_fit, SWALLOW_WINDOW_S)
            if gap_s > 0:
                raise SwallowedRingDownError(
                    f"{exc}; {gap_s:.2f} s without samples lie within {SWALLOW_WINDOW_S:g} s "
                    f"of where the ring-down starts ({t_fit[0]:.2f} s): a camera stall may "
                    "have swallowed it"
                ) from None
            raise
        return replace(
            fit,
            gap_before_start_s=gap_before(t, float(t_fit[0])),
            ring_down_gap_share=ring_down_gap_share(t_fit, fit),
        )


def fit_window(
    t: np.ndarray, u: np.ndarray, start: float | str = AUTO
) -> tuple[np.ndarray, np.ndarray]:
    """``(t, u)`` from ``start`` on; time stays absolute [s].

    The whole signal is first checked as a fit input (finite, strictly increasing
    time, long enough, not flat, at most ``MAX_SAMPLES``), so a bad signal is named
    for what it is. ``start="auto"``: the free decay
    (:func:`~liquidtouch.ring_down.free_decay`, what ``extract`` fits); a number: the
    samples at ``t >= start`` (before the first sample: all of them), at least
    ``MIN_DURATION_S`` of them.
    """

    t, u = validate_signal(t, u)
    if start == AUTO:
        return free_decay(t, u)
    start = as_number(start)
    if not -math.inf < start < math.inf:
        raise SignalError(f"the fit start must be 'auto' or a time in seconds, got {start!r}")
    if t[-1] - max(start, t[0]) < MIN_DURATION_S:
        raise SignalError(
            f"the fit start {start:g} s leaves {max(t[-1] - start, 0.0):.3g} s of the signal "
            f"({t[0]:.3g}–{t[-1]:.3g} s); the fit needs at least {MIN_DURATION_S:g} s"
        )
    keep = t >= start
    return t[keep], u[keep]


def gap_before(t: np.ndarray, start_s: float) -> float:
    """The gap [s] in the sample times ``t`` [s] that ends at ``start_s`` (0 when none).

    A step longer than ``GAP_STEPS`` × the median step is a gap (samples never
    observed); measured as its length beyond one median step.
    """
    t = np.asarray(t, dtype=float)
    i = int(np.searchsorted(t, start_s))
    if i == 0 or t.size < 2:
        return 0.0
    typical = float(np.median(np.diff(t)))
    step = float(t[i] - t[i - 1])
    return step - typical if step > GAP_STEPS * typical else 0.0


def gap_within(t: np.ndarray, duration_s: float) -> float:
    """Time [s] without samples in the first ``duration_s`` [s] of ``t`` [s] (steps over
    ``GAP_STEPS`` × the median step, counted beyond one median step)."""
    t = np.asarray(t, dtype=float)
    if t.size < 2:
        return 0.0
    end = min(float(t[0]) + duration_s, float(t[-1]))
    steps = np.diff(t)
    typical = float(np.median(steps))
    gap = steps > GAP_STEPS * typical
    lo = np.clip(t[:-1][gap] + typical, None, end)
    hi = np.clip(t[1:][gap], None, end)
    return float(np.sum(np.maximum(hi - lo, 0.0)))


def ring_down_gap_share(t: np.ndarray, fit: OscillationFit) -> float:
    """Share (0-1) of the ring-down above the noise that lies in gaps of the fitted ``t`` [s].

    The ring-down above the noise runs from the fit's ``t0`` for
    ``ln(|amplitude| / noise_std) / decay_rate`` [s] (0 when the amplitude is below
    the noise); a gap is a step over ``GAP_STEPS`` × the median step, counted beyond
    one median step. A stall of 0.3-1 s swallows a detergent's ~0.7 s ring-down.
    """
    t = np.asarray(t, dtype=float)
    ratio = abs(fit.amplitude) / fit.noise_std if fit.noise_std > 0 else math.inf
    ring_s = math.log(max(ratio, 1.0)) / fit.decay_rate if fit.decay_rate > 0 else math.inf
    span_s = min(ring_s, float(t[-1] - t[0])) if t.size > 1 else 0.0
    return gap_within(t, span_s) / span_s if span_s > 0 else 0.0


def ring_down_swallowed(fit: OscillationFit) -> bool:
    """Whether a gap swallowed the fitted ring-down: ``ring_down_gap_share`` ≥
    :data:`SWALLOWED_SHARE` (λ and ω then come from its tail, or from noise)."""
    return getattr(fit, "ring_down_gap_share", 0.0) >= SWALLOWED_SHARE
