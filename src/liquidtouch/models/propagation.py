"""The fit's uncertainty through a property model: first-order propagation of (λ, ω) std.

A property model predicts from the features (λ [1/s], ω [rad/s]) as if they were
exact. They are not — a streamed fit's λ may be tens of % off, an offline fit's
a few % — so their std (and λ–ω correlation ρ, when known) is carried through
the model by the delta method, with the model's gradient taken by central
differences one std either side (a linearisation whose step is the uncertainty
itself, so curvature over that range counts)::

    dλ = (f(λ + σλ, ω) − f(λ − σλ, ω)) / 2,   dω = (f(λ, ω + σω) − f(λ, ω − σω)) / 2
    var_fit = dλ² + dω² + 2 ρ dλ dω

and the predictive variance is the model's (calibrated) variance plus ``var_fit``
(:meth:`~liquidtouch.models.property_model.PropertyModel.predict`). λ − σλ is
kept above :data:`MIN_DECAY_RATE` and ω − σω above :data:`MIN_ANGULAR_FREQUENCY` (the
difference is then rescaled to a step of σ: a failed fit's ω std can exceed ω).
One call of the model on 5 n rows: the cost does not grow with the targets.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np

from liquidtouch.errors import TableError

__all__ = [
    "MIN_ANGULAR_FREQUENCY",
    "MIN_DECAY_RATE",
    "clean_feature_std",
    "propagated_variance",
    "sigma_rows",
]

#: λ below the central-difference step is clipped to this [1/s] (λ must stay > 0)
MIN_DECAY_RATE = 1e-6
#: ω below the central-difference step is clipped to this [rad/s] (ω must stay > 0)
MIN_ANGULAR_FREQUENCY = 1e-6


def clean_feature_std(X_std: object, n: int) -> np.ndarray:
    """(n, 2) std of (λ, ω): NaN or absent counts as 0; negative or wrong shape refused."""
    if X_std is None:
        return np.zeros((n, 2))
    try:
        s = np.array(X_std, dtype=float).reshape(n, 2)
    except (TypeError, ValueError):
        raise TableError(f"the feature std must be an ({n}, 2) array of (λ, ω) std") from None
    s[~np.isfinite(s)] = 0.0
    if np.any(s < 0):
        raise TableError("a feature std must be >= 0")
    return s


def _low_side(x: np.ndarray, s: np.ndarray, floor: float) -> np.ndarray:
    """x − s kept above ``floor`` (and at most x)."""
    low = np.maximum(x - s, floor)
    return np.where(s > 0, np.minimum(low, x), x)


def sigma_rows(X: np.ndarray, X_std: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The 5 n rows (X, λ ± σλ, ω ± σω) and the (λ, ω) steps actually taken (n, 2)."""
    lam, omega = X[:, 0], X[:, 1]
    s_lam, s_omega = X_std[:, 0], X_std[:, 1]
    low_lam = _low_side(lam, s_lam, MIN_DECAY_RATE)
    low_omega = _low_side(omega, s_omega, MIN_ANGULAR_FREQUENCY)
    rows = np.concatenate(
        [
            X,
            np.column_stack([lam + s_lam, omega]),
            np.column_stack([low_lam, omega]),
            np.column_stack([lam, omega + s_omega]),
            np.column_stack([lam, low_omega]),
        ]
    )
    return rows, np.column_stack([(lam + s_lam) - low_lam, (omega + s_omega) - low_omega])


def propagated_variance(
    means: Callable[[np.ndarray], Mapping[str, np.ndarray]],
    X: np.ndarray,
    X_std: np.ndarray,
    corr: np.ndarray | float = 0.0,
) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """``({target: mean (n,)}, {target: var_fit (n,)})`` at the (n, 2) features ``X``.

    ``means(rows)`` returns ``{target: predicted mean}`` for an (m, 2) array of rows
    (in the input coordinates); ``X_std`` is the (n, 2) std of (λ, ω) (0: exact),
    ``corr`` the λ–ω correlation (scalar or (n,), in [−1, 1]).
    """
    n = X.shape[0]
    rho = np.broadcast_to(np.asarray(corr, dtype=float), (n,))
    if not np.all(np.abs(rho) <= 1):
        raise TableError("the λ–ω correlation must lie in [-1, 1]")
    rows, step = sigma_rows(X, X_std)
    with np.errstate(invalid="ignore", divide="ignore"):
        rescale = np.where(step > 0, 2 * X_std / step, 0.0)
    mean_out, var_out = {}, {}
    for target, values in means(rows).items():
        v = np.asarray(values, dtype=float).reshape(5, n)
        d_lam = 0.5 * (v[1] - v[2]) * rescale[:, 0]
        d_omega = 0.5 * (v[3] - v[4]) * rescale[:, 1]
        mean_out[target] = v[0]
        var_out[target] = np.maximum(d_lam**2 + d_omega**2 + 2 * rho * d_lam * d_omega, 0.0)
    return mean_out, var_out
