"""Saving and loading property models safely: validated JSON, no pickle, nothing executable.

A model file is one JSON document (:mod:`liquidtouch.models.modelfile_schema`).
Loading refits each estimator deterministically with its stored hyperparameters
(no optimiser), so predictions are identical to the saved model's. Loading
validates everything (:mod:`liquidtouch.models.modelfile_checks`) and raises
:class:`ModelFileError` for a file that is not ours, is of a newer format
version, is corrupt or edited (``sha256``: a checksum of the whole document), or
is too large to load safely (:data:`MAX_MODEL_FILE_BYTES`, checked before
parsing, and :data:`~liquidtouch.models.kernel_limits.MAX_KERNEL_ROWS` training rows
per GP or SVM, :data:`~liquidtouch.models.kernel_limits.MAX_KERNEL_ROWS_TOTAL` per
file, checked before refitting). Version 1 files (no ``sha256``, ``provenance``,
``domain``) still load; their training domain is derived from their training
data. Version 2 files (no ``calibration``) load uncalibrated: ``predict`` warns
and refuses ``--level``. The format is described in ``docs/formats.md``.
"""

from __future__ import annotations

import json
import os
import platform
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from liquidtouch import __version__
from liquidtouch._core import atomic
from liquidtouch.errors import LiquidTouchError, ModelFileError
from liquidtouch.io.tables import FEATURE_COLUMNS
from liquidtouch.models.classifier import LiquidClassifier
from liquidtouch.models.conformal import TargetCalibration
from liquidtouch.models.feature_space import FeatureMap, TrainingDomain
from liquidtouch.models.modelfile_checks import (
    document_sha256,
    training_sha256,
    validate_document,
)
from liquidtouch.models.modelfile_schema import FORMAT_NAME, FORMAT_VERSION, ModelFile
from liquidtouch.models.property_model import REGRESSORS, PropertyModel

__all__ = ["MAX_MODEL_FILE_BYTES", "load_model", "model_from_dict", "model_to_dict", "save_model"]

#: Largest model file read (checked before parsing). A model at the kernel-row limits
#: (two GP targets of 2000 rows) is 0.25 MB; loading a hostile 2 MiB file of minimal rows
#: (a quadratic model of 262 000 ``[0,1]`` rows) takes 1.9 s and +136 MB.
MAX_MODEL_FILE_BYTES = 2 * 1024 * 1024


def _require_model(model: Any) -> None:
    if not isinstance(model, PropertyModel):
        raise ModelFileError(
            f"only a PropertyModel can be saved; got {type(model).__name__} (wrap a fitted "
            "estimator: PropertyModel(regressors={'height_mm': estimator}))"
        )


def _provenance() -> dict[str, str]:
    import sklearn

    return {
        "liquidtouch": __version__,
        "scikit_learn": sklearn.__version__,
        "numpy": np.__version__,
        "python": platform.python_version(),
    }


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
        "calibration": {t: c.to_state() for t, c in model.calibration.items()},
        "extraction_settings": model.extraction_settings,
    }
    try:
        # plain JSON types (numpy scalars, tuples -> lists), as a reader will see them
        doc = json.loads(json.dumps(doc))
    except (TypeError, ValueError) as exc:
        raise ModelFileError(f"the model cannot be saved: {exc}") from None
    doc["provenance"]["training_sha256"] = training_sha256(doc)
    doc["sha256"] = document_sha256(doc)
    try:
        validate_document(doc, "the model")  # never write a file we would refuse to read
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
        data = validate_document(doc, where)
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
                calibration={
                    t: TargetCalibration.from_state(c.model_dump())
                    for t, c in data.calibration.items()
                },
            )
    except ModelFileError:
        raise
    except (LiquidTouchError, ValueError, np.linalg.LinAlgError) as exc:
        raise ModelFileError(
            f"{where} is a corrupt model file: {exc} (retrain the model)"
        ) from None
    model.provenance = data.provenance.model_dump() if data.provenance is not None else None
    model.extraction_settings = data.extraction_settings
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
    except ValueError:  # an integer of more than 4300 digits: no model file holds one
        raise ModelFileError(
            f"{path} is a corrupt model file (a number with thousands of digits); retrain the model"
        ) from None
    return model_from_dict(doc, str(path))
