"""The (λ [1/s], ω [rad/s]) feature space of a model: its transfer map and training domain.

:class:`FeatureMap` is the container-transfer map applied to (λ, ω) before the
trained estimators (:mod:`liquidtouch.models.transfer`); :class:`TrainingDomain`
is the (λ, ω) box a model was trained on, outside which its predictions are
extrapolations.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from liquidtouch._core.checks import check_positive
from liquidtouch.errors import TableError
from liquidtouch.models.validation import check_features

#: Widening of the training domain on each side, as a fraction of the training span
#: (test points of a grid experiment lie a little beyond the training extremes).
DOMAIN_MARGIN = 0.1


@dataclass(frozen=True)
class FeatureMap:
    """Affine per-feature map ``(λ, ω) → (α1 λ + α2, β1 ω + β2)``; identity by default."""

    alpha: tuple[float, float] = (1.0, 0.0)
    beta: tuple[float, float] = (1.0, 0.0)

    def __post_init__(self) -> None:
        for name in ("alpha", "beta"):
            pair = np.asarray(getattr(self, name), dtype=float)
            if pair.shape != (2,) or not np.isfinite(pair).all():
                raise TableError(f"FeatureMap.{name} must be two finite numbers; got {pair!r}")

    def apply(self, X: Any) -> np.ndarray:
        """Map an (n, 2) array of (λ, ω)."""
        X = check_features(X)
        return np.column_stack(
            [self.alpha[0] * X[:, 0] + self.alpha[1], self.beta[0] * X[:, 1] + self.beta[1]]
        )

    def then(self, inner: FeatureMap) -> FeatureMap:
        """The map ``x → self.apply(inner.apply(x))``."""
        if not isinstance(inner, FeatureMap):
            raise TableError(f"can only compose with a FeatureMap; got {type(inner).__name__}")
        a1, a2 = self.alpha
        b1, b2 = self.beta
        return FeatureMap(
            (a1 * inner.alpha[0], a1 * inner.alpha[1] + a2),
            (b1 * inner.beta[0], b1 * inner.beta[1] + b2),
        )

    @property
    def is_identity(self) -> bool:
        return self.alpha == (1.0, 0.0) and self.beta == (1.0, 0.0)


@dataclass(frozen=True)
class TrainingDomain:
    """The (λ, ω) box a model was trained on, widened by ``margin`` × span on each side.

    ``low`` and ``high`` are the per-feature minimum and maximum of the training
    features (λ [1/s], ω [rad/s]) in the estimators' coordinates, i.e. after a
    model's :class:`FeatureMap`.
    """

    low: tuple[float, float]
    high: tuple[float, float]
    margin: float = DOMAIN_MARGIN

    def __post_init__(self) -> None:
        low = np.asarray(self.low, dtype=float)
        high = np.asarray(self.high, dtype=float)
        if low.shape != (2,) or high.shape != (2,) or not np.isfinite([*low, *high]).all():
            raise TableError("TrainingDomain.low and .high must be two finite numbers each")
        if (low > high).any():
            raise TableError(f"TrainingDomain: low {low.tolist()} exceeds high {high.tolist()}")
        check_positive(self.margin, "TrainingDomain.margin", allow_zero=True)

    @classmethod
    def of(cls, feature_arrays: Iterable[Any], margin: float = DOMAIN_MARGIN) -> TrainingDomain:
        """The domain of one or more (n, 2) training feature arrays."""
        X = np.concatenate([check_features(x) for x in feature_arrays])
        low, high = X.min(axis=0), X.max(axis=0)
        return cls((float(low[0]), float(low[1])), (float(high[0]), float(high[1])), margin)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The accepted box ``(lower, upper)``, margin included, each (λ, ω)."""
        low, high = np.asarray(self.low, dtype=float), np.asarray(self.high, dtype=float)
        span = high - low
        return low - self.margin * span, high + self.margin * span

    def contains(self, X: Any) -> np.ndarray:
        """Boolean (n,): which rows of the (n, 2) features ``X`` lie inside :meth:`bounds`."""
        X = check_features(X)
        lower, upper = self.bounds()
        return ((X >= lower) & (X <= upper)).all(axis=1)


def input_interval(lower: float, upper: float, scale: float, shift: float) -> tuple[float, float]:
    """The inputs x with ``scale · x + shift`` in [lower, upper]."""
    if scale == 0:
        return (-np.inf, np.inf) if lower <= shift <= upper else (np.nan, np.nan)
    ends = sorted(((lower - shift) / scale, (upper - shift) / scale))
    return float(ends[0]), float(ends[1])
