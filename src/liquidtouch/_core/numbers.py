"""Numbers as text: a value rounded to its uncertainty, plain values, percentages.

- :func:`with_uncertainty`: the standard deviation to 2 significant digits and the
  value to the same decimal place (``11.0000 ± 0.0051``, ``0.1735 ± 0.0021``,
  ``1230 ± 560``), in scientific notation for very large or small magnitudes;
- :func:`number`: a plain value to 4 significant digits, fixed-point in a
  readable range (``0.01235``, ``12346``), else scientific;
- :func:`fixed`: a fixed number of decimals (R² to 4: ``0.9990``);
- :func:`percent`: a fraction as a percentage (``99.8 %``).

A missing value (None, NaN) prints as ``—``. Pure functions of their arguments:
the command line (:mod:`liquidtouch.cli.format`) and the results' reprs share them.
"""

from __future__ import annotations

import math

__all__ = [
    "FIXED_RANGE",
    "MISSING",
    "SIGNIFICANT",
    "STD_DIGITS",
    "fixed",
    "number",
    "percent",
    "with_uncertainty",
]

MISSING = "—"
SIGNIFICANT = 4  # digits of a plain value
STD_DIGITS = 2  # significant digits of an uncertainty
FIXED_RANGE = (1e-3, 1e6)  # magnitudes printed in fixed point; scientific outside


def _finite(value: object) -> float | None:
    try:
        number_ = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return None
    return number_ if math.isfinite(number_) else None


def _exponent(value: float) -> int:
    """The decimal exponent of ``value`` (0 for zero): 12.3 → 1, 0.045 → -2."""
    return math.floor(math.log10(abs(value))) if value else 0


def number(value: object, significant: int = SIGNIFICANT) -> str:
    """``value`` to ``significant`` digits: fixed point for 1e-3 <= |v| < 1e6, else scientific."""
    v = _finite(value)
    if v is None:
        return MISSING
    if v == 0:
        return "0"
    if not FIXED_RANGE[0] <= abs(v) < FIXED_RANGE[1]:
        return f"{v:.{significant - 1}e}"
    decimals = max(0, significant - 1 - _exponent(v))
    text = f"{v:.{decimals}f}"
    if _exponent(float(text)) > _exponent(v) and decimals > 0:  # 9.9996 → 10.000: one too many
        text = f"{v:.{decimals - 1}f}"
    return text


def fixed(value: object, decimals: int = 4) -> str:
    """``value`` with ``decimals`` decimals (R² to 4: ``0.9990``)."""
    v = _finite(value)
    return MISSING if v is None else f"{v:.{decimals}f}"


def percent(value: object, decimals: int = 1) -> str:
    """A fraction as a percentage: 0.9981 → ``99.8 %``."""
    v = _finite(value)
    return MISSING if v is None else f"{100 * v:.{decimals}f} %"


def with_uncertainty(value: object, std: object) -> str:
    """``value ± std``, the std to 2 significant digits and the value to its last decimal.

    Without a usable std (None, NaN, inf, <= 0) the value alone, as :func:`number`.
    """
    v = _finite(value)
    s = _finite(std)
    if v is None:
        return MISSING
    if s is None or s <= 0:
        return number(v)
    place = _exponent(s) - (STD_DIGITS - 1)  # decimal place of the std's last digit
    s = round(s, -place)
    place = _exponent(s) - (STD_DIGITS - 1)  # 0.0996 rounds to 0.10: one digit fewer
    magnitude = max(abs(v), s)
    if not FIXED_RANGE[0] <= magnitude < FIXED_RANGE[1]:
        exponent = _exponent(magnitude)
        scale = 10.0**exponent
        digits = max(0, exponent - place)
        return f"({v / scale:.{digits}f} ± {s / scale:.{digits}f})e{exponent:+03d}"
    if place >= 0:  # the std's last digit is at the units or above: round the value there
        return f"{round(v, -place):.0f} ± {round(s, -place):.0f}"
    return f"{v:.{-place}f} ± {s:.{-place}f}"
