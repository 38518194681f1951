"""Commands from features to models: ``train``, ``classify``, ``transfer`` (and ``predict``).

``train``, ``classify`` and ``transfer`` take the rows selected by ``--split`` and
``--where COLUMN=VALUE`` (all rows by default) and, after fitting, evaluate the
model on the labelled rows that were not selected: MAE per target (or accuracy)
as a table on stderr and under ``held_out`` in ``--json``
(:mod:`liquidtouch.models.held_out`). ``predict`` lives in :mod:`liquidtouch.cli.predict`
and is registered here with them.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any

import typer

from liquidtouch.cli import options
from liquidtouch.cli.format import warn

TrainSplit = Annotated[
    str | None,
    typer.Option(
        "--split",
        metavar="NAME",
        help="Train on the rows whose 'split' column is NAME (e.g. train); the labelled rows "
        "not selected are evaluated after training.",
        show_default=False,
    ),
]
TrainWhere = Annotated[
    list[str] | None,
    typer.Option(
        "--where",
        metavar="COLUMN=VALUE",
        help="Train on the rows where COLUMN equals VALUE (numerically for a numeric column); "
        "repeat to combine (all must hold). The labelled rows not selected are evaluated.",
        show_default=False,
    ),
]


def _echo_summary(lines: list[str], out: Path) -> None:
    for line in lines:
        typer.echo(line)
    typer.echo(f"wrote {out}")


def _read_training_table(path: Path) -> tuple[Any, Any, int]:
    """A features CSV without its failed rows (warned about), its (n, 2) features, rows skipped.

    Rows whose ``error`` is set (or whose features are empty, in a table with an
    ``error`` column) are skipped; empty features in a table without ``error`` stay
    an error.
    """
    from liquidtouch.io.tables import feature_matrix, read_table
    from liquidtouch.models.feature_rows import drop_failed, failed_rows, row_list

    table = read_table(path)
    failed = failed_rows(table)
    kept, skipped = drop_failed(table)
    if skipped:
        warn(
            f"skipped {skipped} of {len(table)} rows of {path} whose feature extraction "
            f"failed (non-empty error or empty features): rows {row_list(failed)}"
        )
    return kept, feature_matrix(kept), skipped


def _print_held_out(title: str, columns: list[str], rows: list[list[str]]) -> None:
    """A small table on stderr (the summary and 'wrote' stay on stdout)."""
    from rich.console import Console
    from rich.markup import escape
    from rich.table import Table

    table = Table(title=escape(title))
    for k, name in enumerate(columns):
        table.add_column(escape(name), justify="left" if k == 0 else "right")
    for row in rows:
        table.add_row(*(escape(cell) for cell in row))
    Console(stderr=True).print(table)


TrainFeatures = Annotated[
    Path,
    typer.Argument(help="Features CSV: decay_rate, angular_frequency, labels.", show_default=False),
]
Targets = Annotated[
    list[str],
    typer.Option("--target", "-t", help="Label column to learn (repeat for several targets)."),
]
Regressor = Annotated[
    options.RegressorChoice,
    typer.Option(
        "--model",
        "-m",
        help="gpr (the paper's GP), quadratic (the paper's 6-parameter model) or "
        "physics-gpr (GP with a sloshing-physics prior; height and viscosity targets). "
        "A GP takes at most 2000 rows (4000 over all targets; docs/formats.md, Limits).",
    ),
]
ModelOut = Annotated[Path, typer.Option(*options.OUT, help="Model file to write (JSON).")]
CalibrationFolds = Annotated[
    int,
    typer.Option(
        "--calibration-folds",
        min=0,
        help="Calibrate each target's std and intervals by K-fold cross-conformal on the "
        "training rows (K more fits per target; 0: no calibration, std not calibrated). "
        "Fewer rows than K: leave-one-out.",
    ),
]
CalibrationGroup = Annotated[
    str | None,
    typer.Option(
        "--calibration-group",
        help="Column whose rows the calibration holds out together, so that each row is "
        "predicted by a model that never saw its value (default: height_mm; with 8 or more "
        "heights per liquid only a trial's repeats, the rows of equal liquid, container, "
        "height_mm and sugar_concentration; 'none': every row alone).",
        show_default=False,
    ),
]


def train(
    features: TrainFeatures,
    target: Targets,
    model: Regressor = options.RegressorChoice.gpr,
    out: ModelOut = ...,
    split: TrainSplit = None,
    where: TrainWhere = None,
    calibration_folds: CalibrationFolds = 10,
    calibration_group: CalibrationGroup = None,
    as_json: options.Json = False,
) -> None:
    """Train one regressor per --target on a features table and save them in one model file.

    The model's std and --level intervals are calibrated on the training rows
    (cross-conformal, scores normalised by the model's std; stored in the file).
    """
    from liquidtouch._core.numbers import number
    from liquidtouch._core.progress import progress_bar
    from liquidtouch.models.modelfile import save_model
    from liquidtouch.models.table_training import train_on_table

    kind = str(model)
    table, _, skipped = _read_training_table(features)
    with progress_bar(f"training {kind}", len(dict.fromkeys(target))) as advance:
        trained = train_on_table(
            table,
            target,
            model=kind,
            split=split,
            where=where,
            calibration_folds=calibration_folds,
            calibration_group=calibration_group,
            source=features,
            progress=advance,
        )
    fitted, held_out = trained.model, trained.held_out
    save_model(fitted, out)
    if as_json:
        typer.echo(json.dumps(_training_summary(trained, kind, out, skipped)))
        return
    _echo_summary(fitted.summary(), out)
    if held_out is not None:
        training = fitted.training_mae()
        _print_held_out(
            f"evaluation on the {trained.n_held_out} rows not selected",
            ["target", "rows", "training MAE", "held-out MAE"],
            [
                [t, str(e["n_rows"]), number(training[t]), number(e["mae"])]
                for t, e in held_out.items()
            ]
            or [["(no labelled rows)", "0", "", ""]],
        )


def _training_summary(trained: Any, kind: str, out: Path, skipped: int) -> dict[str, Any]:
    """``train --json``: the model file, its targets, the rows, the errors, the calibration."""
    fitted = trained.model
    return {
        "out": str(out),
        "kind": fitted.kind,
        "model": kind,
        "targets": fitted.targets,
        "n_rows": trained.n_rows,
        "n_skipped": skipped,
        "selection": trained.selection,
        "training_mae": fitted.training_mae(),
        "held_out": trained.held_out,
        "models": {t: r.describe() for t, r in fitted.regressors.items()},
        "calibration": {
            t: {"n_folds": c.n_folds, "n_rows": c.n, "std_scale": c.std_scale}
            for t, c in fitted.calibration.items()
        },
        "extraction_settings": fitted.extraction_settings,
    }


def classify(
    features: Path = typer.Argument(
        ..., help="Features CSV with decay_rate, angular_frequency.", show_default=False
    ),
    label: str = typer.Option("liquid", "--label", "-l", help="Class label column."),
    out: Path = typer.Option(..., *options.OUT, help="Model file to write (JSON)."),
    split: TrainSplit = None,
    where: TrainWhere = None,
    as_json: options.Json = False,
) -> None:
    """Train the RBF-SVM liquid classifier (with class probabilities) and save it."""
    from liquidtouch._core.numbers import percent
    from liquidtouch.models.modelfile import save_model
    from liquidtouch.models.table_training import classify_on_table

    table, _, skipped = _read_training_table(features)
    trained = classify_on_table(table, label, split=split, where=where, source=features)
    fitted, held_out = trained.model, trained.held_out
    save_model(fitted, out)
    rule = fitted.classifier.unknown_status()
    if rule != "available":
        fewest = int(fitted.classifier.class_n_.min())
        warn(
            f"this classifier cannot flag unknown liquids (unknown_rule: {rule}; the fewest "
            f"here: {fewest}): it names a liquid it was not trained on as one it was"
        )
    if as_json:
        typer.echo(json.dumps(_classification_summary(trained, label, out, skipped, rule)))
        return
    _echo_summary(fitted.summary(), out)
    if held_out is not None:
        _print_held_out(
            f"evaluation on the {trained.n_held_out} rows not selected",
            ["label", "rows", "training accuracy", "held-out accuracy"],
            [
                [
                    label,
                    str(held_out["n_rows"]),
                    percent(fitted.training_mae()["accuracy"]),
                    percent(held_out["accuracy"]),
                ]
            ],
        )


def _classification_summary(
    trained: Any, label: str, out: Path, skipped: int, rule: str
) -> dict[str, Any]:
    """``classify --json``: the classes, the rows, the accuracies and the unknown rule."""
    fitted = trained.model
    clf = fitted.classifier
    return {
        "out": str(out),
        "kind": fitted.kind,
        "label": label,
        "classes": clf.classes_.tolist(),
        "n_rows": trained.n_rows,
        "n_skipped": skipped,
        "selection": trained.selection,
        "training_accuracy": fitted.training_mae()["accuracy"],
        "held_out": trained.held_out,
        "C": clf.C_,
        "gamma": clf.gamma_,
        "unknown_rule": rule,
        "extraction_settings": fitted.extraction_settings,
    }


TransferFrom = Annotated[
    Path, typer.Argument(help="Regression model of container A.", show_default=False)
]
TuneFeatures = Annotated[
    Path,
    typer.Argument(
        help="Features CSV of trials in container B, labelled with model targets.",
        show_default=False,
    ),
]
TransferOut = Annotated[Path, typer.Option(*options.OUT, help="Transferred model file to write.")]
TuneSplit = Annotated[
    str | None,
    typer.Option(
        "--split",
        metavar="NAME",
        help="Tune on the rows whose 'split' column is NAME; the labelled rows not selected "
        "are evaluated before and after the transfer.",
        show_default=False,
    ),
]
TuneWhere = Annotated[
    list[str] | None,
    typer.Option(
        "--where",
        metavar="COLUMN=VALUE",
        help="Tune on the rows where COLUMN equals VALUE (numerically for a numeric column); "
        "repeat to combine. The labelled rows not selected are evaluated.",
        show_default=False,
    ),
]


def transfer(
    model_file: TransferFrom,
    tune: TuneFeatures,
    out: TransferOut,
    split: TuneSplit = None,
    where: TuneWhere = None,
    as_json: options.Json = False,
) -> None:
    """Fit f_B(λ, ω) = f_A(α1 λ + α2, β1 ω + β2) on a few trials of a new container."""
    from liquidtouch._core.numbers import number
    from liquidtouch.models.modelfile import load_model, save_model
    from liquidtouch.models.table_training import transfer_on_table

    fitted = load_model(model_file)
    table, _, _ = _read_training_table(tune)
    tuned = transfer_on_table(fitted, table, split=split, where=where, source=tune)
    result, held_out = tuned.transfer, tuned.held_out
    save_model(result.model, out)
    if as_json:
        fmap = result.feature_map
        summary = {
            "out": str(out),
            "n_points": result.n_points,
            "selection": tuned.selection,
            "alpha": list(fmap.alpha),
            "beta": list(fmap.beta),
            "tune_mae_before": result.mae_before,
            "tune_mae_after": result.mae_after,
            "held_out": held_out,
        }
        typer.echo(json.dumps(summary))
        return
    _echo_summary(result.summary(), out)
    if held_out is not None:
        _print_held_out(
            f"evaluation on the {tuned.n_held_out} rows not selected",
            ["target", "rows", "MAE before", "MAE after"],
            [
                [t, str(e["n_rows"]), number(e["mae_before"]), number(e["mae_after"])]
                for t, e in held_out.items()
            ]
            or [["(no labelled rows)", "0", "", ""]],
        )


def register(app: typer.Typer) -> None:
    """Register this module's commands on ``app``."""
    app.command("train")(train)
    app.command("classify")(classify)
    from liquidtouch.cli.predict import predict

    app.command("predict")(predict)
    app.command("transfer")(transfer)
