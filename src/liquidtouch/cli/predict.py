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
from typing import Annotated, Any

import numpy as np
import typer

from liquidtouch._core import atomic
from liquidtouch.cli import options
from liquidtouch.cli.format import warn

Level = Annotated[
    float | None,
    typer.Option(
        "--level",
        help="Add predicted_<target>_lower and _upper: the calibrated interval that holds the "
        "truth with this probability (0 < LEVEL < 1, e.g. 0.9; regression models).",
        show_default=False,
    ),
]


ModelArg = Annotated[
    Path, typer.Argument(help="Model file from train, classify or transfer.", show_default=False)
]
InputArg = Annotated[
    Path,
    typer.Argument(
        metavar="INPUT", help="Features CSV, dataset directory, trial directory or video."
    ),
]
PredictionsOut = Annotated[
    Path | None,
    typer.Option(
        *options.OUT, show_default=False, help="Predictions CSV to write (default: print the "
        "CSV, or with --json put the rows in the JSON object).",
    ),
]  # fmt: skip


def predict(
    model_file: ModelArg,
    input_path: InputArg,
    out: PredictionsOut = None,
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
    level: Level = None,
) -> None:
    """Predict properties (mean and std) or the liquid (with probabilities) for each row.

    A dataset, trial or video is first run through the feature extraction with the
    options of 'features' (--jobs and --dask: a dataset's trials; --model is the
    oscillation fit's); they do not change a features CSV. Rows whose feature
    extraction failed are kept with empty predictions (a warning per row); rows
    outside what the model knows (its training domain; for a classifier, "unknown") are
    flagged in the ``out_of_domain`` column (and a warning). The std (and --level's
    interval) is calibrated on the model's training rows and includes the fit's λ and ω
    std propagated through the model. --json prints the counts, the output path (or the
    rows) as one JSON object. The columns: liquidtouch.models.predictions.
    """
    _check_paths(model_file, input_path)  # before the heavy imports: answered at once
    from liquidtouch.batch.inputs import read_prediction_input
    from liquidtouch.models.modelfile import load_model
    from liquidtouch.models.predictions import check_level, predict_rows

    settings = options.fit_settings(loss, model, band_low_hz, band_high_hz, noise, start)
    fitted = load_model(model_file)
    uncalibrated = check_level(fitted, level)
    if uncalibrated:
        warn(uncalibrated)
    table = read_prediction_input(
        input_path, jobs=jobs, dask_address=dask, lowpass_hz=lowpass_hz, n_markers=n_markers,
        sensors=sensor or None, fit_settings=settings,
    )  # fmt: skip
    result = predict_rows(fitted, table, level=level)
    _warn_rows(result, fitted)
    if out is not None:
        atomic.write_text(out, result.table.to_csv(index=False))
    if as_json:
        typer.echo(json.dumps(_summary(result, fitted, model_file, out, level), ensure_ascii=False))
    elif out is None and stdout_is_terminal():
        _print_table(result.table, fitted.targets)
    elif out is None:  # piped: the CSV, as -o writes it
        typer.echo(result.table.to_csv(index=False), nl=False)
    else:
        n_failed = int(result.failed.sum())
        extra = f", {n_failed} without features" if n_failed else ""
        typer.echo(f"wrote {out} ({len(table)} rows{extra}; predicted {', '.join(fitted.targets)})")


def _check_paths(model_file: Path, input_path: Path) -> None:
    """A missing model file or input, said before anything heavy is imported."""
    from liquidtouch.errors import DatasetError, ModelFileError

    if not model_file.is_file():
        raise ModelFileError(f"{model_file}: no such model file")
    if not input_path.exists():
        raise DatasetError(f"{input_path}: no such features CSV, dataset, trial or video")


def _warn_rows(result, fitted) -> None:
    """One warning per failed row, one for the rows out of domain, one for the rows
    extracted otherwise than the model's training features, one for a classifier that
    cannot say "unknown"."""
    from liquidtouch.models.feature_rows import row_list
    from liquidtouch.models.predictions import unknown_rule

    for i in np.flatnonzero(result.failed):
        warn(f"{result.who(i)}: {result.errors[i]}")
    if result.outside_domain.any():
        warn(
            f"{int(result.outside_domain.sum())} row(s) outside the training domain "
            f"({fitted.describe_domain()}): rows {row_list(result.outside_domain)}"
        )
    alone = result.unknown & ~result.outside_domain  # out of domain as unknown only
    if alone.any():
        warn(
            f"{int(alone.sum())} row(s) far from every trained class (named unknown; "
            f"out_of_domain): rows {row_list(alone)}"
        )
    if result.other_settings.any():
        warn(
            f"{int(result.other_settings.sum())} row(s) extracted otherwise than the model's "
            f"training features ({'; '.join(result.settings_differences)}): their std may not "
            f"hold; rows {row_list(result.other_settings)}"
        )
    rule = unknown_rule(fitted)
    if rule is not None and rule != "available":
        warn(f"this classifier cannot flag unknown liquids (unknown_rule: {rule})")


def _summary(result, fitted, model_file: Path, out: Path | None, level) -> dict[str, Any]:
    """predict --json's object: counts, and the rows themselves without --out."""
    from liquidtouch.models.predictions import unknown_rule

    summary: dict[str, Any] = {
        "out": None if out is None else str(out),
        "model": str(model_file),
        "kind": fitted.kind,
        "targets": fitted.targets,
        "n_rows": len(result.table),
        "n_predicted": int((~result.failed).sum()),
        "n_failed": int(result.failed.sum()),
        "n_out_of_domain": int(result.outside.sum()),
        "n_other_settings": int(result.other_settings.sum()),
        "settings_differences": result.settings_differences,
        "level": level,
        "calibrated": fitted.kind == "regression" and fitted.calibrated,
        "unknown_rule": unknown_rule(fitted),
        "failed_rows": [int(i) + 1 for i in np.flatnonzero(result.failed)],
    }
    if out is None:  # the predictions themselves, NaN as null
        summary["rows"] = json.loads(result.table.to_json(orient="records", double_precision=15))
    return summary


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
