"""Container transfer: reuse a model trained on container A for a similar container B.

The paper's transfer keeps the trained model f_A and fits only an affine map
of the features, ``f_B(λ, ω) = f_A(α1 λ + α2, β1 ω + β2)``, on a few labelled
trials of the new container. We fit the four numbers by robust (soft-L1) least
squares starting from the identity, over all of the model's targets that the
tuning table labels, each residual divided by that target's training spread so
that targets in different units weigh alike. A weak pull towards the identity
keeps the map well-posed when the tuning points span little of (λ, ω).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from liquidtouch._core.checks import check_positive
from liquidtouch.errors import TableError
from liquidtouch.models.feature_space import FeatureMap
from liquidtouch.models.kernel_limits import single_threaded_blas
from liquidtouch.models.property_model import PropertyModel
from liquidtouch.models.validation import check_features

MIN_TUNE_ROWS = 4  # four parameters (α1, α2, β1, β2)
START_ALPHA1 = (0.5, 1.0, 2.0)  # decay-rate scales tried as starts (walls damp differently)
START_BETA1 = (0.8, 0.9, 1.0, 1.1, 1.25)  # frequency scales tried (other lengths, shapes)
N_REFINED_STARTS = 3


@dataclass
class TransferResult:
    """The transferred model, its new feature map and the fit quality on the tuning points."""

    model: PropertyModel
    feature_map: FeatureMap
    n_points: int
    mae_before: dict[str, float]
    mae_after: dict[str, float]

    def summary(self) -> list[str]:
        """Human-readable lines: α, β and the tuning MAE before/after per target."""
        a, b = self.feature_map.alpha, self.feature_map.beta
        lines = [
            f"transfer on {self.n_points} points: α1 = {a[0]:.4g}, α2 = {a[1]:+.4g} 1/s, "
            f"β1 = {b[0]:.4g}, β2 = {b[1]:+.4g} rad/s"
        ]
        for t in self.mae_after:
            lines.append(
                f"{t}: tuning MAE {self.mae_before[t]:.4g} (model A as is) -> "
                f"{self.mae_after[t]:.4g} (transferred)"
            )
        return lines


def fit_transfer(
    model: PropertyModel,
    X: Any,
    targets: Mapping[str, Any],
    f_scale: float = 0.1,
    identity_weight: float = 0.01,
) -> TransferResult:
    """Fit ``f_B(λ, ω) = f_A(α1 λ + α2, β1 ω + β2)`` on tuning features ``X`` and labels.

    ``targets`` maps target column → values (a subset of ``model.targets``).
    ``f_scale`` is the soft-L1 threshold in units of each target's training
    standard deviation; ``identity_weight`` the strength of the pull towards
    α = β = (1, 0). If ``model`` already has a map M_A, the result predicts
    ``f(M_A(M_new x))``. Returns the transferred model (a new object) and a summary.
    """
    from scipy.optimize import least_squares

    if not isinstance(model, PropertyModel):
        raise TableError(f"fit_transfer needs a PropertyModel; got {type(model).__name__}")
    if model.kind != "regression":
        raise TableError("container transfer needs a regression model (train one with `train`)")
    f_scale = check_positive(f_scale, "f_scale")
    identity_weight = check_positive(identity_weight, "identity_weight", allow_zero=True)
    if not isinstance(targets, Mapping):
        raise TableError("targets must map target column → values")
    X = check_features(X)
    unknown = [t for t in targets if t not in model.regressors]
    if unknown or not targets:
        raise TableError(
            f"the tuning table must label at least one of the model's targets "
            f"({', '.join(model.targets)}); {'unknown: ' + ', '.join(unknown) if unknown else ''}"
        )
    if X.shape[0] < MIN_TUNE_ROWS:
        raise TableError(
            f"container transfer fits 4 parameters and needs at least {MIN_TUNE_ROWS} "
            f"tuning rows; got {X.shape[0]}"
        )
    try:
        ys = {t: np.asarray(v, dtype=float).ravel() for t, v in targets.items()}
    except (TypeError, ValueError):
        raise TableError("target values must be numeric") from None
    for t, y in ys.items():
        if y.shape[0] != X.shape[0] or not np.isfinite(y).all():
            raise TableError(f"target {t}: need {X.shape[0]} finite values")
    scales = {t: float(np.std(model.regressors[t].y_train_) or 1.0) for t in ys}
    inner = model.feature_map
    lam_scale = float(np.std(X[:, 0]) or np.mean(X[:, 0]) or 1.0)
    omega_scale = float(np.std(X[:, 1]) or np.mean(X[:, 1]) or 1.0)
    identity = np.array([1.0, 0.0, 1.0, 0.0])
    units = np.array([1.0, lam_scale, 1.0, omega_scale])
    prior_weight = np.sqrt(identity_weight)

    def residuals(theta: np.ndarray) -> np.ndarray:
        Xm = inner.apply(FeatureMap(tuple(theta[:2]), tuple(theta[2:])).apply(X))
        parts = [(model.regressors[t].predict(Xm) - y) / scales[t] for t, y in ys.items()]
        parts.append(prior_weight * (theta - identity) / units)
        return np.concatenate(parts)

    def mae(fmap: FeatureMap) -> dict[str, float]:
        Xm = inner.apply(fmap.apply(X))
        return {
            t: float(np.mean(np.abs(model.regressors[t].predict(Xm) - y))) for t, y in ys.items()
        }

    def cost(r: np.ndarray) -> float:  # soft-L1, as least_squares minimises it
        return float(np.sum(2.0 * f_scale**2 * (np.sqrt(1.0 + (r / f_scale) ** 2) - 1.0)))

    # A new container can sit far from A in (λ, ω), where model A is flat (a GPR
    # reverts to its mean away from its data) and a start at the identity stalls:
    # refine the best few of a grid of starts.
    starts = [identity] + [
        np.array([a1, 0.0, b1, 0.0])
        for a1 in START_ALPHA1
        for b1 in START_BETA1
        if (a1, b1) != (1.0, 1.0)
    ]
    with single_threaded_blas():
        ranked = sorted(starts, key=lambda theta: cost(residuals(theta)))[:N_REFINED_STARTS]
        fits = [
            least_squares(
                residuals, start, loss="soft_l1", f_scale=f_scale, x_scale=units, method="trf"
            )
            for start in ranked
        ]
    theta = min(fits, key=lambda fit: fit.cost).x
    new_map = FeatureMap((float(theta[0]), float(theta[1])), (float(theta[2]), float(theta[3])))
    transferred = PropertyModel(
        regressors=model.regressors,
        feature_map=inner.then(new_map),
        domain=model.domain,
        calibration=model.calibration,  # the source container's: not re-measured here
    )
    transferred.extraction_settings = model.extraction_settings
    return TransferResult(
        model=transferred,
        feature_map=new_map,
        n_points=int(X.shape[0]),
        mae_before=mae(FeatureMap()),
        mae_after=mae(new_map),
    )
