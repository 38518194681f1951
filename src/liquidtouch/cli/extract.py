"""``liquidtouch extract`` (one trial) and ``liquidtouch features`` (a whole dataset).

Both run video → marker tracks → u(t) → oscillation fit with the same options,
declared once in :mod:`liquidtouch.cli.options` (the fit options are ``fit``'s).

``extract`` checks every output path (``--signal-out``, ``--tracks-out``,
``--plot``) before any video is read, and writes the outputs only once everything
(tracking, fit, figure) succeeded: a failed run leaves no partial outputs.
"""

from __future__ import annotations

import contextlib
import json
from pathlib import Path
from typing import Annotated

import typer

from liquidtouch.cli import options
from liquidtouch.errors import DatasetError

Sources = Annotated[
    list[Path],
    typer.Argument(
        help="Video files (one per sensor), image folders, or one trial directory "
        "(its meta.json lists the videos).",
        show_default=False,
    ),
]
SignalOut = Annotated[
    Path | None,
    typer.Option(
        "--signal-out",
        help="Write the whole signal u(t) as CSV (header 't,u'); fit reads it.",
        show_default=False,
    ),
]
TracksOut = Annotated[
    Path | None,
    typer.Option(
        "--tracks-out",
        help="Write the marker tracks of every sensor: .npz (arrays per sensor) or .csv "
        "(long format: t, sensor, marker, x, y, valid), by the suffix.",
        show_default=False,
    ),
]
ExtractionPlot = Annotated[
    Path | None,
    typer.Option(
        "--plot",
        help="Write a figure: markers on the first frame, motions, u(t) and the fit over "
        "its window (format from the suffix; PNG without one).",
        show_default=False,
    ),
]
FolderFps = Annotated[
    float | None,
    typer.Option(
        "--fps",
        help="Frame rate [Hz] of image folders given directly (needed unless the folder "
        "holds timestamps.csv; a trial's folders use its meta.json fps).",
        show_default=False,
    ),
]
Dataset = Annotated[
    Path, typer.Argument(help="Dataset directory (with manifest.csv).", show_default=False)
]
FeaturesOut = Annotated[
    Path | None,
    typer.Option(
        *options.OUT, help="Output CSV (default: DATASET/features.csv).", show_default=False
    ),
]
Source = Annotated[
    options.SourceChoice,
    typer.Option(
        "--source",
        help="gelsight: the sensor videos; wrench: the wrist force/torque (wrench.csv), "
        "which uses --lowpass and the fit options only.",
    ),
]


def register(app: typer.Typer) -> None:
    """Register this module's commands on ``app``."""
    app.command("extract")(extract)
    app.command("features")(features)


def extract(
    sources: Sources,
    as_json: options.Json = False,
    signal_out: SignalOut = None,
    tracks_out: TracksOut = None,
    plot: ExtractionPlot = None,
    lowpass_hz: options.Lowpass = options.DEFAULT_LOWPASS_HZ,
    n_markers: options.Markers = options.DEFAULT_MARKERS,
    sensor: options.Sensor = None,
    fps: FolderFps = None,
    loss: options.Loss = options.DEFAULT_LOSS,
    model: options.FitModel = options.DEFAULT_FIT_MODEL,
    band_low_hz: options.BandLow = options.DEFAULT_BAND_LOW_HZ,
    band_high_hz: options.BandHigh = options.DEFAULT_BAND_HIGH_HZ,
    noise: options.Noise = options.DEFAULT_NOISE,
    start: options.Start = None,
    tracking: options.Tracking = options.DEFAULT_TRACKING,
) -> None:
    """Track the markers, build the tactile signal u(t) and fit the damped oscillation.

    --json prints the fit (decay_rate, angular_frequency, fast_*, *_std, r2, t0,
    duration_s, ...) plus explained_variance, n_markers, fps, frames and the codec
    check (codec, codec_lossless, codec_crf, frozen_step_share, freezing_step_px,
    codec_lambda_bias, codec_at_risk). Lossy video that biases λ gets a
    "warning: ..." line on stderr.
    """
    from liquidtouch.errors import SignalError
    from liquidtouch.extraction.pipeline import extract as run_extract

    if n_markers < 1:
        raise SignalError(f"--markers must be at least 1, got {n_markers}")
    settings = options.fit_settings(loss, model, band_low_hz, band_high_hz, noise, start)
    check_output_paths(signal_out=signal_out, tracks_out=tracks_out, plot=plot)
    result = run_extract(
        sources,
        lowpass_hz=lowpass_hz,
        n_markers=n_markers,
        fps=fps,
        progress=True,
        fit_settings=settings,
        sensors=sensor or None,
        tracking=str(tracking),
    )
    write_outputs(result, signal_out=signal_out, tracks_out=tracks_out, plot=plot)
    _warn_extraction(result)
    if as_json:
        out = result.to_dict()
        if result.diagnostics is not None:
            out.update(result.diagnostics.to_dict())
        typer.echo(json.dumps(out))
        return
    _print_extraction(result, [p for p in (signal_out, tracks_out, plot) if p is not None])


def _warn_extraction(result) -> None:
    """The codec check's and the fit's gap warnings, one ``warning: ...`` line each."""
    from liquidtouch.cli.format import gap_warning

    check = result.diagnostics
    warning = check.warning() if check is not None else None
    if warning:
        typer.echo(f"warning: {warning}", err=True)
    gap = gap_warning(result.fit) if result.fit is not None else None
    if gap:
        typer.echo(f"warning: {gap}", err=True)


def _print_extraction(result, written: list[Path]) -> None:
    from rich.console import Console

    from liquidtouch._core.numbers import number, percent
    from liquidtouch.cli.format import fit_quality, fit_table

    sig = result.signal
    typer.echo(
        f"{len(result.tracks)} sensor(s), {sum(tr.n_markers for tr in result.tracks)} "
        f"markers tracked; {sig.n_markers} used, explained variance "
        f"{percent(sig.explained_variance)}, {len(sig.t)} samples at {number(sig.fps, 3)} fps"
    )
    typer.echo(f"tracking: {result.tracking}")
    fit = result.fit
    Console().print(fit_table(fit, f"{fit.model} fit of the free decay (loss={fit.loss})"))
    typer.echo(f"model: {fit.model} ({fit.model_reason})")
    typer.echo(fit_quality(fit))
    check = result.diagnostics
    if check is not None and check.codec:
        kind = {True: "lossless", False: "lossy", None: "unknown"}[check.lossless]
        typer.echo(
            f"codec {check.codec} ({kind}); frozen marker steps {percent(check.frozen_step_share)}"
        )
    for path in written:
        typer.echo(f"wrote {path}")


def features(
    dataset: Dataset,
    out: FeaturesOut = None,
    as_json: options.Json = False,
    jobs: options.Jobs = 1,
    dask: options.Dask = None,
    source: Source = options.SourceChoice.gelsight,
    lowpass_hz: options.Lowpass = options.DEFAULT_LOWPASS_HZ,
    n_markers: options.Markers = options.DEFAULT_MARKERS,
    sensor: options.Sensor = None,
    loss: options.Loss = options.DEFAULT_LOSS,
    model: options.FitModel = options.DEFAULT_FIT_MODEL,
    band_low_hz: options.BandLow = options.DEFAULT_BAND_LOW_HZ,
    band_high_hz: options.BandHigh = options.DEFAULT_BAND_HIGH_HZ,
    noise: options.Noise = options.DEFAULT_NOISE,
    start: options.Start = None,
    tracking: options.Tracking = options.DEFAULT_TRACKING,
) -> None:
    """Extract (λ, ω) and fit quality for every trial of a dataset → features.csv.

    Parallel, cached per trial (a trial whose files and settings did not change is
    not redone), resumable; a bad trial is recorded with its error and the others
    go on. The table records the liquidtouch version and the settings of the run.
    --json prints the counts, the failed trials and the output path.
    """
    from liquidtouch.batch.features import extract_features
    from liquidtouch.io.dataset import FEATURES_NAME

    settings = options.fit_settings(loss, model, band_low_hz, band_high_hz, noise, start)
    table = extract_features(
        dataset,
        out=out,
        jobs=jobs,
        dask_address=dask,
        source=str(source),
        progress=True,
        lowpass_hz=lowpass_hz,
        n_markers=n_markers,
        sensors=sensor or None,
        fit_settings=settings,
        tracking=str(tracking),
    )
    target = out or Path(dataset) / FEATURES_NAME
    failed = table[table["error"].astype(str) != ""]
    if as_json:
        typer.echo(json.dumps(_features_summary(table, target), ensure_ascii=False))
    else:
        typer.echo(
            f"{len(table) - len(failed)} of {len(table)} trials extracted → {target} "
            f"({table.attrs['n_computed']} computed, {table.attrs['n_cached']} from the cache)"
        )
        for row in failed.itertuples(index=False):
            typer.echo(f"failed: {row.trial}: {row.error}", err=True)
    if len(table) and len(failed) == len(table):  # nothing worked: the exit status says so
        raise DatasetError(f"no trial was extracted: all {len(table)} failed (see above)")


def _features_summary(table, target: Path) -> dict:
    """``features --json``: the counts, the failed trials, the output path and the settings."""
    from liquidtouch import __version__

    failed = table[table["error"].astype(str) != ""]
    return {
        "out": str(target),
        "n_trials": len(table),
        "n_extracted": len(table) - len(failed),
        "n_failed": len(failed),
        "n_computed": table.attrs["n_computed"],
        "n_cached": table.attrs["n_cached"],
        "failed": [{"trial": r.trial, "error": r.error} for r in failed.itertuples()],
        "liquidtouch_version": __version__,
        "settings": table.attrs["settings"],
    }


def check_output_paths(**paths: Path | None) -> None:
    """Raise :class:`OutputError` now for an output that cannot be written (before any work).

    ``plot`` must name a figure format (or have no suffix: PNG), ``tracks_out`` end in
    ``.npz`` or ``.csv``; no output may be
    an existing directory or lie below a file, and two outputs may not be one file.
    """
    from liquidtouch.errors import OutputError
    from liquidtouch.io.figures import check_figure_path
    from liquidtouch.tracking.tracks import tracks_format

    seen: dict[Path, str] = {}
    for option, path in paths.items():
        if path is None:
            continue
        flag = "--" + option.replace("_", "-")
        if option == "plot":
            check_figure_path(path)
        if option == "tracks_out":
            tracks_format(path)
        if path.is_dir():
            raise OutputError(f"cannot write {flag} {path}: it is a directory; give a file name")
        parent = next((p for p in path.parents if p.exists()), None)
        if parent is not None and not parent.is_dir():
            raise OutputError(f"cannot write {flag} {path}: {parent} is a file, not a directory")
        key = path.resolve()
        if key in seen:
            raise OutputError(f"{seen[key]} and {flag} both name {path}; give each its own file")
        seen[key] = flag


def write_outputs(
    result, *, signal_out: Path | None, tracks_out: Path | None, plot: Path | None
) -> None:
    """Write the requested outputs all together: each to a temporary file, renamed at the end.

    The figure is drawn first; if anything fails no output is written.
    """
    from liquidtouch._core import atomic

    figure = None
    if plot is not None:
        from liquidtouch.extraction.plot import plot_extraction

        figure = plot_extraction(result)
    with contextlib.ExitStack() as stack:
        if signal_out is not None:
            from liquidtouch.io.signal_csv import write_signal_csv

            tmp = stack.enter_context(atomic.atomic_path(signal_out))
            write_signal_csv(tmp, result.signal.t, result.signal.u)
        if tracks_out is not None:
            from liquidtouch.tracking.tracks import save_tracks, save_tracks_csv, tracks_format

            save = save_tracks_csv if tracks_format(tracks_out) == "csv" else save_tracks
            tmp = stack.enter_context(atomic.atomic_path(tracks_out))
            save(tmp, result.tracks)
        if figure is not None:
            from liquidtouch.io.figures import DEFAULT_FORMAT

            tmp = stack.enter_context(atomic.atomic_path(plot))
            fmt = plot.suffix[1:].lower() or DEFAULT_FORMAT
            figure.savefig(tmp, dpi=90, format=fmt)
