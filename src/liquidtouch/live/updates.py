"""What the streaming estimator reports: :class:`LiveUpdate`, one per refresh.

An update is JSON-ready through :meth:`LiveUpdate.to_dict` (numbers only, NaN
and unsupported estimates as ``null``): the keys are documented in
``docs/formats.md`` ("Live updates").
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field

import numpy as np

from liquidtouch._core.numbers import number, with_uncertainty
from liquidtouch.models.predictions import PROBABILITY_PREFIX

#: the stream's phases: no push yet, a push (or another transient) is under way, the free
#: decay is being fitted, the hold ended (the ring-down's estimate is final), the stream ended
PHASES = ("waiting", "push", "decay", "ended", "done")


#: what changes with every refresh whatever the estimate (left out of :func:`repeat_key`)
VOLATILE_FIELDS = ("frames", "elapsed_s", "lag_s", "timing")


def _number(value: float | None) -> float | None:
    """``value`` as a JSON number; ``None`` for NaN/inf/None."""
    if value is None:
        return None
    value = float(value)
    return value if math.isfinite(value) else None


def _numbers(values: np.ndarray) -> list[float | None]:
    return [_number(v) for v in np.asarray(values, dtype=float).tolist()]


@dataclass(repr=False)
class LiveUpdate:
    """One estimate of the stream (rates 1/s, angular frequencies rad/s, times s).

    Attributes
    ----------
    t_s : time since the free decay started [s] (newest signal sample); NaN before it.
    phase : one of :data:`PHASES`.
    decay_rate, decay_rate_std : λ and its std [1/s]; NaN until supported (the
        emission rule of :mod:`liquidtouch.live.estimator`).
    angular_frequency, angular_frequency_std : ω and its std [rad/s]; NaN until supported.
    predicted : ``{target: (mean, std)}`` of the model (empty without a model or a
        fit; a target with an ``until_std`` threshold only once its std meets it);
        the std combines the model's calibrated predictive std and the fit's λ/ω
        std propagated through the model.
    classified : ``{label column: (class, {class: probability})}`` of a liquid
        classifier (empty without one or until both λ and ω are supported); the
        probabilities average the classifier's over λ, ω ± their std.
    final : the last update of the stream: the whole record refitted as ``extract`` does,
        or, when stopped by ``until_std``, the last streamed estimate (``message`` says).
    stopped_because : why the stream ended (final update only): ``"until_std"``,
        ``"end_of_stream"`` or ``"max_duration"``.
    elapsed_s : stream time since the first frame [s].
    frames : frames consumed so far (all sensors).
    window_s : length of the fitted free-decay window [s] (NaN without a fit).
    model : the fit's model (``"single-mode"``/``"two-mode"``), ``""`` without a fit.
    lag_s : wall-clock lag of the estimate behind the newest frame it includes [s]
        (NaN when frames are not paced in real time).
    message : why there is no estimate yet (e.g. the fit's refusal), else ``""``.
    timing : final update only: per-frame latency of the estimator [ms]
        (``latency_ms_median``/``_p95``/``_max``) and, for paced frames, the lag of
        a frame's processing behind its arrival [s] (``frame_lag_s_median``/``_p95``/``_max``).
    segment : which ring-down of the stream the estimate comes from (1, 2, ...; 0: none yet).
    segment_start_s, segment_end_s : its window on the stream's clock [s].
    segment_final : the hold of that ring-down ended: its estimate is final, never replaced
        (a later push starts segment ``segment + 1``).
    segments : final update only: every ring-down's final estimate (``RingDown.summary``).
    events : the protocol's events on the decay clock [s] (``run-trial``), for the plot.
    combined : once a ring-down is final: every final ring-down so far combined by its ±
        (:func:`liquidtouch.live.combined.combined_answer`: λ, ω, their std, ``ring_downs``,
        ``consistent``, ``outliers``; with a regression model ``predicted`` and, given
        ``until_std``, ``reach`` per target: met, pushes needed, or cannot tell and why).
    out_of_domain : with a model, once λ and ω are reported: (λ, ω) lies outside what the
        model knows — outside its training domain, or a classifier's answer is "unknown"
        (``liquidtouch.models.predictions.out_of_domain``, as ``predict``'s column); None
        without a model or estimate.
    unknown_rule : with a classifier: whether it can answer "unknown"
        (``liquidtouch.models.predictions.unknown_rule``: ``"available"`` or ``"unavailable,
        needs N rows per class"``); None otherwise.
    until_std_unreachable : ``{target: floor}`` of the ``until_std`` targets the model's
        calibrated std never falls below (``liquidtouch.live.stopping.std_floors``): their
        threshold cannot be met (``message`` says so too); they are shown as they come.
    signal_t_s, signal_u, signal_fit : the tactile signal [s, px] on the decay clock
        (0 at the free-decay start, negative before) and the fitted curve (NaN
        where not fitted), for plots.

    Its repr is one short line: the phase, λ and ω rounded to their std, the
    predictions and classes.
    """

    t_s: float = math.nan
    phase: str = "waiting"
    decay_rate: float = math.nan
    decay_rate_std: float = math.nan
    angular_frequency: float = math.nan
    angular_frequency_std: float = math.nan
    predicted: dict[str, tuple[float, float]] = field(default_factory=dict)
    classified: dict[str, tuple[str, dict[str, float]]] = field(default_factory=dict)
    final: bool = False
    stopped_because: str | None = None
    elapsed_s: float = math.nan
    frames: int = 0
    window_s: float = math.nan
    model: str = ""
    lag_s: float = math.nan
    message: str = ""
    timing: dict[str, float] = field(default_factory=dict)
    segment: int = 0
    segment_start_s: float = math.nan
    segment_end_s: float = math.nan
    segment_final: bool = False
    segments: list[dict[str, object]] = field(default_factory=list)
    events: dict[str, float] = field(default_factory=dict)
    combined: dict[str, object] = field(default_factory=dict)
    out_of_domain: bool | None = None
    unknown_rule: str | None = None
    until_std_unreachable: dict[str, float] = field(default_factory=dict)
    signal_t_s: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    signal_u: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    signal_fit: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)

    def __repr__(self) -> str:
        parts = [
            f"phase={self.phase!r}",
            f"t_s={number(self.t_s, 3)}",
            f"decay_rate={with_uncertainty(self.decay_rate, self.decay_rate_std)} 1/s",
            "angular_frequency="
            f"{with_uncertainty(self.angular_frequency, self.angular_frequency_std)} rad/s",
        ]
        parts += [f"{t}={with_uncertainty(m, s)}" for t, (m, s) in self.predicted.items()]
        parts += [f"{label}={name!r}" for label, (name, _) in self.classified.items()]
        if self.out_of_domain:
            parts.append("out_of_domain=True")
        if self.final:
            parts.append("final=True")
        return f"LiveUpdate({', '.join(parts)})"

    def std_of(self, target: str) -> float:
        """The std of ``target`` (``decay_rate``, ``angular_frequency`` or a model target)."""
        if target in ("decay_rate", "angular_frequency"):
            return float(getattr(self, f"{target}_std"))
        if target in self.predicted:
            return float(self.predicted[target][1])
        return math.nan

    def to_dict(self, include_signal: bool = False) -> dict[str, object]:
        """JSON-ready dict (module docstring); ``include_signal`` adds ``signal``."""
        out: dict[str, object] = {
            "t_s": _number(self.t_s),
            "phase": self.phase,
            "decay_rate": _number(self.decay_rate),
            "decay_rate_std": _number(self.decay_rate_std),
            "angular_frequency": _number(self.angular_frequency),
            "angular_frequency_std": _number(self.angular_frequency_std),
        }
        for target, (mean, std) in self.predicted.items():
            out[f"predicted_{target}"] = _number(mean)
            out[f"predicted_{target}_std"] = _number(std)
        for label, (name, proba) in self.classified.items():
            out[f"predicted_{label}"] = name
            for k, p in proba.items():  # predict's columns (models.predictions)
                out[f"{PROBABILITY_PREFIX}{k}"] = _number(p)
        out.update(
            final=bool(self.final),
            elapsed_s=_number(self.elapsed_s),
            frames=int(self.frames),
            window_s=_number(self.window_s),
            model=self.model,
            lag_s=_number(self.lag_s),
            message=self.message,
            segment=int(self.segment),
            segment_start_s=_number(self.segment_start_s),
            segment_end_s=_number(self.segment_end_s),
            segment_final=bool(self.segment_final),
            out_of_domain=self.out_of_domain,
            until_std_unreachable={t: _number(f) for t, f in self.until_std_unreachable.items()},
        )
        if self.combined:
            out["combined"] = self.combined
        if self.unknown_rule is not None:
            out["unknown_rule"] = self.unknown_rule
        if self.final:
            out["segments"] = self.segments
            out["stopped_because"] = self.stopped_because
            out["timing"] = {key: _number(value) for key, value in self.timing.items()}
        if include_signal:
            out["events"] = {name: _number(t) for name, t in self.events.items()}
            out["signal"] = {
                "t_s": _numbers(self.signal_t_s),
                "u": _numbers(self.signal_u),
                "fit": _numbers(self.signal_fit),
            }
        return out


def repeat_key(update: LiveUpdate) -> str:
    """The update's JSON without :data:`VOLATILE_FIELDS`: equal for a repeat of the same
    estimate (a stream whose ring-down ended repeats it every refresh until it stops)."""
    out = {k: v for k, v in update.to_dict().items() if k not in VOLATILE_FIELDS}
    return json.dumps(out, sort_keys=True, default=str)
