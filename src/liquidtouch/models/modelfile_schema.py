"""The schema of a model file (pydantic): what a valid liquidtouch model file holds.

A model file is one JSON document (small arrays — training data, scaling —
are embedded as lists; JSON floats round-trip exactly)::

    {"format": "liquidtouch-model", "format_version": 8,
     "kind": "regression" | "classification", "created_by": "liquidtouch 0.1.0",
     "provenance": {"liquidtouch": ..., "scikit_learn": ..., "numpy": ..., "python": ...,
                    "training_sha256": ...},
     "features": ["decay_rate", "angular_frequency"], "targets": [...],
     "feature_map": {"alpha": [α1, α2], "beta": [β1, β2]},
     "domain": {"decay_rate": [min, max], "angular_frequency": [min, max], "margin": 0.1},
     "regressors": {target: {"model": "gpr" | "physics-gpr" | "quadratic", ...}},
     "classifier": {"model": "svm", "C": ..., "gamma": ..., ..., "unknown": {...}} | null,
     "calibration": {target: {"method": "cross-conformal", "n_folds": K,
                              "random_state": 0, "scores": [...],
                              "local": {"points": [...], "z2": [...], "bandwidth": h, ...},
                              "normalised_by": "model-std" | "total-std"}},
     "extraction_settings": {"source": "gelsight", "n_markers": 16, ...} | null,
     "sha256": ...}

Each estimator stores its hyperparameters (GP kernel: constant, RBF length
scales, white-noise level, and each training row's own noise when it was fitted with
the rows' feature std; SVM: C, gamma; physics prior: wavenumber and coefficients), its
feature/target scaling and its training data. Features are
λ [1/s] and ω [rad/s]. The format is described in ``docs/formats.md``.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from liquidtouch.io.tables import FEATURE_COLUMNS
from liquidtouch.models.classifier import C_BOUNDS, GAMMA_BOUNDS
from liquidtouch.models.regressors import (
    CONSTANT_BOUNDS,
    LENGTH_SCALE_BOUNDS,
    MAX_NOISE_LEVEL,
    MAX_RESTARTS,
    MIN_NOISE_LEVEL,
)

FORMAT_NAME = "liquidtouch-model"
#: Version 2 adds ``sha256``, ``provenance`` and ``domain``; version 3 ``calibration``
#: (cross-conformal scores per target); version 4 the classifier's ``unknown`` rule;
#: version 5 a calibration's ``local`` scale (:mod:`liquidtouch.models.local_scale`);
#: version 6 its ``normalised_by`` (scores of the total std,
#: :mod:`~liquidtouch.models.conformal`); version 7 a GP's ``row_noise`` (each training
#: row's own noise, :mod:`~liquidtouch.models.regressors`); version 8 the
#: ``extraction_settings`` of the training features
#: (:mod:`~liquidtouch.models.extraction_match`).
#: Versions 1-4 still load (uncalibrated; a classifier without ``unknown`` gets the
#: rule at its default false-alarm rate from its training rows).
FORMAT_VERSION = 8

PositiveFloat = Annotated[float, Field(gt=0)]
Sha256 = Annotated[str, Field(pattern=r"^[0-9a-f]{64}$")]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


class _TrainingData(_Strict):
    X_train: list[Annotated[list[float], Field(min_length=2, max_length=2)]] = Field(min_length=1)

    def _check_length(self, other: list[Any], name: str) -> None:
        if len(other) != len(self.X_train):
            raise ValueError(
                f"{name} has {len(other)} values but X_train has {len(self.X_train)} rows"
            )


#: relative rounding of a bound that went through log and exp (a few ulp; 1e-12 is plenty)
_LOG_ROUNDING = 1e-12


def _within(bounds: tuple[float, float]) -> Any:
    """A float within ``bounds`` as a fit that searches them in logarithms returns them
    (``exp(log(100))`` is ``100.00000000000004``)."""
    return Field(ge=bounds[0] * (1 - _LOG_ROUNDING), le=bounds[1] * (1 + _LOG_ROUNDING))


class KernelState(_Strict):
    """A GP's fitted kernel: within the bounds its fit searches (``models.regressors``)."""

    constant: float = _within(CONSTANT_BOUNDS)
    length_scale: list[Annotated[float, _within(LENGTH_SCALE_BOUNDS)]] = Field(
        min_length=2, max_length=3
    )
    noise_level: float = _within((MIN_NOISE_LEVEL, MAX_NOISE_LEVEL))


class PriorState(_Strict):
    kind: Literal["height", "viscosity"]
    wavenumber: float = Field(ge=0)
    coef: list[float] = Field(min_length=2, max_length=2)


class GPRState(_TrainingData):
    model: Literal["gpr", "physics-gpr"]
    n_restarts: int = Field(ge=0, le=MAX_RESTARTS)
    random_state: int
    kernel: KernelState
    prior: PriorState | None
    x_mean: list[float]
    x_scale: list[PositiveFloat]
    y_mean: float
    y_scale: PositiveFloat
    y_train: list[float]
    row_noise: list[Annotated[float, Field(ge=0)]] | None = None

    @model_validator(mode="after")
    def _consistent(self) -> GPRState:
        self._check_length(self.y_train, "y_train")
        if self.row_noise is not None:
            self._check_length(self.row_noise, "row_noise")
        viscosity_prior = self.prior is not None and self.prior.kind == "viscosity"
        n_inputs = 3 if viscosity_prior else 2
        if (self.prior is None) != (self.model == "gpr"):
            raise ValueError("a physics-gpr needs a prior and a plain gpr must not have one")
        for name in ("x_mean", "x_scale"):
            if len(getattr(self, name)) != n_inputs:
                raise ValueError(f"{name} must have {n_inputs} values")
        if len(self.kernel.length_scale) != n_inputs:
            raise ValueError(f"kernel.length_scale must have {n_inputs} values")
        if self.prior is not None and self.prior.kind == "height" and self.prior.wavenumber <= 0:
            raise ValueError("prior.wavenumber must be > 0 for a height prior")
        return self


class QuadraticState(_TrainingData):
    model: Literal["quadratic"]
    coef: list[float] = Field(min_length=6, max_length=6)
    y_train: list[float]

    @model_validator(mode="after")
    def _consistent(self) -> QuadraticState:
        self._check_length(self.y_train, "y_train")
        return self


class ClassStatistics(_Strict):
    n: int = Field(ge=3)
    mean: list[float] = Field(min_length=2, max_length=2)
    cov: list[Annotated[list[float], Field(min_length=2, max_length=2)]] = Field(
        min_length=2, max_length=2
    )


class UnknownRuleState(_Strict):
    """The classifier's "unknown" rule (``models/classifier.py``): Hotelling's T² per class."""

    rule: Literal["hotelling-t2"]
    status: str | None = None
    """``"available"`` or ``"unavailable, needs N rows per class"`` (checked on loading)."""
    features: tuple[Literal["log_decay_rate"], Literal["angular_frequency"]]
    alpha: float = Field(gt=0, lt=1)
    classes: dict[str, ClassStatistics] = Field(min_length=2)


class SVMState(_TrainingData):
    model: Literal["svm"]
    C: float = Field(ge=C_BOUNDS[0], le=C_BOUNDS[1])  # what the refit costs grows with both
    gamma: float = Field(ge=GAMMA_BOUNDS[0], le=GAMMA_BOUNDS[1])
    labels_train: list[str]
    unknown: UnknownRuleState | None = None

    @model_validator(mode="after")
    def _consistent(self) -> SVMState:
        self._check_length(self.labels_train, "labels_train")
        return self


class FeatureMapState(_Strict):
    alpha: tuple[float, float] = (1.0, 0.0)
    beta: tuple[float, float] = (1.0, 0.0)


class DomainState(_Strict):
    decay_rate: tuple[float, float]
    angular_frequency: tuple[float, float]
    margin: float = Field(ge=0)

    @model_validator(mode="after")
    def _ordered(self) -> DomainState:
        for name in ("decay_rate", "angular_frequency"):
            low, high = getattr(self, name)
            if low > high:
                raise ValueError(f"{name}: the minimum {low} exceeds the maximum {high}")
        return self


class LocalScaleState(_Strict):
    points: list[Annotated[list[float], Field(min_length=2, max_length=2)]] = Field(min_length=2)
    z2: list[Annotated[float, Field(ge=0)]] = Field(min_length=2)
    centre: list[float] = Field(min_length=2, max_length=2)
    spread: list[PositiveFloat] = Field(min_length=2, max_length=2)
    bandwidth: PositiveFloat
    prior_weight: PositiveFloat

    @model_validator(mode="after")
    def _rows(self) -> LocalScaleState:
        if len(self.z2) != len(self.points):
            raise ValueError(f"local: {len(self.z2)} scores for {len(self.points)} points")
        return self


class CalibrationState(_Strict):
    method: Literal["cross-conformal"]
    n_folds: int = Field(ge=2)
    random_state: int = 0
    scores: list[Annotated[float, Field(ge=0)]] = Field(min_length=2)
    local: LocalScaleState | None = None
    normalised_by: Literal["model-std", "total-std"] = "model-std"


class ProvenanceState(_Strict):
    liquidtouch: str
    scikit_learn: str
    numpy: str
    python: str
    training_sha256: Sha256


RegressorState = Annotated[GPRState | QuadraticState, Field(discriminator="model")]


class ModelFile(_Strict):
    """The validated contents of a model file."""

    format: Literal["liquidtouch-model"]
    format_version: int = Field(ge=1)
    kind: Literal["regression", "classification"]
    created_by: str = ""
    provenance: ProvenanceState | None = None
    features: list[str]
    targets: list[str] = Field(min_length=1)
    label: str | None = None
    feature_map: FeatureMapState = FeatureMapState()
    domain: DomainState | None = None
    regressors: dict[str, RegressorState] = {}
    classifier: SVMState | None = None
    calibration: dict[str, CalibrationState] = {}
    extraction_settings: dict[str, Any] | None = None
    sha256: Sha256 | None = None

    @model_validator(mode="after")
    def _consistent(self) -> ModelFile:
        if tuple(self.features) != FEATURE_COLUMNS:
            raise ValueError(f"features must be {list(FEATURE_COLUMNS)}")
        if self.kind == "regression":
            if self.classifier is not None or set(self.regressors) != set(self.targets):
                raise ValueError(
                    "a regression model needs one regressor per target and no classifier"
                )
        elif self.classifier is None or self.regressors:
            raise ValueError("a classification model needs a classifier and no regressors")
        unknown = sorted(set(self.calibration) - set(self.regressors))
        if unknown:
            raise ValueError(f"calibration of {', '.join(unknown)}: not a regressor's target")
        for target, cal in self.calibration.items():
            n_rows = len(self.regressors[target].X_train)
            if len(cal.scores) != n_rows:
                raise ValueError(
                    f"calibration of {target}: {len(cal.scores)} scores for {n_rows} training rows"
                )
        if self.calibration and self.format_version < 3:
            raise ValueError("calibration needs format version 3")
        if self.format_version < 5 and any(c.local for c in self.calibration.values()):
            raise ValueError("a local calibration scale needs format version 5")
        if self.format_version < 6 and any(
            c.normalised_by != "model-std" for c in self.calibration.values()
        ):
            raise ValueError("scores normalised by the total std need format version 6")
        if self.format_version < 7 and any(
            getattr(r, "row_noise", None) is not None for r in self.regressors.values()
        ):
            raise ValueError("a GP's row_noise needs format version 7")
        if self.format_version < 8 and self.extraction_settings is not None:
            raise ValueError("extraction_settings need format version 8")
        if self.format_version >= 4 and self.classifier is not None:
            if self.classifier.unknown is None:
                raise ValueError(f"format version {self.format_version} needs classifier.unknown")
        if self.format_version >= 2:
            missing = [n for n in ("provenance", "sha256") if getattr(self, n) is None]
            if missing:
                raise ValueError(
                    f"format version {self.format_version} needs {' and '.join(missing)}"
                )
        return self
