"""Checks of a model-file dict before anything is rebuilt: format, limits, schema, checksums.

:func:`validate_document` refuses a file that is not ours, is of a newer format
version, holds more kernel-model training rows than liquidtouch refits
(:data:`~liquidtouch.models.kernel_limits.MAX_KERNEL_ROWS` per GP or SVM,
:data:`~liquidtouch.models.kernel_limits.MAX_KERNEL_ROWS_TOTAL` per file, checked
before the schema), breaks the schema (:mod:`liquidtouch.models.modelfile_schema`),
or was edited (``sha256``: a checksum of the whole document;
``provenance.training_sha256``: of its training table).
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from typing import Any

from pydantic import ValidationError

from liquidtouch.errors import ModelFileError
from liquidtouch.models.kernel_limits import MAX_KERNEL_ROWS, MAX_KERNEL_ROWS_TOTAL
from liquidtouch.models.modelfile_schema import FORMAT_NAME, FORMAT_VERSION, ModelFile

KERNEL_MODELS = ("gpr", "physics-gpr", "svm")


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


def check_document_rows(doc: Mapping[str, Any], where: str) -> None:
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


def _first_error(exc: ValidationError) -> str:
    first = exc.errors()[0]
    loc = ".".join(str(p) for p in first["loc"]) or "(root)"
    return f"{loc}: {first['msg']}"


def validate_document(doc: Any, where: str) -> ModelFile:
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
    check_document_rows(doc, where)
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
