"""Labels of a trial given by hand (``dataset add --label key=value``), validated.

The label columns (:data:`~liquidtouch.io.dataset.LABEL_COLUMNS`) only.
``liquid`` and ``container`` may be any name (a real recording may use liquids
the simulator does not know), but a name that differs from a catalogue name or
from one already in the dataset only in case, spaces, ``_`` or ``-`` is refused
(it would split one class in two). Numeric labels must be finite numbers
(``height_mm`` [mm] and ``viscosity_cst`` [cSt] > 0, ``sugar_concentration``
[g per 100 g water] >= 0, ``temperature_c`` [°C] above absolute zero).
``log10_viscosity_cst`` is derived from ``viscosity_cst`` and vice versa; given
both, they must agree.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence

from liquidtouch._core.containers import CONTAINERS
from liquidtouch._core.liquids import LIQUIDS
from liquidtouch.errors import DatasetError
from liquidtouch.io.dataset import LABEL_COLUMNS, NUMERIC_LABELS

#: Longest name (label text, trial path) accepted [characters].
MAX_NAME = 200
#: ``viscosity_cst`` and ``log10_viscosity_cst`` given together must agree this well (log10)
LOG10_TOLERANCE = 1e-3
_POSITIVE = {"height_mm", "viscosity_cst"}
_NON_NEGATIVE = {"sugar_concentration"}


def parse_label_options(items: Sequence[str]) -> dict[str, str]:
    """``["liquid=water", "height_mm=25"]`` → ``{"liquid": "water", "height_mm": "25"}``."""
    labels: dict[str, str] = {}
    for item in items:
        key, sep, value = str(item).partition("=")
        key = key.strip()
        if not sep or not key:
            raise DatasetError(f"--label {item!r} must be KEY=VALUE, e.g. --label liquid=water")
        if key in labels:
            raise DatasetError(f"label {key} is given twice")
        labels[key] = value.strip()
    return labels


def typed_labels(items: Sequence[str]) -> dict[str, object]:
    """``KEY=VALUE`` options → a dict: numbers become numbers, ``null``/``none``/empty None.

    Unlike :func:`check_labels` any key is kept (a recording may carry extra fields).
    """
    labels: dict[str, object] = {}
    for key, text in parse_label_options(items).items():
        if text.lower() in ("null", "none", ""):
            labels[key] = None
            continue
        try:
            number = float(text)
        except ValueError:
            labels[key] = text
            continue
        if not math.isfinite(number):
            raise DatasetError(f"--label {key}: {text!r} is not a finite number")
        labels[key] = int(number) if number.is_integer() and "." not in text else number
    return labels


def _normal(name: str) -> str:
    return re.sub(r"[\s_-]+", "-", name.strip().lower())


def check_labels(
    labels: Mapping[str, object], known: Mapping[str, Sequence[str]] | None = None
) -> tuple[dict[str, object], list[str]]:
    """Validated labels (all :data:`LABEL_COLUMNS`, ``None`` when not given) and warnings.

    ``known``: names already used per name column (``liquid``, ``container``),
    e.g. those of the dataset's manifest. See the module doc for the rules.
    """
    import difflib

    catalogue = {"liquid": list(LIQUIDS), "container": list(CONTAINERS)}
    out: dict[str, object] = dict.fromkeys(LABEL_COLUMNS)
    warnings: list[str] = []
    for key, raw in labels.items():
        if key not in LABEL_COLUMNS:
            close = difflib.get_close_matches(key, LABEL_COLUMNS, n=1)
            hint = f" (did you mean {close[0]}?)" if close else ""
            raise DatasetError(
                f"unknown label {key!r}{hint}; the labels are {', '.join(LABEL_COLUMNS)}"
            )
        text = "" if raw is None else str(raw).strip()
        if not text:
            raise DatasetError(f"label {key} is empty; leave it out if it is not known")
        if key in NUMERIC_LABELS:
            out[key] = _numeric_label(key, text)
            continue
        if len(text) > MAX_NAME or any(not ch.isprintable() for ch in text):
            raise DatasetError(f"label {key} {text!r} must be a short printable name")
        names = [*catalogue[key], *(known or {}).get(key, [])]
        for name in dict.fromkeys(names):
            if name != text and _normal(name) == _normal(text):
                raise DatasetError(
                    f"{key} {text!r} differs from {name!r} only in spelling; use "
                    f"--label {key}={name} (or a clearly different name)"
                )
        if text not in names:
            warnings.append(
                f"{key} {text!r} is not in the simulator's catalogue "
                f"({', '.join(catalogue[key])}); kept as a label"
            )
        out[key] = text
    _derive_viscosity(out)
    return out, warnings


def _numeric_label(key: str, text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise DatasetError(f"label {key} must be a number, got {text!r}") from None
    if not math.isfinite(value):
        raise DatasetError(f"label {key} must be a finite number, got {text!r}")
    if key in _POSITIVE and value <= 0:
        raise DatasetError(f"label {key} must be > 0, got {text}")
    if key in _NON_NEGATIVE and value < 0:
        raise DatasetError(f"label {key} must be >= 0, got {text}")
    if key == "temperature_c" and value <= -273.15:
        raise DatasetError(f"label temperature_c must be above absolute zero, got {text} °C")
    return value


def _derive_viscosity(labels: dict[str, object]) -> None:
    nu, log_nu = labels["viscosity_cst"], labels["log10_viscosity_cst"]
    if nu is not None and log_nu is not None:
        if abs(math.log10(nu) - log_nu) > LOG10_TOLERANCE:  # type: ignore[arg-type]
            raise DatasetError(
                f"viscosity_cst {nu:g} and log10_viscosity_cst {log_nu:g} disagree "
                f"(log10({nu:g}) = {math.log10(nu):.4f}); give one of them"  # type: ignore[arg-type]
            )
    elif nu is not None:
        labels["log10_viscosity_cst"] = math.log10(nu)  # type: ignore[arg-type]
    elif log_nu is not None:
        labels["viscosity_cst"] = 10.0**log_nu  # type: ignore[operator]
