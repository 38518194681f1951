"""``liquidtouch predict``: a model's predictions for a features CSV, dataset, trial or video.

Anything but a features CSV is run through the feature extraction first
(:func:`~liquidtouch.batch.inputs.read_prediction_input`), with the extraction and
fit options of ``features`` declared once in :mod:`liquidtouch.cli.options`.
Registered by :func:`liquidtouch.cli.models.register`.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import typer

from liquidtouch.cli import options
from liquidtouch.cli.format import warn


def predict(
    model_file: Path = typer.Argument(
        ..., help="Model file from train, classify or transfer.", show_default=False
    ),
    input_path: Path = typer.Argument(
        ...,
        metavar="INPUT",
        help="Features CSV, dataset directory, trial directory or video.",
        show_default=False,
    ),
    out: Path | None = typer.Option(
        None,
        *options.OUT,
        help="Predictions CSV to write (default: print the CSV, or with --json put the "
        "rows in the JSON object).",
        show_default=False,
    ),
    as_json: options.Json = False,
    jobs: options.Jobs = 1,
    dask: options.Dask = None,
    lowpass_hz: options.Lowpass = options.DEFAULT_LOWPASS_HZ,
    n_markers: options.Markers = options.DEFAULT_MARKERS,
    sensor: options.Sensor = None,
    loss: options.Loss = options.DEFAULT_LOSS,
    model: options.FitModel = options.DEFAULT_FIT_MODEL,
    band_low_hz: options.BandLow = options.DEFAULT_BAND_LOW_HZ,
    band_high_hz: options.BandHigh = options.DEFAULT_BAND_HIGH_HZ,
    noise: options.Noise = options.DEFAULT_NOISE,
    start: options.Start = None,
    level: float | None = typer.Option(
        None,
        "--level",
        help="Add predicted_<target>_lower and _upper: the calibrated interval that holds the "
        "truth with this probability (0 < LEVEL < 1, e.g. 0.9; regression models).",
        show_default=False,
    ),
) -> None:
    """Predict properties (mean and std) or the liquid (with probabilities) for each row.

    A dataset, trial or video is first run through the feature extraction with the
    options of 'features' (--jobs and --dask: a dataset's trials; --model is the
    oscillation fit's); they do not change a features CSV. Rows whose feature
    extraction failed are kept with empty predictions (a warning per row); rows
    outside the model's training domain are flagged in the ``out_of_domain``
    column (and a warning): their predictions are extrapolations. The std (and
    --level's interval) is calibrated on the model's training rows and includes the
    fit's λ and ω std (decay_rate_std, angular_frequency_std) propagated through
    the model. --json prints
    the counts, the output path (or the rows) as one JSON object.
    """
    import numpy as np

    from liquidtouch._core import atomic
    from liquidtouch.batch.inputs import read_prediction_input
    from liquidtouch.errors import TableError
    from liquidtouch.io.tables import feature_matrix
    from liquidtouch.models.conformal import min_rows_for_level
    from liquidtouch.models.feature_rows import error_messages, failed_rows, row_list
    from liquidtouch.models.modelfile import load_model

    settings = options.fit_settings(loss, model, band_low_hz, band_high_hz, noise, start)
    fitted = load_model(model_file)
    if level is not None:
        if fitted.kind != "regression":
            raise TableError("--level needs a regression model (from train), not a classifier")
        need = min_rows_for_level(level)
        for target in fitted.targets:
            cal = fitted.calibration.get(target)
            if cal is None:
                raise TableError(
                    f"--level: the model has no interval calibration for {target} (an older "
                    f"model file, or --calibration-folds 0); retrain it with `liquidtouch "
                    f"train` on at least {need} rows"
                )
            cal.quantile(level)  # refuses a calibration on too few rows, before extracting
    elif fitted.kind == "regression" and not fitted.calibrated:
        warn(
            "the model's std is not calibrated (an older model file or --calibration-folds 0); "
            "retrain it with `liquidtouch train` for a calibrated std and --level"
        )
    table = read_prediction_input(
        input_path,
        jobs=jobs,
        dask_address=dask,
        lowpass_hz=lowpass_hz,
        n_markers=n_markers,
        sensors=sensor or None,
        fit_settings=settings,
    )
    failed = failed_rows(table)
    if failed is None:
        failed = np.zeros(len(table), dtype=bool)
    else:
        messages = error_messages(table)
        for i in np.flatnonzero(failed):
            who = f"trial {table['trial'].iloc[i]}" if "trial" in table.columns else f"row {i + 1}"
            warn(f"{who}: {messages.iloc[i] or 'empty decay_rate or angular_frequency'}")
    good = table[~failed]
    predicted = fitted.predict_table(good, level=level)
    result = table.copy()
    for column in predicted.columns:
        if column not in table.columns or column.startswith(("predicted_", "probability_")):
            result[column] = predicted[column].reindex(table.index)
    outside = np.zeros(len(table), dtype=bool)
    outside[np.flatnonzero(~failed)] = ~fitted.in_domain(feature_matrix(good))
    result["out_of_domain"] = outside
    if outside.any():
        warn(
            f"{int(outside.sum())} row(s) outside the training domain "
            f"({fitted.describe_domain()}): rows {row_list(outside)}"
        )
    if out is not None:
        atomic.write_text(out, result.to_csv(index=False))
    if as_json:
        summary: dict[str, Any] = {
            "out": None if out is None else str(out),
            "model": str(model_file),
            "kind": fitted.kind,
            "targets": fitted.targets,
            "n_rows": len(table),
            "n_predicted": int((~failed).sum()),
            "n_failed": int(failed.sum()),
            "n_out_of_domain": int(outside.sum()),
            "level": level,
            "calibrated": fitted.kind == "regression" and fitted.calibrated,
            "failed_rows": [int(i) + 1 for i in np.flatnonzero(failed)],
        }
        if out is None:  # the predictions themselves, NaN as null
            records = json.loads(result.to_json(orient="records", double_precision=15))
            summary["rows"] = records
        typer.echo(json.dumps(summary, ensure_ascii=False))
    elif out is None and stdout_is_terminal():
        _print_table(result, fitted.targets)
    elif out is None:  # piped: the CSV, as -o writes it
        typer.echo(result.to_csv(index=False), nl=False)
    else:
        extra = f", {int(failed.sum())} without features" if failed.any() else ""
        typer.echo(f"wrote {out} ({len(table)} rows{extra}; predicted {', '.join(fitted.targets)})")


def stdout_is_terminal() -> bool:
    """Whether stdout is an interactive terminal (a table then, else the CSV)."""
    try:
        return sys.stdout.isatty()
    except (AttributeError, ValueError):
        return False


def _print_table(result, targets: list[str]) -> None:
    """The predictions as a readable table on stdout: one row per input row, each target's
    value ± std (a class and its probability), λ, ω and whether it lies out of domain."""
    import math

    from rich.console import Console
    from rich.table import Table

    from liquidtouch._core.numbers import with_uncertainty

    table = Table(title=f"predictions ({len(result)} rows)")
    table.add_column("trial" if "trial" in result.columns else "row")
    for column in ("λ [1/s]", "ω [rad/s]", *targets, "out of domain"):
        table.add_column(column.replace("[", "\\["), justify="right")
    for i in range(len(result)):
        values = result.iloc[i].to_dict()
        cells = [str(values.get("trial", i + 1))]
        for name in ("decay_rate", "angular_frequency"):
            value = values.get(name, math.nan)
            cells.append("—" if value is None or value != value else f"{value:.4g}")
        for target in targets:
            mean = values.get(f"predicted_{target}")
            std = values.get(f"predicted_{target}_std")
            if isinstance(mean, str):
                share = values.get(f"probability_{mean}")
                cells.append(mean + (f" ({share:.0%})" if isinstance(share, float) else ""))
            elif mean is None or mean != mean:
                cells.append("—")
            else:
                cells.append(with_uncertainty(mean, std if std is not None else math.nan))
        cells.append("yes" if values.get("out_of_domain") else "")
        table.add_row(*cells)
    Console(soft_wrap=False).print(table)
