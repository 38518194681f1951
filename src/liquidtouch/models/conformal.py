"""Calibrated predictive intervals: cross-conformal scores normalised by the model's std.

A GP's predictive std is a model's opinion of its error; on real feature tables it
is too small in one place and too large in another (height ±1σ coverage 50 % on
one benchmark, 82-92 % on others). :func:`calibrate_regressor` measures it on the
training rows themselves: K-fold cross-conformal (K = n is the jackknife),
with the **normalised conformity score** ``|y − ŷ| / σ̂`` of every row predicted by
a model that did not see it (MAPIE's ``CrossConformalRegressor`` with
``StdConformityScore``, the "J+GP" score; ``method="base"``: the interval is
built round the full model's prediction). Normalising by the GP's std makes the
interval wider where the data are thin and narrower where they are dense.

The sorted scores are kept (:class:`TargetCalibration`, stored in the model file),
so any level can be answered afterwards:

- ``std_scale`` s = the conformal 68.27 % quantile of the scores: the calibrated
  std is ``s · ρ · σ̂`` (±1 calibrated std covers 68 % of held-out rows);
- rows that share a group (``groups``) are held out together, so a row is never
  predicted by a model that saw its twins. Which rows are twins depends on the
  design (:func:`default_groups`). For height, every liquid at one fill height is a
  twin of a sparse design (the height is read from ω, nearly the same for every
  liquid at one height): held out one trial at a time, 3-4 heights per liquid (or 6
  with repeats) look far better than they are (``benchmarks/learning_curve.py``:
  height RMS z 3.8-42), so the fill height is held out whole. On a dense design (≥
  :data:`DENSE_HEIGHTS` heights per liquid) that errs the other way: the held-out
  rows lie two grid steps from the nearest training height, a new trial within half
  a step (simulated video benchmark, 8 heights: out-of-fold height error 2.0-2.7 mm
  per liquid against 0.4-0.6 mm on new trials; learning curve 9 × 1-3: RMS z 0.84-1.17
  by height, 0.99-1.08 by trial), so only a trial's repeats are held out together;
- the model's std is not equally wrong everywhere (one GP noise level for every
  liquid): a local factor ρ(λ, ω) learnt from the out-of-fold scores
  (:mod:`liquidtouch.models.local_scale`, chosen by cross-validation) widens it
  where the held-out rows erred more, and the scores are taken in units of σ̂ ρ;
- a level-α interval is ``ŷ ± q_α · ρ · σ̂``, q_α = the ⌈(n + 1) α⌉-th smallest score
  (finite-sample marginal coverage ≥ α for exchangeable rows, for the split
  version; cross-conformal "base" is the usual close approximation). With n rows
  the largest level that has a finite q is n / (n + 1): a 90 % interval needs 9
  rows, 95 % 19, 99 % 99 (:func:`min_rows_for_level`); a smaller set is refused.

When the features themselves are uncertain, the propagated variance σ_fit²
(:mod:`liquidtouch.models.propagation`) is part of the std the model predicts with.
Given the training rows' own fit std (``X_std``, the ``*_std`` columns of a features
table), the scores are normalised by that same total, ``|y − ŷ| / √(σ̂² + σ_fit²)``
(``normalised_by="total-std"``), each held-out row's fit std propagated through the
fold model that predicts it, and a new row's std is ``s · ρ · √(σ̂² + σ_fit²)``: the
final fit's scatter is then counted once, in proportion to each row's own fit std
(scores of σ̂ alone already hold the training fits' scatter, and adding a new fit's
σ_fit on top counted it twice: ``benchmarks/RESULTS.md``, calibration). Without it
(``"model-std"``, model files before version 6) the std is ``√((s ρ σ̂)² + σ_fit²)``.
The interval is ``ŷ ± (q_α / s) · σ_total``: q_α in calibrated stds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin, clone
from sklearn.model_selection import GroupKFold, KFold, PredefinedSplit
from sklearn.utils.validation import has_fit_parameter

from liquidtouch.errors import TableError
from liquidtouch.models.local_scale import LocalScale, fit_local_scale
from liquidtouch.models.propagation import clean_feature_std, propagated_variance

__all__ = [
    "DEFAULT_FOLDS",
    "DENSE_HEIGHTS",
    "NORMALISED_BY",
    "ONE_SIGMA_LEVEL",
    "TRIAL_COLUMNS",
    "TargetCalibration",
    "TotalStdRegressor",
    "calibrate_regressor",
    "calibration_folds",
    "default_groups",
    "feature_std_param",
    "min_rows_for_level",
]

#: folds of the cross-conformal calibration (fewer rows than folds: leave-one-out)
DEFAULT_FOLDS = 10
#: coverage of ±1 std of a Gaussian: the level the calibrated std is set to
ONE_SIGMA_LEVEL = math.erf(1 / math.sqrt(2))
#: calibration methods a model file may name
METHODS = ("cross-conformal",)
#: what the scores are normalised by: the model's std σ̂, or the total std √(σ̂² + σ_fit²)
#: with the row's fit std propagated (module docstring)
NORMALISED_BY = ("model-std", "total-std")
#: label columns that say under which conditions a trial was recorded (its repeats share them)
TRIAL_COLUMNS = ("liquid", "container", "height_mm", "sugar_concentration")
#: fill heights per liquid from which a design is dense: a trial's repeats are held out
#: together, not its whole fill height (module docstring; the README asks for 8-9)
DENSE_HEIGHTS = 8


def default_groups(table: Any) -> np.ndarray | None:
    """The calibration groups of a training table (module docstring): ``height_mm``'s
    values, or — with at least :data:`DENSE_HEIGHTS` distinct heights per liquid (median
    over the liquids) — one group per set of equal :data:`TRIAL_COLUMNS` values (a
    trial's repeats; an empty cell counts as a value). ``None`` (every row alone)
    without a ``height_mm`` column.
    """
    if "height_mm" not in table.columns:
        return None
    heights = table["height_mm"].astype(str)
    if "liquid" in table.columns:
        per_liquid = heights.groupby(table["liquid"].astype(str)).nunique()
        dense = float(per_liquid.median()) >= DENSE_HEIGHTS
    else:
        dense = heights.nunique() >= DENSE_HEIGHTS
    if not dense:
        return heights.to_numpy()
    columns = [c for c in TRIAL_COLUMNS if c in table.columns]
    keys = table[columns].astype(object).where(table[columns].notna(), "").astype(str)
    return keys.agg("|".join, axis=1).to_numpy()


def min_rows_for_level(level: float) -> int:
    """Fewest calibration rows n with ⌈(n + 1) · level⌉ ≤ n (a finite level-``level`` quantile)."""
    level = float(level)
    if not 0 < level < 1:
        raise TableError(f"the interval level must be a number in (0, 1), e.g. 0.9; got {level}")
    n = max(math.ceil(level / (1 - level) - 1e-9), 1)
    while math.ceil((n + 1) * level - 1e-9) > n:
        n += 1
    return n


@dataclass(frozen=True)
class TargetCalibration:
    """The cross-conformal calibration of one target (dimensionless scores).

    ``scores``: the sorted out-of-fold normalised scores ``|y − ŷ| / (σ̂ ρ)`` (σ̂ the total
    std √(σ̂² + σ_fit²) when ``normalised_by="total-std"``), one per training row;
    ``n_folds``: K; ``random_state``: the fold shuffle's seed; ``local``: the local
    factor ρ on the model's std (:mod:`~liquidtouch.models.local_scale`;
    ``None``: ρ = 1, one scale everywhere); ``normalised_by``: one of
    :data:`NORMALISED_BY` (module docstring).
    """

    scores: tuple[float, ...]
    n_folds: int
    random_state: int = 0
    method: str = "cross-conformal"
    local: LocalScale | None = None
    normalised_by: str = "model-std"

    def __post_init__(self) -> None:
        s = np.asarray(self.scores, dtype=float)
        if s.ndim != 1 or s.size < 2 or not np.all(np.isfinite(s)) or np.any(s < 0):
            raise TableError("a calibration needs at least 2 finite scores >= 0")
        if self.method not in METHODS:
            raise TableError(f"unknown calibration method {self.method!r}")
        if self.normalised_by not in NORMALISED_BY:
            raise TableError(f"unknown score normalisation {self.normalised_by!r}")
        object.__setattr__(self, "scores", tuple(float(v) for v in np.sort(s)))

    @property
    def n(self) -> int:
        """Calibration rows."""
        return len(self.scores)

    def quantile(self, level: float) -> float:
        """q_α: the ⌈(n + 1) α⌉-th smallest score (in model stds σ̂).

        Raises :class:`TableError` when the calibration has too few rows for ``level``.
        """
        need = min_rows_for_level(level)
        if self.n < need:
            raise TableError(
                f"a {100 * float(level):g} % interval needs a model calibrated on at least "
                f"{need} training rows; this one has {self.n} (train on at least {need} rows, "
                f"or ask for --level {self.n / (self.n + 1):.3g} or lower)"
            )
        k = math.ceil((self.n + 1) * float(level) - 1e-9)
        if k < 1:  # below 1/(n + 1) no score is the quantile (index 0 would read the last)
            raise TableError(
                f"a {100 * float(level):g} % interval is below what a calibration on {self.n} "
                f"rows resolves: ask for --level {1 / (self.n + 1):.3g} or higher"
            )
        return self.scores[k - 1]

    @property
    def std_scale(self) -> float:
        """s: the calibrated std is ``s · σ̂`` (the 68.27 % conformal quantile; > 0)."""
        return max(self.quantile(ONE_SIGMA_LEVEL), 1e-12)

    def local_factor(self, X: Any) -> np.ndarray:
        """ρ (n,) at the (n, 2) features ``X`` (λ [1/s], ω [rad/s]): ones without a local scale."""
        if self.local is None:
            return np.ones(np.asarray(X).shape[0])
        return self.local.factor(X)

    def half_width(self, level: float) -> float:
        """Half-width of the level-``level`` interval in calibrated stds (q_α / s)."""
        return self.quantile(level) / self.std_scale

    def coverage_of(self, k: float) -> float:
        """Share of calibration rows within ±k calibrated stds (in-sample check)."""
        return float(np.mean(np.asarray(self.scores) <= float(k) * self.std_scale))

    def to_state(self) -> dict[str, Any]:
        """Plain-data state (model file)."""
        state = {
            "method": self.method,
            "n_folds": int(self.n_folds),
            "random_state": int(self.random_state),
            "scores": list(self.scores),
        }
        if self.local is not None:
            state["local"] = self.local.to_state()
        if self.normalised_by != "model-std":
            state["normalised_by"] = self.normalised_by
        return state

    @classmethod
    def from_state(cls, state: dict[str, Any]) -> TargetCalibration:
        """Rebuild from :meth:`to_state`."""
        return cls(
            scores=tuple(state["scores"]),
            n_folds=int(state["n_folds"]),
            random_state=int(state.get("random_state", 0)),
            method=state.get("method", "cross-conformal"),
            local=None if state.get("local") is None else LocalScale.from_state(state["local"]),
            normalised_by=state.get("normalised_by", "model-std"),
        )


def calibration_folds(
    n_rows: int, n_folds: int = DEFAULT_FOLDS, groups: Any = None, random_state: int = 0
) -> list[tuple[np.ndarray, np.ndarray]]:
    """The (train, held-out) row indices of the calibration: K = min(``n_folds``, groups) folds.

    ``groups`` (n,): rows of one group are held out together (GroupKFold, shuffled);
    ``None``: every row its own group (KFold, shuffled).
    """
    if isinstance(n_folds, bool) or not isinstance(n_folds, int) or n_folds < 2:
        raise TableError(f"n_folds must be an integer >= 2; got {n_folds!r}")
    index = np.arange(int(n_rows))
    if groups is None:
        k = min(n_folds, int(n_rows))
        if k < 2:
            raise TableError(f"a calibration needs at least 2 training rows; got {n_rows}")
        return list(KFold(k, shuffle=True, random_state=random_state).split(index))
    groups = np.asarray(groups)
    if groups.shape != (int(n_rows),):
        raise TableError(f"calibration groups: {groups.shape[0]} values for {n_rows} rows")
    k = min(n_folds, len(np.unique(groups)))
    if k < 2:
        raise TableError("a grouped calibration needs at least 2 groups (e.g. 2 fill heights)")
    folds = GroupKFold(k, shuffle=True, random_state=random_state)
    return list(folds.split(index, groups=groups))


def feature_std_param(estimator: Any, X_std: Any) -> dict[str, Any]:
    """``{"X_std": X_std}`` for an estimator whose ``fit`` takes the rows' feature std (a GP:
    each row's own noise), else ``{}``; also ``{}`` without a std."""
    if X_std is None or not has_fit_parameter(estimator, "X_std"):
        return {}
    return {"X_std": X_std}


class TotalStdRegressor(RegressorMixin, BaseEstimator):
    """A regressor on (n, 4) rows (λ, ω, σλ, σω) whose std is the total std: the wrapped
    ``estimator``'s std on (λ, ω) and (σλ, σω) propagated through its mean, in quadrature
    (the scores' normaliser of ``normalised_by="total-std"``; module docstring)."""

    def __init__(self, estimator: Any = None) -> None:
        self.estimator = estimator

    def fit(self, X: Any, y: Any) -> TotalStdRegressor:
        """Fit the wrapped estimator on the features ``X[:, :2]`` (and their std ``X[:, 2:]``
        when its ``fit`` takes ``X_std``, as the final model is fitted); return ``self``."""
        X = np.asarray(X, dtype=float)
        options = feature_std_param(self.estimator, X[:, 2:])
        self.estimator_ = clone(self.estimator).fit(X[:, :2], y, **options)
        return self

    def predict(self, X: Any, return_std: bool = False) -> Any:
        """Mean (n,) at ``X[:, :2]``; with ``return_std``, also the total std (n,)."""
        X = np.asarray(X, dtype=float)
        mean, std = self.estimator_.predict(X[:, :2], return_std=True)
        if not return_std:
            return mean
        _, var = propagated_variance(
            lambda rows: {"y": self.estimator_.predict(rows)}, X[:, :2], X[:, 2:]
        )
        return mean, np.hypot(std, np.sqrt(var["y"]))


def calibrate_regressor(
    estimator: Any,
    X: Any,
    y: Any,
    n_folds: int = DEFAULT_FOLDS,
    random_state: int = 0,
    groups: Any = None,
    X_std: Any = None,
) -> TargetCalibration:
    """Cross-conformal calibration of an (unfitted) regressor with ``predict(X, return_std=True)``.

    ``X`` (n, d) features, ``y`` (n,) one target. K = min(``n_folds``, n) shuffled
    folds; each fold is predicted by a clone fitted on the others (MAPIE's
    ``CrossConformalRegressor``, ``StdConformityScore``). Costs K fits of the estimator.
    ``groups`` (n,): rows of one group (e.g. one fill height) are held out together,
    so a row is predicted by a model that has not seen its group — as a new trial at
    a new height is. Repeated grid values otherwise make K-fold optimistic: a held-out
    row's twins stay in training (synthetic, 5 liquids × 3 heights × 2 trials: height
    ±1σ coverage 12 % with KFold). ``X_std`` (n, 2): the rows' own fit std of (λ, ω);
    the scores are then normalised by the total std (``normalised_by="total-std"``).
    """
    from mapie.conformity_scores import StdConformityScore
    from mapie.regression import CrossConformalRegressor

    X = np.asarray(X, dtype=float)
    y = np.asarray(y, dtype=float)
    normalised_by = "model-std" if X_std is None else "total-std"
    features = X
    if X_std is not None:
        features = np.column_stack([X, clean_feature_std(X_std, X.shape[0])])
        estimator = TotalStdRegressor(estimator)
    folds = calibration_folds(X.shape[0], n_folds, groups, random_state)
    test_fold = np.empty(X.shape[0], dtype=int)
    for i, (_, held_out) in enumerate(folds):
        test_fold[held_out] = i
    mapie = CrossConformalRegressor(
        clone(estimator),
        conformity_score=StdConformityScore(),
        method="base",
        cv=PredefinedSplit(test_fold),
    )
    mapie.fit_conformalize(features, y)
    scores = np.abs(np.asarray(mapie.conformity_scores, dtype=float))
    local, rho = fit_local_scale(X, scores, groups)
    return TargetCalibration(
        tuple((scores / rho).tolist()),
        n_folds=len(folds),
        random_state=random_state,
        local=local,
        normalised_by=normalised_by,
    )
