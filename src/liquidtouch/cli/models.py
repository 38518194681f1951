"""Commands from features to properties: ``train``, ``classify``, ``predict``, ``transfer``."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import typer


def _echo_summary(lines: list[str], out: Path) -> None:
    for line in lines:
        typer.echo(line)
    typer.echo(f"wrote {out}")


def train(
    features: Path = typer.Argument(
        ..., help="Features CSV: decay_rate, angular_frequency, labels."
    ),
    target: list[str] = typer.Option(
        ..., "--target", "-t", help="Label column to learn (repeat for several targets)."
    ),
    model: str = typer.Option(
        "gpr",
        "--model",
        "-m",
        help="gpr (the paper's GP), quadratic (the paper's 6-parameter model) or "
        "physics-gpr (GP with a sloshing-physics prior; height and viscosity targets).",
    ),
    out: Path = typer.Option(..., "--out", "-o", help="Model file to write (JSON)."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
) -> None:
    """Train one regressor per --target on a features table and save them in one model file."""
    from liquidtouch.errors import TableError
    from liquidtouch.io.tables import numeric_column, read_feature_table
    from liquidtouch.models.modelfile import save_model
    from liquidtouch.models.property_model import MODEL_KINDS, train_regression
    from liquidtouch.progress import progress_bar

    if model not in MODEL_KINDS:
        raise TableError(f"unknown --model {model!r}; choose one of {', '.join(MODEL_KINDS)}")
    table, X = read_feature_table(features)
    targets = {t: numeric_column(table, t) for t in dict.fromkeys(target)}
    with progress_bar(f"training {model}", len(targets), enabled=sys.stderr.isatty()) as advance:
        fitted = train_regression(X, targets, model, advance)
    save_model(fitted, out)
    if as_json:
        typer.echo(
            json.dumps(
                {
                    "out": str(out),
                    "kind": fitted.kind,
                    "model": model,
                    "targets": fitted.targets,
                    "n_rows": int(X.shape[0]),
                    "training_mae": fitted.training_mae(),
                    "models": {t: r.describe() for t, r in fitted.regressors.items()},
                }
            )
        )
    else:
        _echo_summary(fitted.summary(), out)


def classify(
    features: Path = typer.Argument(..., help="Features CSV with decay_rate, angular_frequency."),
    label: str = typer.Option("liquid", "--label", "-l", help="Class label column."),
    out: Path = typer.Option(..., "--out", "-o", help="Model file to write (JSON)."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
) -> None:
    """Train the RBF-SVM liquid classifier (with class probabilities) and save it."""
    from liquidtouch.io.tables import label_column, read_feature_table
    from liquidtouch.models.modelfile import save_model
    from liquidtouch.models.property_model import train_classifier

    table, X = read_feature_table(features)
    fitted = train_classifier(X, label_column(table, label), label=label)
    save_model(fitted, out)
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
                    "training_accuracy": fitted.training_mae()["accuracy"],
                    "C": clf.C_,
                    "gamma": clf.gamma_,
                }
            )
        )
    else:
        _echo_summary(fitted.summary(), out)


def predict(
    model_file: Path = typer.Argument(..., help="Model file from train, classify or transfer."),
    input_path: Path = typer.Argument(
        ...,
        metavar="INPUT",
        help="Features CSV, dataset directory, trial directory or video.",
    ),
    out: Path | None = typer.Option(
        None, "--out", "-o", help="Predictions CSV to write (default: print the CSV)."
    ),
) -> None:
    """Predict properties (mean and std) or the liquid (with probabilities) for each row."""
    from liquidtouch.batch.inputs import read_prediction_input
    from liquidtouch.io import atomic
    from liquidtouch.models.modelfile import load_model

    fitted = load_model(model_file)
    table = read_prediction_input(input_path)
    text = fitted.predict_table(table).to_csv(index=False)
    if out is None:
        typer.echo(text, nl=False)
    else:
        atomic.write_text(out, text)
        typer.echo(f"wrote {out} ({len(table)} rows; predicted {', '.join(fitted.targets)})")


def transfer(
    model_file: Path = typer.Argument(..., help="Regression model of container A."),
    tune: Path = typer.Argument(
        ..., help="Features CSV of a few trials in container B, labelled with model targets."
    ),
    out: Path = typer.Option(..., "--out", "-o", help="Transferred model file to write."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
) -> None:
    """Fit f_B(λ, ω) = f_A(α1 λ + α2, β1 ω + β2) on a few trials of a new container."""
    from liquidtouch.errors import TableError
    from liquidtouch.io.tables import numeric_column, read_feature_table
    from liquidtouch.models.modelfile import load_model, save_model
    from liquidtouch.models.transfer import fit_transfer

    fitted = load_model(model_file)
    table, X = read_feature_table(tune)
    labelled = [t for t in fitted.targets if t in table.columns]
    if fitted.kind != "regression":
        raise TableError("container transfer needs a regression model (train one with `train`)")
    if not labelled:
        raise TableError(
            f"{tune}: no column of the model's targets ({', '.join(fitted.targets)}); "
            "label the tuning trials with at least one of them"
        )
    result = fit_transfer(fitted, X, {t: numeric_column(table, t) for t in labelled})
    save_model(result.model, out)
    if as_json:
        fmap = result.feature_map
        typer.echo(
            json.dumps(
                {
                    "out": str(out),
                    "n_points": result.n_points,
                    "alpha": list(fmap.alpha),
                    "beta": list(fmap.beta),
                    "tune_mae_before": result.mae_before,
                    "tune_mae_after": result.mae_after,
                }
            )
        )
    else:
        _echo_summary(result.summary(), out)


def register(app: typer.Typer) -> None:
    """Register this module's commands on ``app``."""
    app.command("train")(train)
    app.command("classify")(classify)
    app.command("predict")(predict)
    app.command("transfer")(transfer)
