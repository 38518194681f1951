"""Several ring-downs of one bottle, one (λ, ω): combined by their ±, their agreement checked.

Each push of the same bottle gives a ring-down and its fit's (λ, ω) with std. They
estimate the same small-amplitude slow mode, so :func:`combine_ring_downs` takes the
inverse-variance weighted mean of each feature and the std ``1/sqrt(Σ 1/σᵢ²)`` — but
only as far as they agree:

- **Consistency**: ``χ² = Σ (xᵢ − x̄)²/σᵢ²`` with ``n − 1`` degrees of freedom, per
  feature. Beyond its :data:`CONSISTENCY_LEVEL` quantile the ring-downs disagree beyond
  their ±: the combination says so (``consistent`` false, the ring-downs whose
  standardised residual is largest named in ``outliers``) and its std is widened by the
  Birge ratio ``sqrt(χ²/(n − 1))`` — the spread the ring-downs show, not the ± they
  claimed. Nothing is dropped: the caller reports the disagreement.
- **Floor**: repeating a push of the same kind does not average away what every such
  push shares (the fit's systematic error). The combined std is never below
  :data:`~liquidtouch.models.reach.FIT_FLOOR` × the value (:mod:`liquidtouch.models.reach`)
  — for one ring-down too, so that adding a push never widens the answer's ±.

One implementation for ``run-trial --max-pushes``, ``live`` (the ring-downs of one
stream) and the Python API (``liquidtouch.combine_ring_downs``).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.stats import chi2

from liquidtouch.errors import SignalError
from liquidtouch.io.tables import FEATURE_COLUMNS
from liquidtouch.models.reach import FIT_FLOOR

__all__ = ["CONSISTENCY_LEVEL", "CombinedRingDowns", "RingDownEstimate", "combine_ring_downs"]

#: χ² quantile beyond which ring-downs are called inconsistent (a 1 % false alarm per
#: feature when they do agree: rare enough not to cry wolf on every trial)
CONSISTENCY_LEVEL = 0.99
#: a ring-down estimate's keys: each feature and its std
_KEYS = tuple(k for name in FEATURE_COLUMNS for k in (name, f"{name}_std"))


@dataclass(frozen=True)
class RingDownEstimate:
    """One ring-down's fit: λ [1/s], ω [rad/s] and their std (the fit's ±)."""

    decay_rate: float
    decay_rate_std: float
    angular_frequency: float
    angular_frequency_std: float

    @classmethod
    def of(cls, values: Mapping[str, object]) -> RingDownEstimate:
        """From a mapping with the four keys (a ring-down summary, a fit's dict, a row)."""
        try:
            return cls(*(float(values[k]) for k in _KEYS))  # type: ignore[arg-type]
        except (KeyError, TypeError, ValueError):
            raise SignalError(f"a ring-down estimate needs {', '.join(_KEYS)} as numbers") from None


@dataclass(frozen=True)
class CombinedRingDowns:
    """The combination of ``n`` ring-downs (module docstring).

    ``decay_rate``/``angular_frequency`` and their ``_std`` are the combined features;
    ``chi2`` per feature; ``consistent`` whether every feature's χ² is below its
    :data:`CONSISTENCY_LEVEL` quantile; ``outliers`` the indices (into the input) of the
    ring-downs that disagree most (empty when consistent); ``used`` the indices combined
    (ring-downs without a finite value and std are left out and not counted).
    """

    decay_rate: float
    decay_rate_std: float
    angular_frequency: float
    angular_frequency_std: float
    n: int
    chi2: dict[str, float] = field(default_factory=dict)
    consistent: bool = True
    outliers: tuple[int, ...] = ()
    used: tuple[int, ...] = ()

    def features(self) -> tuple[np.ndarray, np.ndarray]:
        """``(X, X_std)`` as (1, 2) arrays, the property model's input."""
        return (
            np.array([[self.decay_rate, self.angular_frequency]]),
            np.array([[self.decay_rate_std, self.angular_frequency_std]]),
        )

    def message(self) -> str:
        """One line for the user: how many ring-downs, and whether they agree."""
        if self.n <= 1:
            return f"{self.n} ring-down"
        if self.consistent:
            return f"{self.n} ring-downs combined, consistent"
        worst = ", ".join(str(i + 1) for i in self.outliers)
        return (
            f"{self.n} ring-downs disagree beyond their ± (χ²/dof "
            + ", ".join(f"{k} {v / (self.n - 1):.1f}" for k, v in self.chi2.items())
            + f"; most off: push {worst}); the ± is widened to their spread"
        )

    def to_dict(self) -> dict[str, object]:
        """JSON-ready."""
        return {
            "decay_rate": self.decay_rate,
            "decay_rate_std": self.decay_rate_std,
            "angular_frequency": self.angular_frequency,
            "angular_frequency_std": self.angular_frequency_std,
            "ring_downs": self.n,
            "chi2": dict(self.chi2),
            "consistent": self.consistent,
            "outliers": list(self.outliers),
            "used": list(self.used),
            "message": self.message(),
        }


def _usable(e: RingDownEstimate) -> bool:
    values = (e.decay_rate, e.decay_rate_std, e.angular_frequency, e.angular_frequency_std)
    return all(math.isfinite(v) for v in values) and e.decay_rate_std > 0 < e.angular_frequency_std


def combine_ring_downs(
    estimates: Iterable[RingDownEstimate | Mapping[str, object]],
) -> CombinedRingDowns:
    """Combine ring-down estimates of one bottle (module docstring: weights, check, floor).

    ``estimates``: :class:`RingDownEstimate` or mappings with ``decay_rate``,
    ``decay_rate_std``, ``angular_frequency``, ``angular_frequency_std``. Those without a
    finite value and a finite std > 0 are left out (``used`` lists the rest). Raises
    :class:`~liquidtouch.errors.SignalError` when none is usable.
    """
    items = [e if isinstance(e, RingDownEstimate) else RingDownEstimate.of(e) for e in estimates]
    used = tuple(i for i, e in enumerate(items) if _usable(e))
    if not used:
        raise SignalError(
            "no ring-down to combine: none has a finite λ, ω and std (was the bottle pushed?)"
        )
    rows = [items[i] for i in used]
    out: dict[str, tuple[float, float]] = {}
    chi: dict[str, float] = {}
    residuals = np.zeros(len(rows))
    dof = len(rows) - 1
    limit = float(chi2.ppf(CONSISTENCY_LEVEL, dof)) if dof else math.inf
    for name, floor in zip(FEATURE_COLUMNS, FIT_FLOOR, strict=True):
        x, s = _column(rows, name)
        mean, std, stat = _weighted(x, s)
        chi[name] = stat
        residuals = np.maximum(residuals, np.abs(x - mean) / s)
        if stat > limit:  # disagree: the spread they show, not the ± they claim (dof ≥ 1)
            std *= math.sqrt(stat / dof)
        out[name] = (mean, max(std, floor * abs(mean)))
    consistent = all(v <= limit for v in chi.values())
    outliers: tuple[int, ...] = ()
    if not consistent:
        order = np.argsort(-residuals)
        outliers = tuple(used[int(j)] for j in order[: max(1, dof // 2)])
    return CombinedRingDowns(
        out["decay_rate"][0], out["decay_rate"][1],
        out["angular_frequency"][0], out["angular_frequency"][1],
        n=len(rows), chi2=chi, consistent=consistent, outliers=outliers, used=used,
    )  # fmt: skip


def _column(rows: Sequence[RingDownEstimate], name: str) -> tuple[np.ndarray, np.ndarray]:
    x = np.array([getattr(r, name) for r in rows])
    s = np.array([getattr(r, f"{name}_std") for r in rows])
    return x, s


def _weighted(x: np.ndarray, s: np.ndarray) -> tuple[float, float, float]:
    """Inverse-variance mean, its std and the χ² of the values about it."""
    w = 1.0 / (s * s)
    mean = float(np.sum(w * x) / np.sum(w))
    return mean, float(1.0 / math.sqrt(np.sum(w))), float(np.sum(w * (x - mean) ** 2))
