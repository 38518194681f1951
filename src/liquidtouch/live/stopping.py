"""When a stream may stop early: every requested target's std below its threshold.

``--until-std height_mm=0.5 --until-std log10_viscosity_cst=0.05`` becomes
``{"height_mm": 0.5, "log10_viscosity_cst": 0.05}`` (:func:`parse_until_std`);
a target is ``decay_rate`` [1/s], ``angular_frequency`` [rad/s] or a target of
the model file (its std is the predicted std, in the target's unit).
:func:`check_until_std` refuses targets the stream cannot report before any
frame is read.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

from liquidtouch._core.checks import as_number
from liquidtouch.errors import ModelFileError, SignalError

#: targets the fit itself reports, without a model
FIT_TARGETS = ("decay_rate", "angular_frequency")


def parse_until_std(items: Sequence[str]) -> dict[str, float]:
    """``["TARGET=STD", ...]`` → ``{target: std}``; SignalError for a malformed item.

    The std must be a finite number > 0 (in the target's unit); a target given twice
    is refused.
    """
    out: dict[str, float] = {}
    for item in items:
        target, sep, text = str(item).partition("=")
        target = target.strip()
        if not sep or not target:
            raise SignalError(
                f"--until-std {item!r} must be TARGET=STD, e.g. --until-std height_mm=0.5"
            )
        value = as_number(text.strip()) if text.strip() else math.nan
        if not 0 < value < math.inf:
            raise SignalError(
                f"--until-std {item!r}: the std must be a number > 0 in the target's unit, "
                f"got {text.strip()!r}"
            )
        if target in out:
            raise SignalError(f"--until-std names {target!r} twice; give each target once")
        out[target] = float(value)
    return out


def check_until_std(until_std: Mapping[str, float], model_targets: Sequence[str] = ()) -> None:
    """Refuse targets that are neither fit targets nor ``model_targets`` (before streaming).

    A model target without a model, or one the model file does not predict, raises
    :class:`ModelFileError`; a bad threshold raises :class:`SignalError`.
    """
    for target, std in until_std.items():
        if not 0 < as_number(std) < math.inf:
            raise SignalError(f"the std threshold of {target!r} must be a number > 0, got {std!r}")
        if target in FIT_TARGETS or target in model_targets:
            continue
        known = ", ".join([*FIT_TARGETS, *model_targets])
        where = "the model predicts" if model_targets else "without --model the stream reports"
        raise ModelFileError(
            f"--until-std {target}: unknown target; {where} {known}"
            + ("" if model_targets else " (give --model for properties such as height_mm)")
        )


def stop_reached(until_std: Mapping[str, float], stds: Mapping[str, float]) -> bool:
    """Whether every target of ``until_std`` has a finite std in ``stds`` below its threshold.

    No targets: never (the stream runs to its end).
    """
    if not until_std:
        return False
    return all(
        math.isfinite(stds.get(target, math.nan)) and stds[target] < limit
        for target, limit in until_std.items()
    )
