"""How the commands print numbers: a value rounded to its uncertainty, plain values, tables.

- :func:`with_uncertainty`: the standard deviation to 2 significant digits and the
  value to the same decimal place (``11.0000 ± 0.0051``, ``0.1735 ± 0.0021``,
  ``1230 ± 560``), in scientific notation for very large or small magnitudes;
- :func:`number`: a plain value to 4 significant digits, fixed-point in a
  readable range (``0.01235``, ``12346``), else scientific;
- :func:`fixed`: a fixed number of decimals (R² to 4: ``0.9990``);
- :func:`fit_table`: the slow/fast-mode table of an oscillation fit, units in
  the headers (escaped: rich would read ``[rad/s]`` as markup);
- :func:`warn`: a ``warning: ...`` line on stderr (stdout stays the result).

A missing value (None, NaN) prints as ``—``.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from rich.table import Table

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


def fit_table(result: object, title: str) -> Table:
    """The slow/fast-mode table of an ``OscillationFit``: λ [1/s], ω [rad/s], amplitude."""
    from rich.markup import escape
    from rich.table import Table

    table = Table(title=escape(title))
    table.add_column("mode")
    table.add_column(escape("decay rate λ [1/s]"), justify="right")
    table.add_column(escape("angular frequency ω [rad/s]"), justify="right")
    table.add_column("amplitude", justify="right")
    for mode, prefix in (("slow", ""), ("fast", "fast_")):
        table.add_row(
            mode,
            with_uncertainty(
                getattr(result, f"{prefix}decay_rate"), getattr(result, f"{prefix}decay_rate_std")
            ),
            with_uncertainty(
                getattr(result, f"{prefix}angular_frequency"),
                getattr(result, f"{prefix}angular_frequency_std"),
            ),
            number(getattr(result, f"{prefix}amplitude")),
        )
    return table


def fit_quality(result: object) -> str:
    """One line: R² (4 decimals), noise level, samples and the fitted window [s]."""
    start = float(result.t0)
    end = start + float(result.duration_s)
    gaps = getattr(result, "gap_share", 0.0)
    return (
        f"R² = {fixed(result.r2)}   noise σ = {number(result.noise_std, 3)}   "
        f"{result.n_samples} samples from {number(start, 3)} s to {number(end, 3)} s"
        + (f" ({gaps:.1%} of it in gaps, not fitted)" if gaps > 0 else "")
    )


def gap_warning(result: object) -> str | None:
    """A line when a gap in the samples ends where the fitted free decay starts, else None."""
    gap = getattr(result, "gap_before_start_s", 0.0)
    if not gap > 0:
        return None
    return (
        f"a gap of {gap:.2f} s without samples ends where the fitted free decay starts "
        f"({float(result.t0):.2f} s): the ring-down may have started inside it, so λ and ω "
        "come from its later part"
    )


def warn(message: str) -> None:
    """Print ``warning: message`` on stderr."""
    import typer

    typer.echo(f"warning: {message}", err=True)
