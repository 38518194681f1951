"""Properties from a streaming fit: the model's prediction with the fit's uncertainty in it.

A :class:`~liquidtouch.models.property_model.PropertyModel` predicts each target
from the features (λ [1/s], ω [rad/s]) with its own predictive std, as if the
features were exact. Early in a stream they are not, so the fit's λ and ω std
are propagated through the model by central differences one std either side
(a linearisation whose step is the uncertainty itself, so curvature over that
range counts) and added in quadrature::

    var = std_model(λ, ω)² + ((f(λ+σλ, ω) − f(λ−σλ, ω)) / 2)² + ((f(λ, ω+σω) − f(λ, ω−σω)) / 2)²

treating λ and ω as independent (the fit reports their std only). One call of
``PropertyModel.predict`` on five rows: the cost does not grow with the targets.

A liquid classifier gives class probabilities instead
(:func:`classify_with_fit_std`): the mean of its probabilities at the same five
points — the centre weighted 1/3, each ±1σ point 1/6 (the sigma points of a
Gaussian in two dimensions) — so an uncertain λ spreads the probability over
the classes it could belong to.
"""

from __future__ import annotations

import math

import numpy as np

from liquidtouch.errors import ModelFileError

#: λ below the central-difference step is clipped to this [1/s] (λ must stay > 0)
MIN_DECAY_RATE = 1e-6


#: weights of the five points (centre, λ ± σλ, ω ± σω) in a classifier's mean probabilities
SIGMA_POINT_WEIGHTS = np.array([1 / 3, 1 / 6, 1 / 6, 1 / 6, 1 / 6])


def check_live_model(model: object) -> str:
    """``"regression"`` or ``"classification"``: the kind of a :class:`PropertyModel`.

    Anything else raises :class:`ModelFileError`.
    """
    kind = getattr(model, "kind", None)
    if kind not in ("regression", "classification"):
        raise ModelFileError(
            "the live estimate needs a model from 'train' (targets such as height_mm) or "
            f"'classify' (liquid names); got {type(model).__name__}"
        )
    return kind


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
    rows = _five_rows(
        float(decay_rate), _std_or_zero(decay_rate_std),
        float(angular_frequency), _std_or_zero(angular_frequency_std),
    )  # fmt: skip
    out = {}
    for target, (mean, std) in model.predict(rows).items():
        mean = np.asarray(mean, dtype=float)
        spread = 0.5 * (mean[1] - mean[2]), 0.5 * (mean[3] - mean[4])
        total = math.sqrt(float(np.asarray(std)[0]) ** 2 + spread[0] ** 2 + spread[1] ** 2)
        out[target] = (float(mean[0]), total)
    return out


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
    return {model.targets[0]: (best, dict(zip(classes, mean.tolist(), strict=True)))}
