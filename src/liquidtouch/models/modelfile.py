"""Saving and loading property models safely: validated JSON, no pickle, nothing executable.

A model file is one JSON document (small arrays — training data, scaling —
are embedded as lists; JSON floats round-trip exactly)::

    {"format": "liquidtouch-model", "format_version": 1,
     "kind": "regression" | "classification", "created_by": "liquidtouch 0.1.0",
     "features": ["decay_rate", "angular_frequency"], "targets": [...],
     "feature_map": {"alpha": [α1, α2], "beta": [β1, β2]},
     "regressors": {target: {"model": "gpr" | "physics-gpr" | "quadratic", ...}},
     "classifier": {"model": "svm", "C": ..., "gamma": ..., ...} | null}

Each estimator stores its hyperparameters (GP kernel: constant, RBF length
scales, white-noise level; SVM: C, gamma; physics prior: wavenumber and
coefficients), its feature/target scaling and its training data; loading
refits deterministically with those hyperparameters (no optimiser), so
predictions are identical to the saved model's. Loading validates everything
(pydantic) and raises :class:`ModelFileError` for a file that is not ours, is
of a newer format version, or is corrupt. The format is described in
``docs/formats.md``.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from liquidtouch import __version__
from liquidtouch.errors import ModelFileError
from liquidtouch.io import atomic
from liquidtouch.io.tables import FEATURE_COLUMNS
from liquidtouch.models.classifier import LiquidClassifier
from liquidtouch.models.property_model import REGRESSORS, FeatureMap, PropertyModel

FORMAT_NAME = "liquidtouch-model"
FORMAT_VERSION = 1

PositiveFloat = Annotated[float, Field(gt=0)]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


class _TrainingData(_Strict):
    X_train: list[Annotated[list[float], Field(min_length=2, max_length=2)]] = Field(min_length=1)

    def _check_length(self, other: list[Any], name: str) -> None:
        if len(other) != len(self.X_train):
            raise ValueError(
                f"{name} has {len(other)} values but X_train has {len(self.X_train)} rows"
            )


class KernelState(_Strict):
    constant: PositiveFloat
    length_scale: list[PositiveFloat] = Field(min_length=2, max_length=3)
    noise_level: PositiveFloat


class PriorState(_Strict):
    kind: Literal["height", "viscosity"]
    wavenumber: float = Field(ge=0)
    coef: list[float] = Field(min_length=2, max_length=2)


class GPRState(_TrainingData):
    model: Literal["gpr", "physics-gpr"]
    n_restarts: int = Field(ge=0)
    random_state: int
    kernel: KernelState
    prior: PriorState | None
    x_mean: list[float]
    x_scale: list[PositiveFloat]
    y_mean: float
    y_scale: PositiveFloat
    y_train: list[float]

    @model_validator(mode="after")
    def _consistent(self) -> GPRState:
        self._check_length(self.y_train, "y_train")
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


class SVMState(_TrainingData):
    model: Literal["svm"]
    C: PositiveFloat
    gamma: PositiveFloat
    labels_train: list[str]

    @model_validator(mode="after")
    def _consistent(self) -> SVMState:
        self._check_length(self.labels_train, "labels_train")
        return self


class FeatureMapState(_Strict):
    alpha: tuple[float, float] = (1.0, 0.0)
    beta: tuple[float, float] = (1.0, 0.0)


RegressorState = Annotated[GPRState | QuadraticState, Field(discriminator="model")]


class ModelFile(_Strict):
    """The validated contents of a model file."""

    format: Literal["liquidtouch-model"]
    format_version: int = Field(ge=1)
    kind: Literal["regression", "classification"]
    created_by: str = ""
    features: list[str]
    targets: list[str] = Field(min_length=1)
    label: str | None = None
    feature_map: FeatureMapState = FeatureMapState()
    regressors: dict[str, RegressorState] = {}
    classifier: SVMState | None = None

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
        return self


def _require_model(model: Any) -> None:
    if not isinstance(model, PropertyModel):
        raise ModelFileError(
            f"only a PropertyModel can be saved; got {type(model).__name__} (wrap a fitted "
            "estimator: PropertyModel(regressors={'height_mm': estimator}))"
        )


def model_to_dict(model: PropertyModel) -> dict[str, Any]:
    """The JSON-ready dict of ``model`` (validated against :class:`ModelFile`).

    Raises :class:`ModelFileError` if ``model`` cannot be stored.
    """
    _require_model(model)
    doc = {
        "format": FORMAT_NAME,
        "format_version": FORMAT_VERSION,
        "kind": model.kind,
        "created_by": f"liquidtouch {__version__}",
        "features": list(FEATURE_COLUMNS),
        "targets": model.targets,
        "label": model.label,
        "feature_map": {
            "alpha": list(model.feature_map.alpha),
            "beta": list(model.feature_map.beta),
        },
        "regressors": {t: r.to_state() for t, r in model.regressors.items()},
        "classifier": model.classifier.to_state() if model.classifier is not None else None,
    }
    try:
        ModelFile.model_validate(doc)  # never write a file we would refuse to read
    except ValidationError as exc:
        raise ModelFileError(f"the model cannot be saved: {_first_error(exc)}") from None
    return doc


def save_model(model: PropertyModel, path: str | os.PathLike[str]) -> Path:
    """Atomically write ``model`` as a JSON model file; return the path."""
    doc = model_to_dict(model)
    path = Path(path)
    atomic.write_json(path, doc)
    return path


def _first_error(exc: ValidationError) -> str:
    first = exc.errors()[0]
    loc = ".".join(str(p) for p in first["loc"]) or "(root)"
    return f"{loc}: {first['msg']}"


def _validate(doc: Any, where: str) -> ModelFile:
    if not isinstance(doc, dict) or doc.get("format") != FORMAT_NAME:
        raise ModelFileError(
            f'{where} is not a liquidtouch model file (no "format": "{FORMAT_NAME}"); '
            "create one with `liquidtouch train` or `liquidtouch classify`"
        )
    version = doc.get("format_version")
    if isinstance(version, int) and version > FORMAT_VERSION:
        raise ModelFileError(
            f"{where} has model format version {version}; this liquidtouch reads up to "
            f"{FORMAT_VERSION} (upgrade liquidtouch)"
        )
    try:
        return ModelFile.model_validate(doc)
    except ValidationError as exc:
        raise ModelFileError(
            f"{where} is a corrupt model file: {_first_error(exc)} (retrain the model)"
        ) from None


def model_from_dict(doc: Any, where: str = "model") -> PropertyModel:
    """Validate a model-file dict and rebuild the :class:`PropertyModel` exactly."""
    data = _validate(doc, where)
    fmap = FeatureMap(tuple(data.feature_map.alpha), tuple(data.feature_map.beta))
    try:
        if data.kind == "classification":
            clf = LiquidClassifier.from_state(data.classifier.model_dump())
            return PropertyModel(classifier=clf, label=data.label, feature_map=fmap)
        regressors = {
            t: REGRESSORS[s.model].from_state(s.model_dump()) for t, s in data.regressors.items()
        }
    except ModelFileError:
        raise
    except (ValueError, np.linalg.LinAlgError) as exc:
        raise ModelFileError(
            f"{where} is a corrupt model file: {exc} (retrain the model)"
        ) from None
    return PropertyModel(regressors={t: regressors[t] for t in data.targets}, feature_map=fmap)


def load_model(path: str | os.PathLike[str]) -> PropertyModel:
    """Read, validate and rebuild a model file; raise :class:`ModelFileError` if unusable."""
    path = Path(path)
    if not path.is_file():
        raise ModelFileError(f"{path}: no such model file")
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError):
        raise ModelFileError(
            f"{path} is not a liquidtouch model file (not JSON); "
            "create one with `liquidtouch train` or `liquidtouch classify`"
        ) from None
    return model_from_dict(doc, str(path))
