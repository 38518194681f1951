"""Number checks shared by every stage: a value in, a float (or a typed error) out.

:func:`as_number` turns anything into a float that fails every range check when
it is not a real number (so ``not low <= as_number(x) <= high`` refuses bools,
strings, ``None`` and NaN alike); :func:`check_range`, :func:`check_positive`
and :func:`check_int` raise the :class:`~liquidtouch.errors.LiquidTouchError`
subclass the caller names, with a message that says what was expected.
"""

from __future__ import annotations

import math
import numbers

from liquidtouch.errors import LiquidTouchError, TableError


def as_number(value: object) -> float:
    """``value`` as a float; NaN (fails every range check) when it is not a real number."""
    if isinstance(value, bool):
        return float("nan")
    try:
        return float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return float("nan")


def is_real(value: object) -> bool:
    """True for a finite real number that is not a bool."""
    return (
        isinstance(value, numbers.Real)
        and not isinstance(value, bool)
        and math.isfinite(float(value))
    )


def check_range(
    value: object,
    what: str,
    low: float,
    high: float,
    unit: str,
    error: type[LiquidTouchError] = LiquidTouchError,
) -> float:
    """``value`` as a float in ``[low, high]`` [``unit``]; ``error`` otherwise."""
    if not is_real(value):
        raise error(f"{what} must be a finite number of {unit}, got {value!r}")
    number = float(value)  # type: ignore[arg-type]
    if not low <= number <= high:
        raise error(f"{what} {number:g} {unit} is outside {low:g}-{high:g} {unit}")
    return number


def check_int(
    value: object, name: str, minimum: int, error: type[LiquidTouchError] = TableError
) -> int:
    """``value`` as an int >= ``minimum``; ``error`` otherwise (bools refused)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < minimum:
        raise error(f"{name} must be an integer >= {minimum}; got {value!r}")
    return int(value)


def check_positive(
    value: object,
    name: str,
    allow_zero: bool = False,
    error: type[LiquidTouchError] = TableError,
) -> float:
    """``value`` as a finite float > 0 (>= 0 with ``allow_zero``); ``error`` otherwise."""
    if not is_real(value) or value < 0 or (value == 0 and not allow_zero):  # type: ignore[operator]
        raise error(
            f"{name} must be a finite number {'>=' if allow_zero else '>'} 0; got {value!r}"
        )
    return float(value)  # type: ignore[arg-type]
