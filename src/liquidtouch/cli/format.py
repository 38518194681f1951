"""How the commands print numbers: a value rounded to its uncertainty, plain values, tables.

The number formatting itself (:func:`with_uncertainty`, :func:`number`,
:func:`fixed`, :func:`percent`; a missing value prints as ``—``) lives in
:mod:`liquidtouch._core.numbers`, shared with the results' reprs; here are
what only the commands need:

- :func:`fit_table`: the slow/fast-mode table of an oscillation fit, units in
  the headers (escaped: rich would read ``[rad/s]`` as markup);
- :func:`fit_quality`: one line of fit quality;
- :func:`warn`: a ``warning: ...`` line on stderr (stdout stays the result);
  :func:`note`: an informational line on stderr;
- :func:`cut_values`: every over-long value of a message cut to
  :data:`MAX_VALUE_CHARS` (a 100 KB label must not give a 100 KB error line).
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING

from liquidtouch._core.numbers import (
    fixed,
    number,
    with_uncertainty,
)

if TYPE_CHECKING:
    from rich.table import Table

    from liquidtouch.fit.result import OscillationFit

__all__ = ["MAX_VALUE_CHARS", "cut_values", "fit_quality", "fit_table", "note", "warn"]

MAX_VALUE_CHARS = 80
"""Longest run of non-blank characters (a value, a path) printed in a message."""
_LONG = re.compile(r"\S{" + str(MAX_VALUE_CHARS + 1) + ",}")


def cut_values(message: str) -> str:
    """``message`` with every run of over :data:`MAX_VALUE_CHARS` non-blank characters cut
    to its first and last characters around ``…`` (a path keeps its file name)."""
    half = (MAX_VALUE_CHARS - 1) // 2

    def cut(match: re.Match[str]) -> str:
        text = match.group(0)
        return f"{text[:half]}…{text[-(MAX_VALUE_CHARS - 1 - half) :]}"

    return _LONG.sub(cut, message)


def fit_table(result: OscillationFit, title: str) -> Table:
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


def fit_quality(result: OscillationFit) -> str:
    """One line: R² (4 decimals), noise level, samples and the fitted window [s]."""
    start = float(result.t0)
    end = start + float(result.duration_s)
    gaps = getattr(result, "gap_share", 0.0)
    return (
        f"R² = {fixed(result.r2)}   noise σ = {number(result.noise_std, 3)}   "
        f"{result.n_samples} samples from {number(start, 3)} s to {number(end, 3)} s"
        + (f" ({gaps:.1%} of it in gaps, not fitted)" if gaps > 0 else "")
    )


def gap_warning(result: OscillationFit) -> str | None:
    """A line when a gap swallowed the ring-down, or a gap in the samples ends where the
    fitted free decay starts; else None."""
    from liquidtouch.extraction.fit_settings import ring_down_swallowed

    if ring_down_swallowed(result):
        return (
            f"gaps without samples cover {result.ring_down_gap_share:.0%} of the ring-down "
            f"above the noise (from {float(result.t0):.2f} s): the gap swallowed the ring-down, "
            "so λ and ω come from its tail and may be far off; record without stalls"
        )
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

    typer.echo(f"warning: {cut_values(message)}", err=True)


def note(message: str) -> None:
    """Print ``message`` on stderr: what the user should know, not a warning."""
    import typer

    typer.echo(cut_values(message), err=True)
