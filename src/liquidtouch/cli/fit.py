"""``liquidtouch fit``: fit the damped-oscillation model to a signal CSV."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Annotated

import typer

from liquidtouch.cli import options
from liquidtouch.errors import SignalError

SignalArgument = Annotated[
    Path | None,
    typer.Argument(
        help="Signal CSV with header 't,u' (t in seconds, u in any unit), e.g. from "
        "extract --signal-out.",
        show_default=False,
    ),
]
FitPlot = Annotated[
    Path | None,
    typer.Option(
        "--plot",
        help="Write a figure of the fitted window: signal, fit, both modes and residual "
        "(format from the suffix; PNG without one).",
        show_default=False,
    ),
]
Example = Annotated[
    bool, typer.Option("--example", help="Fit the built-in example signal instead of a file.")
]


def register(app: typer.Typer) -> None:
    """Register this module's commands on ``app``."""
    app.command("fit")(fit)


def fit(
    signal: SignalArgument = None,
    as_json: options.Json = False,
    loss: options.Loss = options.DEFAULT_LOSS,
    model: options.FitModel = options.DEFAULT_FIT_MODEL,
    band_low_hz: options.BandLow = options.DEFAULT_BAND_LOW_HZ,
    band_high_hz: options.BandHigh = options.DEFAULT_BAND_HIGH_HZ,
    noise: options.Noise = options.DEFAULT_NOISE,
    start: options.Start = None,
    plot: FitPlot = None,
    example: Example = False,
) -> None:
    """Fit a damped oscillation + drift to a signal; print λ, ω and their errors.

    By default (--start auto) the fit covers the free decay after the push, as
    extract does: a whole record (before the push, the push, the ring-down) gives
    the same λ and ω as extract. A signal that already starts at the release needs
    --start 0 (its largest excursion may come later, where two modes beat); the
    built-in example is fitted from its first sample unless --start is given; it is
    drawn from the paper's two-mode model (--model two-mode fits that model).
    """
    from liquidtouch.fit.example import example_signal

    if example == (signal is not None):
        raise SignalError("give either a SIGNAL.csv or --example (exactly one)")
    settings = options.fit_settings(loss, model, band_low_hz, band_high_hz, noise, start)
    if plot is not None:
        from liquidtouch.io.figures import check_figure_path

        check_figure_path(plot)  # before the fit: a typo in --plot costs nothing
    if example:
        t, u = example_signal()
        source = "built-in example signal"
        if start is None:  # the example starts at the release
            settings = dataclasses.replace(settings, start=float(t[0]))
    else:
        from liquidtouch.io.signal_csv import read_signal_csv

        t, u = read_signal_csv(signal)
        source = str(signal)
    t_fit, u_fit = settings.window(t, u)
    result = settings.fit(t, u)
    if plot is not None:
        from liquidtouch.fit.plot import plot_fit

        plot_fit(t_fit, u_fit, result, plot)
    from liquidtouch.cli.format import gap_warning

    gap = gap_warning(result)
    if gap:
        typer.echo(f"warning: {gap}", err=True)
    if as_json:
        typer.echo(json.dumps(result.to_dict()))
        return
    _print_table(result, source, plot)


def _print_table(result, source: str, plot: Path | None) -> None:
    from rich.console import Console

    from liquidtouch.cli.format import fit_quality, fit_table

    Console().print(fit_table(result, f"{result.model} fit of {source} (loss={result.loss})"))
    typer.echo(f"model: {result.model} ({result.model_reason})")
    typer.echo(fit_quality(result) + (f"   plot: {plot}" if plot else ""))
