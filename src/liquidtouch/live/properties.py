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
"""

from __future__ import annotations

import math

import numpy as np

from liquidtouch.errors import ModelFileError

#: λ below the central-difference step is clipped to this [1/s] (λ must stay > 0)
MIN_DECAY_RATE = 1e-6


def check_regression_model(model: object) -> list[str]:
    """The targets of a regression :class:`PropertyModel`; ModelFileError otherwise."""
    if getattr(model, "kind", None) != "regression":
        raise ModelFileError(
            "the live estimate needs a regression model (from 'train', with targets such as "
            "height_mm); a liquid classifier gives no std to stop on"
        )
    return list(model.targets)


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
    lam, omega = float(decay_rate), float(angular_frequency)
    d_lam = 0.0 if not math.isfinite(decay_rate_std) else float(decay_rate_std)
    d_omega = 0.0 if not math.isfinite(angular_frequency_std) else float(angular_frequency_std)
    rows = np.array(
        [
            [lam, omega],
            [lam + d_lam, omega],
            [max(lam - d_lam, MIN_DECAY_RATE), omega],
            [lam, omega + d_omega],
            [lam, omega - d_omega],
        ]
    )
    out = {}
    for target, (mean, std) in model.predict(rows).items():
        mean = np.asarray(mean, dtype=float)
        spread = 0.5 * (mean[1] - mean[2]), 0.5 * (mean[3] - mean[4])
        total = math.sqrt(float(np.asarray(std)[0]) ** 2 + spread[0] ** 2 + spread[1] ** 2)
        out[target] = (float(mean[0]), total)
    return out
