"""``liquidtouch fit``: fit the damped-oscillation model to a signal CSV."""

from __future__ import annotations

import json
from pathlib import Path

import typer

from liquidtouch.errors import SignalError


def register(app: typer.Typer) -> None:
    """Register this module's commands on ``app``."""
    app.command("fit")(fit)


def fit(
    signal: Path | None = typer.Argument(
        None, help="Signal CSV with header 't,u' (t in seconds, u in any unit).", show_default=False
    ),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object on stdout."),
    loss: str = typer.Option(
        "paper", "--loss", help="'paper': Σ(u−û)²/(u²+δ) (default); 'ls': plain least squares."
    ),
    model: str = typer.Option(
        "two-mode",
        "--model",
        help="'two-mode' (falls back to one mode if the data do not support a fast mode) "
        "or 'single-mode'.",
    ),
    band_low_hz: float = typer.Option(0.3, "--band-low", help="Lowest slosh frequency [Hz]."),
    band_high_hz: float = typer.Option(5.0, "--band-high", help="Highest slosh frequency [Hz]."),
    noise: str = typer.Option(
        "white",
        "--noise",
        help="Noise assumption for the standard errors: 'white' or 'correlated' (low-passed).",
    ),
    plot: Path | None = typer.Option(
        None, "--plot", help="Write a PNG of the signal, fit, both modes and residual."
    ),
    example: bool = typer.Option(
        False, "--example", help="Fit the built-in example signal instead of a file."
    ),
) -> None:
    """Fit u ≈ B e^{-λt}cos(ωt+ψ) + B' e^{-λ't}cos(ω't+ψ') + drift; print λ, ω and errors."""
    from liquidtouch.fit.oscillation import example_signal, fit_oscillation

    if example == (signal is not None):
        raise SignalError("give either a SIGNAL.csv or --example (exactly one)")
    if example:
        t, u = example_signal()
        source = "built-in example signal"
    else:
        from liquidtouch.io.signal_csv import read_signal_csv

        t, u = read_signal_csv(signal)
        source = str(signal)
    result = fit_oscillation(
        t, u, loss=loss, model=model, band_hz=(band_low_hz, band_high_hz), noise=noise
    )
    if plot is not None:
        from liquidtouch.fit.plot import plot_fit

        plot_fit(t, u, result, plot)
    if as_json:
        typer.echo(json.dumps(result.to_dict()))
        return
    _print_table(result, source, plot)


def _print_table(result, source: str, plot: Path | None) -> None:
    from rich.console import Console
    from rich.table import Table

    def fmt(value: float, std: float | None = None) -> str:
        if value != value:  # NaN: mode not fitted
            return "—"
        return f"{value:.4g}" + (f" ± {std:.2g}" if std is not None and std == std else "")

    table = Table(title=f"{result.model} fit of {source} (loss={result.loss})")
    table.add_column("mode")
    table.add_column("decay rate λ [1/s]", justify="right")
    table.add_column("angular frequency ω [rad/s]", justify="right")
    table.add_column("amplitude", justify="right")
    table.add_row(
        "slow",
        fmt(result.decay_rate, result.decay_rate_std),
        fmt(result.angular_frequency, result.angular_frequency_std),
        fmt(result.amplitude),
    )
    table.add_row(
        "fast",
        fmt(result.fast_decay_rate, result.fast_decay_rate_std),
        fmt(result.fast_angular_frequency, result.fast_angular_frequency_std),
        fmt(result.fast_amplitude),
    )
    console = Console()
    console.print(table)
    console.print(
        f"R² = {result.r2:.4f}   noise σ = {result.noise_std:.3g}   "
        f"{result.n_samples} samples over {result.duration_s:.3g} s"
        + (f"   plot: {plot}" if plot else "")
    )
