"""How the commands print numbers: a value rounded to its uncertainty, plain values, tables.

The number formatting itself (:func:`with_uncertainty`, :func:`number`,
:func:`fixed`, :func:`percent`; a missing value prints as ``—``) lives in
:mod:`liquidtouch._core.numbers`, shared with the results' reprs; here are
what only the commands need:

- :func:`fit_table`: the slow/fast-mode table of an oscillation fit, units in
  the headers (escaped: rich would read ``[rad/s]`` as markup);
- :func:`fit_quality`: one line of fit quality;
- :func:`warn`: a ``warning: ...`` line on stderr (stdout stays the result).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from liquidtouch._core.numbers import (
    fixed,
    number,
    with_uncertainty,
)

if TYPE_CHECKING:
    from rich.table import Table

__all__ = ["fit_quality", "fit_table", "warn"]


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
    return (
        f"R² = {fixed(result.r2)}   noise σ = {number(result.noise_std, 3)}   "
        f"{result.n_samples} samples from {number(start, 3)} s to {number(end, 3)} s"
    )


def warn(message: str) -> None:
    """Print ``warning: message`` on stderr."""
    import typer

    typer.echo(f"warning: {message}", err=True)
