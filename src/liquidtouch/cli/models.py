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


def train(
    features: Path = typer.Argument(
        ..., help="Features CSV: decay_rate, angular_frequency, labels.", show_default=False
    ),
    target: list[str] = typer.Option(
        ..., "--target", "-t", help="Label column to learn (repeat for several targets)."
    ),
    model: options.RegressorChoice = typer.Option(
        options.RegressorChoice.gpr,
        "--model",
        "-m",
        help="gpr (the paper's GP), quadratic (the paper's 6-parameter model) or "
        "physics-gpr (GP with a sloshing-physics prior; height and viscosity targets). "
        "A GP takes at most 2000 rows (4000 over all targets; docs/formats.md, Limits).",
    ),
    out: Path = typer.Option(..., *options.OUT, help="Model file to write (JSON)."),
    split: TrainSplit = None,
    where: TrainWhere = None,
    calibration_folds: int = typer.Option(
        10,
        "--calibration-folds",
        min=0,
        help="Calibrate each target's std and intervals by K-fold cross-conformal on the "
        "training rows (K more fits per target; 0: no calibration, std not calibrated). "
        "Fewer rows than K: leave-one-out.",
    ),
    calibration_group: str | None = typer.Option(
        None,
        "--calibration-group",
        help="Column whose rows the calibration holds out together, so that each row is "
        "predicted by a model that never saw its value (default: height_mm; with 8 or more "
        "heights per liquid only a trial's repeats, the rows of equal liquid, container, "
        "height_mm and sugar_concentration; 'none': every row alone).",
        show_default=False,
    ),
    as_json: options.Json = False,
) -> None:
    """Train one regressor per --target on a features table and save them in one model file.

    The model's std and --level intervals are calibrated on the training rows
    (cross-conformal, scores normalised by the model's std; stored in the file).
    """
    from liquidtouch._core.numbers import number
    from liquidtouch._core.progress import progress_bar
    from liquidtouch.io.tables import numeric_column
    from liquidtouch.models.held_out import regression_errors, selection_summary, split_rows
    from liquidtouch.models.modelfile import save_model
    from liquidtouch.models.property_model import feature_std_matrix
    from liquidtouch.models.training import train_regression

    kind = str(model)
    table, X, skipped = _read_training_table(features)
    table, X, rest, chosen = split_rows(table, X, split, where, features)
    targets = {t: numeric_column(table, t) for t in dict.fromkeys(target)}
    with progress_bar(f"training {kind}", len(targets)) as advance:
        folds = None if calibration_folds == 0 else max(calibration_folds, 2)
        groups = calibration_groups(table, calibration_group)
        fitted = train_regression(
            X,
            targets,
            kind,
            advance,
            calibration_folds=folds,
            calibration_groups=groups,
            calibration_std=feature_std_matrix(table),
        )
    held_out = None if rest is None else regression_errors(fitted, rest, list(targets))
    save_model(fitted, out)
    if as_json:
        typer.echo(
            json.dumps(
                {
                    "out": str(out),
                    "kind": fitted.kind,
                    "model": kind,
                    "targets": fitted.targets,
                    "n_rows": int(X.shape[0]),
                    "n_skipped": skipped,
                    "selection": selection_summary(chosen, split, where),
                    "training_mae": fitted.training_mae(),
                    "held_out": held_out,
                    "models": {t: r.describe() for t, r in fitted.regressors.items()},
                    "calibration": {
                        t: {"n_folds": c.n_folds, "n_rows": c.n, "std_scale": c.std_scale}
                        for t, c in fitted.calibration.items()
                    },
                }
            )
        )
        return
    _echo_summary(fitted.summary(), out)
    if held_out is not None:
        training = fitted.training_mae()
        _print_held_out(
            f"evaluation on the {len(rest)} rows not selected",
            ["target", "rows", "training MAE", "held-out MAE"],
            [
                [t, str(e["n_rows"]), number(training[t]), number(e["mae"])]
                for t, e in held_out.items()
            ]
            or [["(no labelled rows)", "0", "", ""]],
        )


def calibration_groups(table: Any, column: str | None) -> Any:
    """The calibration's groups: ``column``'s values (default:
    :func:`~liquidtouch.models.conformal.default_groups`)."""
    from liquidtouch.errors import TableError
    from liquidtouch.models.conformal import default_groups

    if column is None:
        if "height_mm" in table.columns and table["height_mm"].isna().any():
            raise TableError("--calibration-group height_mm: the column has empty values")
        return default_groups(table)
    if column.strip().lower() == "none":
        return None
    if column not in table.columns:
        raise TableError(f"--calibration-group {column!r}: no such column in the training table")
    values = table[column]
    if values.isna().any():
        raise TableError(f"--calibration-group {column}: the column has empty values")
    return values.astype(str).to_numpy()


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
    from liquidtouch.io.tables import label_column
    from liquidtouch.models.held_out import (
        classification_accuracy,
        selection_summary,
        split_rows,
    )
    from liquidtouch.models.modelfile import save_model
    from liquidtouch.models.training import train_classifier

    table, X, skipped = _read_training_table(features)
    table, X, rest, chosen = split_rows(table, X, split, where, features)
    fitted = train_classifier(X, label_column(table, label), label=label)
    held_out = None if rest is None else classification_accuracy(fitted, rest, label)
    save_model(fitted, out)
    rule = fitted.classifier.unknown_status()
    if rule != "available":
        fewest = int(fitted.classifier.class_n_.min())
        warn(
            f"this classifier cannot flag unknown liquids (unknown_rule: {rule}; the fewest "
            f"here: {fewest}): it names a liquid it was not trained on as one it was"
        )
    if as_json:
        clf = fitted.classifier
        typer.echo(
            json.dumps(
                {
                    "out": str(out),
                    "kind": fitted.kind,
                    "label": label,
                    "classes": clf.classes_.tolist(),
                    "n_rows": int(X.shape[0]),
                    "n_skipped": skipped,
                    "selection": selection_summary(chosen, split, where),
                    "training_accuracy": fitted.training_mae()["accuracy"],
                    "held_out": held_out,
                    "C": clf.C_,
                    "gamma": clf.gamma_,
                    "unknown_rule": rule,
                }
            )
        )
        return
    _echo_summary(fitted.summary(), out)
    if held_out is not None:
        _print_held_out(
            f"evaluation on the {len(rest)} rows not selected",
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


def transfer(
    model_file: Path = typer.Argument(
        ..., help="Regression model of container A.", show_default=False
    ),
    tune: Path = typer.Argument(
        ...,
        help="Features CSV of trials in container B, labelled with model targets.",
        show_default=False,
    ),
    out: Path = typer.Option(..., *options.OUT, help="Transferred model file to write."),
    split: str | None = typer.Option(
        None,
        "--split",
        metavar="NAME",
        help="Tune on the rows whose 'split' column is NAME; the labelled rows not selected "
        "are evaluated before and after the transfer.",
        show_default=False,
    ),
    where: list[str] | None = typer.Option(
        None,
        "--where",
        metavar="COLUMN=VALUE",
        help="Tune on the rows where COLUMN equals VALUE (numerically for a numeric column); "
        "repeat to combine. The labelled rows not selected are evaluated.",
        show_default=False,
    ),
    as_json: options.Json = False,
) -> None:
    """Fit f_B(λ, ω) = f_A(α1 λ + α2, β1 ω + β2) on a few trials of a new container."""
    from liquidtouch._core.numbers import number
    from liquidtouch.errors import TableError
    from liquidtouch.io.tables import numeric_column
    from liquidtouch.models.held_out import regression_errors, selection_summary, split_rows
    from liquidtouch.models.modelfile import load_model, save_model
    from liquidtouch.models.transfer import fit_transfer

    fitted = load_model(model_file)
    table, X, _ = _read_training_table(tune)
    table, X, rest, chosen = split_rows(table, X, split, where, tune)
    labelled = [t for t in fitted.targets if t in table.columns]
    if fitted.kind != "regression":
        raise TableError("container transfer needs a regression model (train one with `train`)")
    if not labelled:
        raise TableError(
            f"{tune}: no column of the model's targets ({', '.join(fitted.targets)}); "
            "label the tuning trials with at least one of them"
        )
    result = fit_transfer(fitted, X, {t: numeric_column(table, t) for t in labelled})
    held_out = None
    if rest is not None:
        before = regression_errors(fitted, rest, labelled)
        after = regression_errors(result.model, rest, labelled)
        held_out = {
            t: {"n_rows": e["n_rows"], "mae_before": before[t]["mae"], "mae_after": e["mae"]}
            for t, e in after.items()
        }
    save_model(result.model, out)
    if as_json:
        fmap = result.feature_map
        typer.echo(
            json.dumps(
                {
                    "out": str(out),
                    "n_points": result.n_points,
                    "selection": selection_summary(chosen, split, where),
                    "alpha": list(fmap.alpha),
                    "beta": list(fmap.beta),
                    "tune_mae_before": result.mae_before,
                    "tune_mae_after": result.mae_after,
                    "held_out": held_out,
                }
            )
        )
        return
    _echo_summary(result.summary(), out)
    if held_out is not None:
        _print_held_out(
            f"evaluation on the {len(rest)} rows not selected",
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
