"""A trained property model: one regressor per label column, or a liquid classifier.

:class:`PropertyModel` is what ``liquidtouch train`` / ``classify`` /
``transfer`` write and ``predict`` reads (see :mod:`liquidtouch.models.modelfile`).
It may carry a container-transfer :class:`FeatureMap` applied to (λ, ω)
before the trained estimators (:mod:`liquidtouch.models.transfer`), and knows
its :class:`TrainingDomain`: :meth:`PropertyModel.in_domain` tells which inputs
lie outside the (λ, ω) box it was trained on, where its predictions are
extrapolations (a quadratic diverges, a GP reverts to its prior mean, the SVM
picks a class at random with confidence).
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import Any

import numpy as np
import pandas as pd

from liquidtouch.errors import TableError
from liquidtouch.io.tables import FEATURE_COLUMNS, feature_matrix
from liquidtouch.models.classifier import UNKNOWN, LiquidClassifier
from liquidtouch.models.conformal import (
    TargetCalibration,
)
from liquidtouch.models.feature_space import (
    FeatureMap,
    TrainingDomain,
    input_interval,
)
from liquidtouch.models.physics_prior import PhysicsGPRegressor
from liquidtouch.models.predictions import PROBABILITY_PREFIX
from liquidtouch.models.propagation import clean_feature_std, propagated_variance
from liquidtouch.models.quadratic import QuadraticRegressor
from liquidtouch.models.reach import FIT_FLOOR, Reach, reach_of
from liquidtouch.models.regressors import GPRegressor
from liquidtouch.models.validation import check_features

__all__ = [
    "MODEL_KINDS",
    "REGRESSORS",
    "STD_COLUMNS",
    "PropertyModel",
    "feature_std_matrix",
]

#: The regressor kinds, by the name used on the command line and in model files:
#: the paper's GP, the paper's 6-parameter quadratic, our physics-informed GP.
MODEL_KINDS: tuple[str, ...] = ("gpr", "quadratic", "physics-gpr")
REGRESSORS: dict[str, type] = dict(
    zip(MODEL_KINDS, (GPRegressor, QuadraticRegressor, PhysicsGPRegressor), strict=True)
)

#: the features' std columns of a feature table (the fit's standard errors), propagated
STD_COLUMNS: tuple[str, str] = ("decay_rate_std", "angular_frequency_std")


def feature_std_matrix(table: pd.DataFrame) -> np.ndarray | None:
    """(n, 2) std of (λ [1/s], ω [rad/s]) from a table's :data:`STD_COLUMNS` (an empty or
    non-numeric cell is NaN: unknown); ``None`` when the table has no such columns."""
    if not all(c in table.columns for c in STD_COLUMNS):
        return None
    return table[list(STD_COLUMNS)].apply(pd.to_numeric, errors="coerce").to_numpy(float)


class PropertyModel:
    """Regressors (one per target column) or a classifier, plus an optional feature map.

    The project's multi-target model (not a scikit-learn estimator): a dict of
    fitted single-target estimators, each trained on the two features
    ``FEATURE_COLUMNS`` (λ [1/s], ω [rad/s]). :meth:`predict` returns
    ``{target: (mean, std)}``.

    ``calibration`` maps targets to their cross-conformal
    :class:`~liquidtouch.models.conformal.TargetCalibration` (``train`` adds it):
    the predicted std is then calibrated (``s · σ̂``), and :meth:`predict_interval`
    answers any level. Without it the std is the estimator's own (not calibrated).
    The fit's (λ, ω) std given to :meth:`predict` is propagated through the model
    (:mod:`liquidtouch.models.propagation`) and its variance added.

    ``domain`` is the :class:`TrainingDomain`; by default the box of the
    estimators' training features (``X_train_``) with :data:`DOMAIN_MARGIN`, or
    ``None`` (no check) if an estimator does not expose its training features.

    :meth:`get_params` / :meth:`set_params` read and replace the constructor
    arguments in the scikit-learn style (``PropertyModel(**m.get_params())`` is
    an equivalent model). Its repr is one line: kind, targets, estimator kind,
    training rows and the accepted (λ, ω) domain.
    """

    #: the constructor's parameters, in its order (what :meth:`get_params` returns)
    _PARAMS = ("regressors", "classifier", "label", "feature_map", "domain", "calibration")

    def __init__(
        self,
        regressors: Mapping[str, Any] | None = None,
        classifier: LiquidClassifier | None = None,
        label: str | None = None,
        feature_map: FeatureMap | None = None,
        domain: TrainingDomain | None = None,
        calibration: Mapping[str, TargetCalibration] | None = None,
    ) -> None:
        if bool(regressors) == (classifier is not None):
            raise TableError("a PropertyModel holds either regressors or a classifier")
        if feature_map is not None and not isinstance(feature_map, FeatureMap):
            raise TableError(f"feature_map must be a FeatureMap; got {type(feature_map).__name__}")
        if domain is not None and not isinstance(domain, TrainingDomain):
            raise TableError(f"domain must be a TrainingDomain; got {type(domain).__name__}")
        estimators = dict(regressors or {})
        if classifier is not None:
            estimators[label or "liquid"] = classifier
        for target, estimator in estimators.items():
            if getattr(estimator, "n_features_in_", None) != len(FEATURE_COLUMNS):
                raise TableError(
                    f"the estimator for {target!r} must be fitted on the "
                    f"{len(FEATURE_COLUMNS)} features ({', '.join(FEATURE_COLUMNS)})"
                )
        calibration = dict(calibration or {})
        for target, cal in calibration.items():
            if target not in (regressors or {}) or not isinstance(cal, TargetCalibration):
                raise TableError(
                    f"calibration of {target!r}: a TargetCalibration of one of the regressors' "
                    "targets is needed"
                )
        self.calibration = calibration
        self.regressors = dict(regressors or {})
        self.classifier = classifier
        self.label = label
        self.feature_map = feature_map or FeatureMap()
        if domain is None and all(hasattr(e, "X_train_") for e in estimators.values()):
            domain = TrainingDomain.of(e.X_train_ for e in estimators.values())
        self.domain = domain
        #: what made the model (versions, training-table hash), set by ``load_model``
        self.provenance: dict[str, str] | None = None
        #: the settings its training features were extracted with (``train`` sets them
        #: from the table; :mod:`liquidtouch.models.extraction_match`); None: not known
        self.extraction_settings: dict[str, Any] | None = None

    def get_params(self, deep: bool = True) -> dict[str, Any]:
        """The constructor arguments: ``regressors``, ``classifier``, ``label``, ``feature_map``,
        ``domain`` (the one in use: the default is the training features' box).

        ``deep`` is accepted for scikit-learn compatibility; the fitted estimators
        are returned as they are, not expanded into ``classifier__C`` etc. (changing
        their hyperparameters would not refit them). The ``regressors`` dict is a copy.
        """
        return {
            "regressors": dict(self.regressors),
            "classifier": self.classifier,
            "label": self.label,
            "feature_map": self.feature_map,
            "domain": self.domain,
            "calibration": dict(self.calibration),
        }

    def set_params(self, **params: Any) -> PropertyModel:
        """Replace constructor arguments (checked as the constructor checks them); ``self``.

        Raises :class:`TableError` for an unknown parameter or an invalid combination.
        The :attr:`provenance` and :attr:`extraction_settings` are kept.
        """
        unknown = sorted(set(params) - set(self._PARAMS))
        if unknown:
            raise TableError(
                f"PropertyModel has no parameter {', '.join(map(repr, unknown))}; "
                f"its parameters: {', '.join(self._PARAMS)}"
            )
        merged = {**self.get_params(), **params}
        kept = {"provenance": self.provenance, "extraction_settings": self.extraction_settings}
        fresh = PropertyModel(**merged)  # validate before changing anything
        self.__dict__.update({**fresh.__dict__, **kept})
        return self

    def __repr__(self) -> str:
        estimators = list(self.regressors.values()) or [self.classifier]
        names = {kind: name for name, kind in REGRESSORS.items()}
        names[LiquidClassifier] = "svm"
        kinds = sorted({names.get(type(e), type(e).__name__) for e in estimators})
        rows = sorted({int(np.shape(getattr(e, "X_train_", ()))[0]) for e in estimators})
        row_text = str(rows[0]) if len(rows) == 1 else f"{rows[0]}–{rows[-1]}"
        transfer = "" if self.feature_map.is_identity else ", container transfer"
        return (
            f"PropertyModel({self.kind}, targets={self.targets!r}, model={'+'.join(kinds)!r}, "
            f"{row_text} training rows, {self.describe_domain()}{transfer})"
        )

    @property
    def kind(self) -> str:
        """``"regression"`` or ``"classification"``."""
        return "classification" if self.classifier is not None else "regression"

    @property
    def targets(self) -> list[str]:
        """The predicted columns (target names, or the class label column)."""
        return [self.label or "liquid"] if self.classifier is not None else list(self.regressors)

    def _mapped(self, X: Any) -> np.ndarray:
        return self.feature_map.apply(X)

    def in_domain(self, X: Any) -> np.ndarray:
        """Boolean (n,): which rows of the (n, 2) features ``X`` lie in the training domain.

        ``X`` is mapped by the feature map first (as :meth:`predict` does). All
        ``True`` when the model has no :attr:`domain`.
        """
        Xm = self._mapped(X)
        if self.domain is None:
            return np.ones(Xm.shape[0], dtype=bool)
        return self.domain.contains(Xm)

    def input_domain(self) -> tuple[tuple[float, float], tuple[float, float]] | None:
        """The accepted ``((λ_min, λ_max), (ω_min, ω_max))`` of the inputs, margin included.

        The training domain mapped back through the feature map (λ_min is at least 0);
        ``None`` without a :attr:`domain`.
        """
        if self.domain is None:
            return None
        lower, upper = self.domain.bounds()
        fmap = self.feature_map
        lam = input_interval(lower[0], upper[0], *fmap.alpha)
        omega = input_interval(lower[1], upper[1], *fmap.beta)
        return (max(lam[0], 0.0), lam[1]), omega

    def describe_domain(self) -> str:
        """``"λ in [a, b] 1/s, ω in [c, d] rad/s"`` (see :meth:`input_domain`)."""
        bounds = self.input_domain()
        if bounds is None:
            return "no training domain recorded"
        (a, b), (c, d) = bounds
        return f"λ in [{a:.4g}, {b:.4g}] 1/s, ω in [{c:.4g}, {d:.4g}] rad/s"

    @property
    def calibrated(self) -> bool:
        """Whether every target's std is calibrated (a regression model from ``train``)."""
        return bool(self.regressors) and set(self.calibration) == set(self.regressors)

    def _predict_parts(
        self, X: Any, X_std: Any = None, corr: Any = 0.0
    ) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """``{target: (mean, calibrated model std, propagated fit std)}``."""
        if self.classifier is not None:
            raise TableError("this is a classification model; use predict_proba / predict_table")
        X = check_features(X)
        X_std = clean_feature_std(X_std, X.shape[0])
        Xm = self._mapped(X)
        out = {}
        raw = {t: r.predict(Xm, return_std=True) for t, r in self.regressors.items()}
        if np.any(X_std > 0):

            def means(rows: np.ndarray) -> dict[str, np.ndarray]:
                return {t: r.predict(self._mapped(rows)) for t, r in self.regressors.items()}

            _, fit_var = propagated_variance(means, X, X_std, corr)
        else:
            fit_var = {t: np.zeros(X.shape[0]) for t in self.regressors}
        for t, (mean, std) in raw.items():
            cal = self.calibration.get(t)
            scale = 1.0 if cal is None else cal.std_scale * cal.local_factor(Xm)
            fit_std = np.sqrt(fit_var[t])
            if cal is not None and cal.normalised_by == "total-std":  # scores of the total std
                fit_std = scale * fit_std
            out[t] = (np.asarray(mean), scale * np.asarray(std), fit_std)
        return out

    def predict(
        self, X: Any, X_std: Any = None, corr: Any = 0.0
    ) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """Regression: ``{target: (mean, std)}`` at the (n, 2) features ``X`` (λ [1/s], ω [rad/s]).

        ``X_std``: (n, 2) std of the features (NaN or ``None``: exact), ``corr`` their
        correlation; std² = (calibrated) model variance + propagated feature variance.
        """
        return {
            t: (mean, np.hypot(model_std, fit_std))
            for t, (mean, model_std, fit_std) in self._predict_parts(X, X_std, corr).items()
        }

    def reach(
        self, X: Any, X_std: Any, until_std: Mapping[str, float], pushes: int = 1
    ) -> dict[str, Reach]:
        """``{target: Reach}``: can each target of ``until_std`` reach its std at these features?

        ``X`` (1, 2) are the (λ [1/s], ω [rad/s]) of ``pushes`` combined ring-downs
        (:func:`~liquidtouch.models.combine.combine_ring_downs`), ``X_std`` their std.
        A target whose asked std is below what any number of pushes of this kind gives —
        the model's own std, or the fit's :data:`~liquidtouch.models.reach.FIT_FLOOR`
        through the model's slope — or whose (λ, ω) or predicted value lies outside the
        training range "cannot be told here" (:mod:`liquidtouch.models.reach`).
        ``until_std`` may also name ``decay_rate`` and ``angular_frequency`` (the fit's own
        std, no model part).
        """
        X = check_features(X)[:1]
        X_std = clean_feature_std(X_std, 1)
        floor = np.abs(X) * np.asarray(FIT_FLOOR)
        parts = self._predict_parts(X, X_std) if self.regressors else {}
        floors = self._predict_parts(X, floor) if self.regressors else {}
        inside = bool(self.in_domain(X)[0])
        out = {}
        for target, asked in until_std.items():
            if target in FEATURE_COLUMNS:
                j = FEATURE_COLUMNS.index(target)
                model_std, fit_std, floor_std, known = 0.0, X_std[0, j], floor[0, j], True
            elif target in parts:
                mean, model_std, fit_std = (v[0] for v in parts[target])
                floor_std = floors[target][2][0]
                known = inside and self._trained_on(target, mean, model_std)
            else:
                raise TableError(f"the model does not predict {target!r}; it predicts "
                                 f"{', '.join(self.targets)}")  # fmt: skip
            out[target] = reach_of(
                target, float(asked), model_std=float(model_std), fit_std=float(fit_std),
                floor_std=float(floor_std), pushes=pushes, in_domain=known,
            )  # fmt: skip
        return out

    def _trained_on(self, target: str, value: float, std: float) -> bool:
        """Whether ``value`` lies within the range of ``target`` the model was trained on,
        give or take its own ``std`` (``True`` when the estimator keeps no training targets)."""
        y = getattr(self.regressors[target], "y_train_", None)
        return y is None or bool(np.min(y) - std <= value <= np.max(y) + std)

    def predict_interval(
        self, X: Any, level: float, X_std: Any = None, corr: Any = 0.0
    ) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """``{target: (lower, upper)}``: the calibrated level-``level`` interval (0 < level < 1).

        ``mean ± (q_level / s) · std`` (:mod:`liquidtouch.models.conformal`). Raises
        :class:`TableError` for a model without calibration or calibrated on too few rows.
        """
        if self.classifier is None:
            missing = [t for t in self.regressors if t not in self.calibration]
            if missing:
                raise TableError(
                    f"the model has no interval calibration for {', '.join(missing)} "
                    "(a model file of an older liquidtouch, or trained on too few rows to "
                    "calibrate); retrain it with `liquidtouch train`"
                )
            half = {t: self.calibration[t].half_width(level) for t in self.regressors}
        out = {}
        for t, (mean, std) in self.predict(X, X_std, corr).items():
            out[t] = (mean - half[t] * std, mean + half[t] * std)
        return out

    def predict_proba(self, X: Any) -> tuple[np.ndarray, np.ndarray]:
        """Classification: ``(predicted class, probabilities (n, n_classes))``."""
        if self.classifier is None:
            raise TableError("this is a regression model; use predict / predict_table")
        proba = self.classifier.predict_proba(self._mapped(X))
        return self.classifier.classes_[np.argmax(proba, axis=1)], proba

    def unknown(self, X: Any, X_std: Any = None) -> np.ndarray:
        """Classification: boolean (n,), the rows far from every trained class ("unknown").

        ``X`` (n, 2) is mapped by the feature map first; ``X_std`` (n, 2), the rows' λ
        and ω std (or ``None``), is scaled with it. The rule:
        :mod:`liquidtouch.models.classifier` (Hotelling's T² per class).
        """
        if self.classifier is None:
            raise TableError("this is a regression model; 'unknown' is a classifier's answer")
        Xm = self._mapped(X)
        if X_std is not None:
            scale = np.abs([self.feature_map.alpha[0], self.feature_map.beta[0]])
            X_std = np.asarray(X_std, dtype=float).reshape(Xm.shape) * scale
        return self.classifier.unknown(Xm, X_std)

    def predict_table(self, table: pd.DataFrame, level: float | None = None) -> pd.DataFrame:
        """``table`` plus predicted columns (and their std, or class probabilities).

        The table's :data:`STD_COLUMNS` (the fit's std), when present, are propagated
        into ``predicted_<target>_std``. ``level``: add ``predicted_<target>_lower`` and
        ``_upper``, the calibrated interval (:meth:`predict_interval`).
        A classifier names :data:`~liquidtouch.models.classifier.UNKNOWN` for a row far from
        every trained class (:meth:`unknown`, with the fit's std when present); its
        probabilities are still given.
        """
        X = feature_matrix(table)
        out = table.copy()
        X_std = feature_std_matrix(table)
        if self.classifier is not None:
            predicted, proba = self.predict_proba(X)
            predicted = np.where(self.unknown(X, X_std), UNKNOWN, predicted.astype(object))
            out[f"predicted_{self.targets[0]}"] = predicted
            for j, name in enumerate(self.classifier.classes_):
                out[f"{PROBABILITY_PREFIX}{name}"] = proba[:, j]
            return out
        bounds = {} if level is None else self.predict_interval(X, level, X_std)
        for target, (mean, std) in self.predict(X, X_std).items():
            out[f"predicted_{target}"] = mean
            out[f"predicted_{target}_std"] = std
            if target in bounds:
                out[f"predicted_{target}_lower"] = bounds[target][0]
                out[f"predicted_{target}_upper"] = bounds[target][1]
        return out

    def training_mae(self) -> dict[str, float]:
        """Mean absolute error on the training data (accuracy for a classifier)."""
        if self.classifier is not None:
            clf = self.classifier
            return {"accuracy": float(np.mean(clf.predict(clf.X_train_) == clf.labels_train_))}
        return {
            t: float(np.mean(np.abs(r.predict(r.X_train_) - r.y_train_)))
            for t, r in self.regressors.items()
        }

    def summary(self) -> list[str]:
        """Human-readable lines: per target, training MAE and the fitted model; the
        settings its features were extracted with."""
        lines = []
        fit_quality = self.training_mae()
        if self.classifier is not None:
            n = self.classifier.X_train_.shape[0]
            lines.append(
                f"{self.targets[0]}: {n} rows, training accuracy "
                f"{100 * fit_quality['accuracy']:.1f} %; {self.classifier.describe()}"
            )
        for target, reg in self.regressors.items():
            lines.append(
                f"{target}: {reg.X_train_.shape[0]} rows, training MAE "
                f"{fit_quality[target]:.4g}; {reg.describe()}"
            )
            cal = self.calibration.get(target)
            if cal is not None:
                local = ""
                if cal.local is not None:
                    local = f" × a local factor (bandwidth {cal.local.bandwidth:g})"
                lines.append(
                    f"  calibration: {cal.n_folds}-fold cross-conformal on {cal.n} rows; "
                    f"std scale {cal.std_scale:.3g}{local} (the model's std × this covers 68 % "
                    "of held-out rows)"
                )
            else:
                lines.append("  calibration: none (its std is not calibrated)")
        if not self.feature_map.is_identity:
            a, b = self.feature_map.alpha, self.feature_map.beta
            lines.append(
                f"container transfer: α = ({a[0]:.4g}, {a[1]:+.4g}), β = ({b[0]:.4g}, {b[1]:+.4g})"
            )
        settings = self.extraction_settings
        if settings is not None:
            shown = ", ".join(
                f"{name} {json.dumps(settings[name], separators=(',', ':'))}"
                for name in sorted(settings)
            )
            lines.append(f"features extracted with: {shown}")
        return lines
