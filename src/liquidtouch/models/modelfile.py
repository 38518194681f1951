"""Saving and loading property models safely: validated JSON, no pickle, nothing executable.

A model file is one JSON document (small arrays — training data, scaling —
are embedded as lists; JSON floats round-trip exactly)::

    {"format": "liquidtouch-model", "format_version": 2,
     "kind": "regression" | "classification", "created_by": "liquidtouch 0.1.0",
     "provenance": {"liquidtouch": ..., "scikit_learn": ..., "numpy": ..., "python": ...,
                    "training_sha256": ...},
     "features": ["decay_rate", "angular_frequency"], "targets": [...],
     "feature_map": {"alpha": [α1, α2], "beta": [β1, β2]},
     "domain": {"decay_rate": [min, max], "angular_frequency": [min, max], "margin": 0.1},
     "regressors": {target: {"model": "gpr" | "physics-gpr" | "quadratic", ...}},
     "classifier": {"model": "svm", "C": ..., "gamma": ..., ...} | null,
     "sha256": ...}

Each estimator stores its hyperparameters (GP kernel: constant, RBF length
scales, white-noise level; SVM: C, gamma; physics prior: wavenumber and
coefficients), its feature/target scaling and its training data; loading
refits deterministically with those hyperparameters (no optimiser), so
predictions are identical to the saved model's. Loading validates everything
(pydantic) and raises :class:`ModelFileError` for a file that is not ours, is
of a newer format version, is corrupt or edited (``sha256``: a checksum of the
whole document), or is too large to load safely (:data:`MAX_MODEL_FILE_BYTES`,
checked before parsing, and :data:`~liquidtouch.models.regressors.MAX_KERNEL_ROWS`
training rows per GP or SVM, :data:`~liquidtouch.models.regressors.MAX_KERNEL_ROWS_TOTAL`
per file, checked before refitting). Version 1 files (no ``sha256``,
``provenance``, ``domain``) still load; their training domain is derived from
their training data. The format is described in ``docs/formats.md``.
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
from collections.abc import Mapping
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from liquidtouch import __version__
from liquidtouch.errors import LiquidTouchError, ModelFileError
from liquidtouch.io import atomic
from liquidtouch.io.tables import FEATURE_COLUMNS
from liquidtouch.models.classifier import LiquidClassifier
from liquidtouch.models.property_model import (
    REGRESSORS,
    FeatureMap,
    PropertyModel,
    TrainingDomain,
)
from liquidtouch.models.regressors import MAX_KERNEL_ROWS, MAX_KERNEL_ROWS_TOTAL

FORMAT_NAME = "liquidtouch-model"
#: Version 2 adds ``sha256``, ``provenance`` and ``domain``; version 1 files still load.
FORMAT_VERSION = 2
#: Largest model file read (checked before parsing). A model at the kernel-row limits
#: (two GP targets of 2000 rows) is 0.25 MB; loading a hostile 2 MiB file of minimal rows
#: (a quadratic model of 262 000 ``[0,1]`` rows) takes 1.9 s and +136 MB.
MAX_MODEL_FILE_BYTES = 2 * 1024 * 1024
KERNEL_MODELS = ("gpr", "physics-gpr", "svm")

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
        if self.format_version >= 2:
            missing = [n for n in ("provenance", "sha256") if getattr(self, n) is None]
            if missing:
                raise ValueError(
                    f"format version {self.format_version} needs {' and '.join(missing)}"
                )
        return self


def _require_model(model: Any) -> None:
    if not isinstance(model, PropertyModel):
        raise ModelFileError(
            f"only a PropertyModel can be saved; got {type(model).__name__} (wrap a fitted "
            "estimator: PropertyModel(regressors={'height_mm': estimator}))"
        )


def _canonical(obj: Any) -> bytes:
    """Canonical JSON bytes: sorted keys, no whitespace, ASCII (floats as Python's repr)."""
    return json.dumps(obj, sort_keys=True, separators=(",", ":")).encode("ascii")


def document_sha256(doc: Mapping[str, Any]) -> str:
    """SHA-256 (hex) of the canonical JSON of a model-file dict without its ``sha256`` key."""
    return hashlib.sha256(_canonical({k: v for k, v in doc.items() if k != "sha256"})).hexdigest()


def _estimator_states(doc: Mapping[str, Any]) -> dict[str, Any]:
    """``{target: state}`` of a raw model-file dict (the classifier under its label)."""
    if doc.get("kind") == "classification":
        label = doc.get("label")
        return {label if isinstance(label, str) and label else "liquid": doc.get("classifier")}
    regressors = doc.get("regressors")
    return dict(regressors) if isinstance(regressors, Mapping) else {}


def training_sha256(doc: Mapping[str, Any]) -> str:
    """SHA-256 (hex) of the training table of a model-file dict.

    The canonical JSON of ``{target: {"X_train": ..., "y_train" | "labels_train": ...}}``:
    identical for every model trained on the same rows and target columns.
    """
    tables = {
        target: {k: state[k] for k in ("X_train", "y_train", "labels_train") if k in state}
        for target, state in _estimator_states(doc).items()
    }
    return hashlib.sha256(_canonical(tables)).hexdigest()


def _provenance() -> dict[str, str]:
    import sklearn

    return {
        "liquidtouch": __version__,
        "scikit_learn": sklearn.__version__,
        "numpy": np.__version__,
        "python": platform.python_version(),
    }


def _check_kernel_rows(doc: Mapping[str, Any], where: str) -> None:
    """Refuse kernel models (GP, SVM) with more training rows than liquidtouch refits.

    Runs on the raw dict, before validation: the refit is O(n³) time, O(n²) memory.
    """
    total = 0
    for target, state in _estimator_states(doc).items():
        if not isinstance(state, Mapping) or state.get("model") not in KERNEL_MODELS:
            continue
        rows = state.get("X_train")
        n = len(rows) if isinstance(rows, list) else 0
        total += n
        if n > MAX_KERNEL_ROWS:
            raise ModelFileError(
                f"{where}: the {state['model']} model of {target} holds {n} training rows; "
                f"liquidtouch refits at most {MAX_KERNEL_ROWS} rows per GP or SVM when "
                "loading (O(n³) time, O(n²) memory); retrain it on a subsample, or with "
                "--model quadratic"
            )
    if total > MAX_KERNEL_ROWS_TOTAL:
        raise ModelFileError(
            f"{where}: its GP models hold {total} training rows in total; liquidtouch refits "
            f"at most {MAX_KERNEL_ROWS_TOTAL} per model file when loading; train one model "
            "per target, on a subsample, or with --model quadratic"
        )


def model_to_dict(model: PropertyModel) -> dict[str, Any]:
    """The JSON-ready dict of ``model`` (checked to load again: :func:`model_from_dict`'s checks).

    Raises :class:`ModelFileError` if ``model`` cannot be stored.
    """
    _require_model(model)
    if model.classifier is not None:
        states = {"classifier": model.classifier.to_state(), "regressors": {}}
    else:
        states = {
            "classifier": None,
            "regressors": {t: r.to_state() for t, r in model.regressors.items()},
        }
    domain = model.domain
    doc: dict[str, Any] = {
        "format": FORMAT_NAME,
        "format_version": FORMAT_VERSION,
        "kind": model.kind,
        "created_by": f"liquidtouch {__version__}",
        "provenance": _provenance(),
        "features": list(FEATURE_COLUMNS),
        "targets": model.targets,
        "label": model.label,
        "feature_map": {
            "alpha": list(model.feature_map.alpha),
            "beta": list(model.feature_map.beta),
        },
        "domain": None
        if domain is None
        else {
            "decay_rate": [domain.low[0], domain.high[0]],
            "angular_frequency": [domain.low[1], domain.high[1]],
            "margin": domain.margin,
        },
        "regressors": states["regressors"],
        "classifier": states["classifier"],
    }
    try:
        # plain JSON types (numpy scalars, tuples -> lists), as a reader will see them
        doc = json.loads(json.dumps(doc))
    except (TypeError, ValueError) as exc:
        raise ModelFileError(f"the model cannot be saved: {exc}") from None
    doc["provenance"]["training_sha256"] = training_sha256(doc)
    doc["sha256"] = document_sha256(doc)
    try:
        _validate(doc, "the model")  # never write a file we would refuse to read
    except ModelFileError as exc:
        raise ModelFileError(f"the model cannot be saved: {exc}") from None
    return doc


def _json_text(obj: Any, level: int = 0) -> str:
    """Indented JSON with every list of numbers or strings on one line."""
    if isinstance(obj, dict) and obj:
        pad = "  " * (level + 1)
        items = [f"{pad}{json.dumps(k)}: {_json_text(v, level + 1)}" for k, v in obj.items()]
        return "{\n" + ",\n".join(items) + "\n" + "  " * level + "}"
    return json.dumps(obj)


def save_model(model: PropertyModel, path: str | os.PathLike[str]) -> Path:
    """Atomically write ``model`` as a JSON model file; return the path.

    Raises :class:`ModelFileError` if the file would exceed :data:`MAX_MODEL_FILE_BYTES`.
    """
    text = _json_text(model_to_dict(model)) + "\n"
    size = len(text.encode("utf-8"))
    if size > MAX_MODEL_FILE_BYTES:
        raise ModelFileError(
            f"the model would be a {size}-byte file, but model files are limited to "
            f"{MAX_MODEL_FILE_BYTES} bytes ({MAX_MODEL_FILE_BYTES // 2**20} MiB); train it on "
            "fewer rows (subsample the table) or fewer targets per model"
        )
    path = Path(path)
    atomic.write_text(path, text)
    return path


def _first_error(exc: ValidationError) -> str:
    first = exc.errors()[0]
    loc = ".".join(str(p) for p in first["loc"]) or "(root)"
    return f"{loc}: {first['msg']}"


def _validate(doc: Any, where: str) -> ModelFile:
    """Format, version, size limits, schema and checksums of a model-file dict."""
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
    _check_kernel_rows(doc, where)
    try:
        data = ModelFile.model_validate(doc)
    except ValidationError as exc:
        raise ModelFileError(
            f"{where} is a corrupt model file: {_first_error(exc)} (retrain the model)"
        ) from None
    if data.sha256 is not None and document_sha256(doc) != data.sha256:
        raise ModelFileError(
            f"{where} does not match its sha256 checksum: the model file was edited or is "
            "corrupt (retrain the model)"
        )
    if data.provenance is not None and training_sha256(doc) != data.provenance.training_sha256:
        raise ModelFileError(
            f"{where}: its training data do not match provenance.training_sha256 "
            "(the model file was edited or is corrupt; retrain the model)"
        )
    return data


def _domain(data: ModelFile, estimators: Mapping[str, Any]) -> TrainingDomain:
    if data.domain is None:  # format version 1: the box of the training data
        return TrainingDomain.of(e.X_train_ for e in estimators.values())
    d = data.domain
    return TrainingDomain(
        (d.decay_rate[0], d.angular_frequency[0]),
        (d.decay_rate[1], d.angular_frequency[1]),
        d.margin,
    )


def model_from_dict(doc: Any, where: str = "model") -> PropertyModel:
    """Validate a model-file dict and rebuild the :class:`PropertyModel` exactly.

    Raises :class:`ModelFileError` for anything but a valid model file within the limits.
    """
    try:
        data = _validate(doc, where)
    except RecursionError:
        raise ModelFileError(
            f"{where} is not a liquidtouch model file (nested too deeply)"
        ) from None
    fmap = FeatureMap(tuple(data.feature_map.alpha), tuple(data.feature_map.beta))
    try:
        if data.kind == "classification":
            clf = LiquidClassifier.from_state(data.classifier.model_dump())
            estimators: dict[str, Any] = {data.label or "liquid": clf}
            model = PropertyModel(
                classifier=clf, label=data.label, feature_map=fmap, domain=_domain(data, estimators)
            )
        else:
            regressors = {
                t: REGRESSORS[s.model].from_state(s.model_dump())
                for t, s in data.regressors.items()
            }
            model = PropertyModel(
                regressors={t: regressors[t] for t in data.targets},
                feature_map=fmap,
                domain=_domain(data, regressors),
            )
    except ModelFileError:
        raise
    except (LiquidTouchError, ValueError, np.linalg.LinAlgError) as exc:
        raise ModelFileError(
            f"{where} is a corrupt model file: {exc} (retrain the model)"
        ) from None
    model.provenance = data.provenance.model_dump() if data.provenance is not None else None
    return model


def load_model(path: str | os.PathLike[str]) -> PropertyModel:
    """Read, validate and rebuild a model file; raise :class:`ModelFileError` if unusable.

    Files larger than :data:`MAX_MODEL_FILE_BYTES` are refused before they are parsed.
    """
    path = Path(path)
    if not path.is_file():
        raise ModelFileError(f"{path}: no such model file")
    too_large = ModelFileError(
        f"{path} is larger than {MAX_MODEL_FILE_BYTES} bytes "
        f"({MAX_MODEL_FILE_BYTES // 2**20} MiB), the limit for model files; it is not a model "
        "liquidtouch wrote (retrain the model)"
    )
    if path.stat().st_size > MAX_MODEL_FILE_BYTES:
        raise too_large
    with path.open("rb") as stream:
        raw = stream.read(MAX_MODEL_FILE_BYTES + 1)
    if len(raw) > MAX_MODEL_FILE_BYTES:  # it grew since stat()
        raise too_large
    not_json = ModelFileError(
        f"{path} is not a liquidtouch model file (not JSON); "
        "create one with `liquidtouch train` or `liquidtouch classify`"
    )
    try:
        doc = json.loads(raw.decode("utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError):
        raise not_json from None
    except RecursionError:
        raise ModelFileError(
            f"{path} is not a liquidtouch model file (JSON nested too deeply)"
        ) from None
    except ValueError as exc:  # e.g. an integer of more than 4300 digits
        raise ModelFileError(f"{path} is a corrupt model file: {exc} (retrain the model)") from None
    return model_from_dict(doc, str(path))
