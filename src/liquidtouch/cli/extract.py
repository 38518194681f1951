"""``liquidtouch extract``: GelSight videos (or a trial directory) → u(t) → oscillation fit."""

from __future__ import annotations

import json
from pathlib import Path

import typer


def register(app: typer.Typer) -> None:
    """Register this module's commands on ``app``."""
    app.command("extract")(extract)


def extract(
    sources: list[Path] = typer.Argument(
        ...,
        help="Video files (one per sensor), image folders, or one trial directory "
        "(its meta.json lists the videos).",
        show_default=False,
    ),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object on stdout."),
    signal_out: Path | None = typer.Option(
        None, "--signal-out", help="Write the signal u(t) as CSV (header 't,u')."
    ),
    tracks_out: Path | None = typer.Option(
        None, "--tracks-out", help="Write the marker tracks of every sensor as .npz."
    ),
    plot: Path | None = typer.Option(
        None, "--plot", help="Write a PNG: markers on the first frame, motions, u(t) and fit."
    ),
    lowpass_hz: float = typer.Option(3.0, "--lowpass", help="Low-pass cut-off [Hz]."),
    n_markers: int = typer.Option(16, "--markers", help="Markers (across sensors) to keep."),
    fps: float = typer.Option(30.0, "--fps", help="Frame rate of image folders [Hz]."),
) -> None:
    """Track the markers, build the tactile signal u(t) and fit the damped oscillation.

    --json prints the fit (decay_rate, angular_frequency, fast_*, *_std, r2, ...)
    plus explained_variance, n_markers, fps and frames.
    """
    from liquidtouch.errors import SignalError
    from liquidtouch.extraction import extract as run_extract
    from liquidtouch.extraction import plot_extraction

    if n_markers < 1:
        raise SignalError(f"--markers must be at least 1, got {n_markers}")
    result = run_extract(
        sources, lowpass_hz=lowpass_hz, n_markers=n_markers, fps=fps, progress=not as_json
    )
    if signal_out is not None:
        from liquidtouch.io.signal_csv import write_signal_csv

        write_signal_csv(signal_out, result.signal.t, result.signal.u)
    if tracks_out is not None:
        from liquidtouch.tracking.tracks import save_tracks

        save_tracks(tracks_out, result.tracks)
    if plot is not None:
        plot_extraction(result, plot)
    summary = result.to_dict()
    if as_json:
        typer.echo(json.dumps(summary))
        return
    sig = result.signal
    typer.echo(
        f"{len(result.tracks)} sensor(s), {sum(tr.n_markers for tr in result.tracks)} markers "
        f"tracked; {sig.n_markers} used, explained variance {sig.explained_variance:.1%}, "
        f"{len(sig.t)} samples at {sig.fps:.3g} fps"
    )
    for key in ("decay_rate", "angular_frequency", "fast_decay_rate", "fast_angular_frequency"):
        value, std = summary.get(key), summary.get(f"{key}_std")
        if value is not None:
            typer.echo(f"  {key:24s} {value:.4g}" + (f" ± {std:.2g}" if std is not None else ""))
    typer.echo(f"  {'r2':24s} {summary.get('r2')}")
