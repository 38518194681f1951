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

import numpy as np

from liquidtouch._core.checks import as_number
from liquidtouch.errors import ModelFileError, SignalError

#: targets the fit itself reports, without a model
FIT_TARGETS = ("decay_rate", "angular_frequency")
#: points per feature of the grid over the training domain on which a model's smallest
#: calibrated std is found (:func:`std_floors`; 30 × 30 rows: a few ms of a GP's predict)
FLOOR_GRID_POINTS = 30


def check_live_model(model: object) -> str:
    """``"regression"`` or ``"classification"``: the kind of a :class:`PropertyModel`.

    Anything else raises :class:`ModelFileError`.
    """
    kind = getattr(model, "kind", None)
    if kind not in ("regression", "classification"):
        raise ModelFileError(
            "the live estimate needs a model from 'train' (targets such as height_mm) or "
            f"'classify' (liquid names); got {type(model).__name__}"
        )
    return kind


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


def check_until_std(
    until_std: Mapping[str, float],
    model_targets: Sequence[str] = (),
    model_kind: str = "",
) -> None:
    """Refuse targets that are neither fit targets nor ``model_targets`` (before streaming).

    ``model_kind`` is the model's (``"regression"``, ``"classification"``, ``""`` for none).
    A model target without a model, one the model file does not predict, or any model
    target with a classifier (its answer has no std) raises :class:`ModelFileError`; a bad
    threshold raises :class:`SignalError`.
    """
    for target, std in until_std.items():
        if not 0 < as_number(std) < math.inf:
            raise SignalError(f"the std threshold of {target!r} must be a number > 0, got {std!r}")
        if target in FIT_TARGETS or target in model_targets:
            continue
        fit = ", ".join(FIT_TARGETS)
        if model_kind == "classification":
            raise ModelFileError(
                f"--until-std {target}: the --model is a classifier (from classify): it names "
                f"the liquid with probabilities, no std; the targets are {fit}, or give a "
                "regression model (from train) for properties such as height_mm"
            )
        if model_targets:
            known = ", ".join([*FIT_TARGETS, *model_targets])
            raise ModelFileError(
                f"--until-std {target}: unknown target; the model predicts {known}"
            )
        raise ModelFileError(
            f"--until-std {target}: unknown target; without --model the stream reports {fit} "
            "(give --model for properties such as height_mm)"
        )


def std_floors(model: object, targets: Sequence[str]) -> dict[str, float]:
    """``{target: the smallest std the regression ``model`` gives anywhere in its training
    domain}`` [the target's unit]: its calibrated predictive std with exact λ and ω, on a
    :data:`FLOOR_GRID_POINTS`² grid over the domain and at the training rows (the fit's std
    only adds to it), so a streamed prediction's std never falls below it."""
    bounds = model.input_domain() if targets else None
    if bounds is None:
        return {}
    (lam0, lam1), (om0, om1) = bounds
    lam, omega = np.meshgrid(
        np.linspace(max(lam0, 1e-9), lam1, FLOOR_GRID_POINTS),
        np.linspace(om0, om1, FLOOR_GRID_POINTS),
    )
    X = np.column_stack([lam.ravel(), omega.ravel()])
    if model.feature_map.is_identity:  # the std is least at the training rows: add them
        X = np.vstack([X, *(getattr(model.regressors[t], "X_train_", X[:0]) for t in targets)])
    predicted = model.predict(X)
    return {t: float(np.min(predicted[t][1])) for t in targets if t in predicted}


def unreachable_targets(model: object | None, until_std: Mapping[str, float]) -> dict[str, float]:
    """``{target: floor}`` of the ``until_std`` targets whose threshold lies below the regression
    ``model``'s calibrated std floor (:func:`std_floors`): their std can never meet it."""
    if model is None or getattr(model, "kind", "") != "regression":
        return {}
    wanted = [t for t in until_std if t in model.targets]
    return {t: f for t, f in std_floors(model, wanted).items() if until_std[t] <= f}


def unreachable_here(
    model: object, decay_rate: float, angular_frequency: float, until_std: Mapping[str, float]
) -> dict[str, float]:
    """``{target: the model's calibrated std at (λ, ω)}`` of the ``until_std`` targets whose
    threshold lies below it: with exact λ and ω the std is that, and the fit's std only adds
    to it, so this stream's estimate can never meet them."""
    wanted = [t for t in until_std if t in getattr(model, "targets", ())]
    if not wanted:
        return {}
    predicted = model.predict(np.array([[float(decay_rate), float(angular_frequency)]]))
    floors = {t: float(predicted[t][1][0]) for t in wanted}
    return {t: f for t, f in floors.items() if until_std[t] <= f}


def unreachable_message(
    unreachable: Mapping[str, float],
    until_std: Mapping[str, float],
    where: str = "at the estimated λ and ω",
) -> str:
    """One sentence per unreachable target: its threshold, the model's floor ``where`` (e.g.
    ``"anywhere in its training domain"``), what happens."""
    return " ".join(
        f"--until-std {t}={until_std[t]:g} cannot be met: this model's calibrated std of {t} "
        f"is {floor:.3g} {where} (the fit's std only adds to it); {t} is shown as it comes "
        "and the stream runs to its end."
        for t, floor in unreachable.items()
    )


#: what :func:`unreachable_message` says of a target below the model's floor everywhere
EVERYWHERE = "or more anywhere in its training domain"


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
