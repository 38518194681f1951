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

import numpy as np

from liquidtouch.errors import LiquidTouchError, SignalError, TableError

MAX_ABS_SIGNAL = 1e12
"""Largest magnitude of a signal value taken in (``fit``'s ``u``, any unit; pixels in
practice, where 1e12 is already absurd): beyond it the fit's squares overflow."""
MAX_ABS_POSITION_PX = 1e6
"""Largest magnitude of a marker position taken in [px] (a sensor image is < 1e5 px)."""
MAX_ABS_TIME_S = 1e11
"""Largest magnitude of a time taken in [s] (epoch seconds, ~1.8e9, fit well)."""
MIN_TIME_STEP_S = 1e-6
"""Smallest step between consecutive frame or sample times [s] (1 MHz)."""
MAX_RATE_HZ = 1.0 / MIN_TIME_STEP_S
"""Largest frame or sample rate taken in [Hz]."""
MIN_FIT_SAMPLES = 20
"""Fewest samples the oscillation fit takes (``fit``); ``dataset add`` refuses a recording
of fewer frames, which no feature can come from."""
MIN_FIT_DURATION_S = 2.0
"""Shortest signal the oscillation fit takes [s] (``fit``); ``dataset add`` refuses a
shorter recording."""


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


def check_magnitude(
    values: np.ndarray,
    what: str,
    limit: float,
    unit: str,
    error: type[LiquidTouchError] = TableError,
) -> None:
    """Refuse finite ``values`` of magnitude over ``limit`` [``unit``] (NaN is let through:
    the caller says what a missing value means)."""
    values = np.asarray(values, dtype=float)
    big = np.abs(values) > limit
    if big.any():
        k = int(np.argmax(big.ravel()))
        raise error(
            f"{what} holds {int(big.sum())} value(s) beyond ±{limit:g} {unit} (first "
            f"{values.ravel()[k]:.3g}); such numbers are not a measurement"
        )


def finite_array(
    x: object, what: str, min_ndim: int, error: type[LiquidTouchError] = SignalError
) -> np.ndarray:
    """``x`` as a float array of at least ``min_ndim`` dimensions, non-empty and finite;
    ``error`` otherwise."""
    try:
        x = np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        raise error(f"{what} must be an array of real numbers") from None
    if x.ndim < min_ndim or x.size == 0:
        raise error(f"{what} must be a non-empty {min_ndim}-D array, got shape {x.shape}")
    if not np.isfinite(x).all():
        raise error(f"{what} holds NaN/inf values; interpolate or drop them first")
    return x


def check_times(
    t: object,
    what: str,
    error: type[LiquidTouchError] = SignalError,
    *,
    min_count: int = 2,
    first: int = 0,
) -> np.ndarray:
    """Timestamps [s] as a 1-D float array, or ``error``: the one check of a time axis.

    At least ``min_count`` finite times, each within :data:`MAX_ABS_TIME_S`, strictly
    increasing by at least :data:`MIN_TIME_STEP_S` (a frame or sample rate of at most
    :data:`MAX_RATE_HZ`): what every stage that reads frame or sample times needs.
    Messages number the times from ``first`` (``#first`` is ``t[0]``).
    """
    try:
        t = np.asarray(t, dtype=float)
    except (TypeError, ValueError):
        raise error(f"{what} must be an array of times in seconds") from None
    if t.ndim != 1 or t.size < min_count:
        raise error(
            f"{what} must be a non-empty 1-D array of at least {min_count} strictly increasing "
            "times [s] "
            f"(got shape {t.shape}); sort the frames and drop duplicates"
        )
    bad = ~np.isfinite(t)
    if bad.any():
        raise error(
            f"{what} holds {int(bad.sum())} NaN/inf value(s) (first at "
            f"#{first + int(np.argmax(bad))}); drop them or give real times"
        )
    check_magnitude(t, what, MAX_ABS_TIME_S, "s", error)
    steps = np.diff(t)
    if steps.size and not float(steps.min()) > 0:
        i = int(np.argmax(steps <= 0))
        raise error(
            f"{what} must increase strictly (times [s]), but #{first + i + 1} ({t[i + 1]:.9g} s) "
            f"is not after #{first + i} ({t[i]:.9g} s); sort the frames and drop duplicates"
        )
    if steps.size and float(steps.min()) < MIN_TIME_STEP_S * (1 - 1e-9):  # to rounding
        i = int(np.argmin(steps))
        raise error(
            f"{what} has a step of {float(steps[i]):.3g} s (after #{first + i}); consecutive "
            "times must "
            f"be at least {MIN_TIME_STEP_S:g} s apart (at most {MAX_RATE_HZ:g} Hz)"
        )
    return t
