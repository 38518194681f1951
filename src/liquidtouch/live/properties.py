"""Properties from a streaming fit: the model's prediction with the fit's uncertainty in it.

A :class:`~liquidtouch.models.property_model.PropertyModel` predicts each target
from the features (λ [1/s], ω [rad/s]) with its own (calibrated) predictive std.
Early in a stream the features are far from exact, so their streamed std is
propagated through the model and its variance added — by
:meth:`PropertyModel.predict` itself (``X_std``; the delta method of
:mod:`liquidtouch.models.propagation`, one implementation for ``predict``, the
live estimate and the benchmarks)::

    var = (s · std_model(λ, ω))² + dλ² + dω²,  dλ = (f(λ+σλ, ω) − f(λ−σλ, ω)) / 2, ...

treating λ and ω as independent (the fit reports their std only).

A liquid classifier gives class probabilities instead
(:func:`classify_with_fit_std`): the mean of its probabilities at five points
(λ, ω), λ ± σλ, ω ± σω — the centre weighted 1/3, each ±1σ point 1/6 (the sigma
points of a Gaussian in two dimensions) — so an uncertain λ spreads the
probability over the classes it could belong to.
Far from every trained class (Hotelling's T² per class in (log λ, ω),
with the fit's λ and ω std added to each class's spread:
:mod:`liquidtouch.models.classifier`) it answers ``"unknown"``, its probabilities kept.

:func:`out_of_domain` says when an answer lies outside what the model knows: (λ, ω)
outside its training domain (the box ``predict`` flags), or, for a classifier, unknown.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from liquidtouch.batch.features import feature_settings
from liquidtouch.extraction.fit_settings import FitSettings
from liquidtouch.live.stopping import check_live_model, check_until_std, unreachable_targets
from liquidtouch.models import predictions
from liquidtouch.models.classifier import UNKNOWN
from liquidtouch.models.extraction_match import settings_differences
from liquidtouch.models.propagation import MIN_DECAY_RATE

#: weights of the five points (centre, λ ± σλ, ω ± σω) in a classifier's mean probabilities
SIGMA_POINT_WEIGHTS = np.array([1 / 3, 1 / 6, 1 / 6, 1 / 6, 1 / 6])


def check_live_request(model: object | None, until_std: Mapping[str, float]) -> dict[str, float]:
    """Check a live estimate's model and ``until_std`` before any frame is read (or any robot
    moves): the model's kind, every target; return the targets the model can never meet
    (:func:`~liquidtouch.live.stopping.unreachable_targets`)."""
    kind = check_live_model(model) if model is not None else ""
    targets = list(model.targets) if kind == "regression" else []
    check_until_std(until_std, targets, kind)
    return unreachable_targets(model, until_std)


def settings_warning(
    model: object,
    *,
    lowpass_hz: float | None,
    n_markers: int,
    fit_settings: FitSettings | None = None,
) -> str | None:
    """A warning when the live estimate, u(t) of ``n_markers`` markers (of every sensor)
    low-passed at ``lowpass_hz`` [Hz] (None: not) fitted with ``fit_settings`` (default:
    ``extract``'s), is made otherwise than ``model``'s training features (the settings
    :func:`~liquidtouch.batch.features.feature_settings` gives them;
    :mod:`~liquidtouch.models.extraction_match`); None when it is not, or not known."""
    trained = getattr(model, "extraction_settings", None)
    if trained is None:
        return None
    used = feature_settings(lowpass_hz=lowpass_hz, n_markers=n_markers, fit_settings=fit_settings)
    differ = settings_differences(trained, used)
    if not differ:
        return None
    return (
        f"the live signal is made otherwise than the model's training features "
        f"({'; '.join(differ)}): its std may not hold"
    )


def _five_rows(lam: float, d_lam: float, omega: float, d_omega: float) -> np.ndarray:
    """(λ, ω), then λ ± σλ, then ω ± σω: the rows the std is propagated on."""
    return np.array(
        [
            [lam, omega],
            [lam + d_lam, omega],
            [max(lam - d_lam, MIN_DECAY_RATE), omega],
            [lam, omega + d_omega],
            [lam, omega - d_omega],
        ]
    )


def _std_or_zero(std: float) -> float:
    return float(std) if math.isfinite(float(std)) else 0.0


def predict_with_fit_std(
    model: object,
    decay_rate: float,
    decay_rate_std: float,
    angular_frequency: float,
    angular_frequency_std: float,
) -> dict[str, tuple[float, float]]:
    """``{target: (mean, std)}`` at (λ, ω) with the fit's std propagated (module docstring).

    A NaN std of λ or ω counts as 0 (that feature's uncertainty is left out).
    """
    X = np.array([[float(decay_rate), float(angular_frequency)]])
    X_std = np.array([[_std_or_zero(decay_rate_std), _std_or_zero(angular_frequency_std)]])
    return {
        target: (float(mean[0]), float(std[0]))
        for target, (mean, std) in model.predict(X, X_std).items()
    }


def classify_with_fit_std(
    model: object,
    decay_rate: float,
    decay_rate_std: float,
    angular_frequency: float,
    angular_frequency_std: float,
) -> dict[str, tuple[str, dict[str, float]]]:
    """``{label column: (most probable class, {class: probability})}`` of a classifier.

    The probabilities are the sigma-point mean (module docstring), so they sum to 1;
    a NaN std of λ or ω counts as 0.
    """
    rows = _five_rows(
        float(decay_rate), _std_or_zero(decay_rate_std),
        float(angular_frequency), _std_or_zero(angular_frequency_std),
    )  # fmt: skip
    _, proba = model.predict_proba(rows)
    mean = SIGMA_POINT_WEIGHTS @ np.asarray(proba, dtype=float)
    classes = [str(c) for c in model.classifier.classes_]
    best = classes[int(np.argmax(mean))]
    std = [[_std_or_zero(decay_rate_std), _std_or_zero(angular_frequency_std)]]
    if model.unknown(rows[:1], std)[0]:
        best = UNKNOWN
    return {model.targets[0]: (best, dict(zip(classes, mean.tolist(), strict=True)))}


def out_of_domain(
    model: object,
    decay_rate: float,
    angular_frequency: float,
    classified: dict[str, tuple[str, dict[str, float]]] | None = None,
) -> bool:
    """(λ, ω) is outside what ``model`` knows (:func:`liquidtouch.models.predictions.out_of_domain`,
    the definition ``predict`` uses): outside its training domain, or a classifier's answer in
    ``classified`` is ``"unknown"``."""
    answers = [name for name, _ in (classified or {}).values()][:1] or None
    X = [[float(decay_rate), float(angular_frequency)]]
    return bool(predictions.out_of_domain(model, X, answers)[0])
