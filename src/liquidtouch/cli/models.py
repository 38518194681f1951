"""Commands from features to properties: ``train``, ``classify``, ``predict``, ``transfer``.

``train``, ``classify`` and ``transfer`` take the rows selected by ``--split`` and
``--where COLUMN=VALUE`` (all rows by default) and, after fitting, evaluate the
model on the labelled rows that were not selected: MAE per target (or accuracy)
as a table on stderr and under ``held_out`` in ``--json``.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import typer

from liquidtouch.cli import options

MAX_LISTED_VALUES = 10  # values of a column quoted in an error message

_SPLIT_HELP = (
    "Train on the rows whose 'split' column is NAME (e.g. train); the labelled rows not "
    "selected are evaluated after training."
)
_WHERE_HELP = (
    "Train on the rows where COLUMN equals VALUE (numerically for a numeric column); "
    "repeat to combine (all must hold). The labelled rows not selected are evaluated."
)


def _echo_summary(lines: list[str], out: Path) -> None:
    for line in lines:
        typer.echo(line)
    typer.echo(f"wrote {out}")


def _warn(message: str) -> None:
    typer.echo(f"warning: {message}", err=True)


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
        _warn(
            f"skipped {skipped} of {len(table)} rows of {path} whose feature extraction "
            f"failed (non-empty error or empty features): rows {row_list(failed)}"
        )
    return kept, feature_matrix(kept), skipped


def _listed(values: Any) -> str:
    shown = [str(v) for v in list(values)[:MAX_LISTED_VALUES]]
    more = len(values) - len(shown)
    return ", ".join(shown) + (f" and {more} more" if more > 0 else "")


def _column_equals(table: Any, column: str, value: str, flag: str, path: Path) -> Any:
    """Boolean mask of ``table[column] == value``: numeric for a numeric column, else text."""
    import numpy as np
    import pandas as pd

    from liquidtouch.errors import TableError

    if column not in table.columns:
        raise TableError(
            f"{flag}: {path} has no column {column!r} (columns: {_listed(table.columns)})"
        )
    cells = table[column]
    if pd.api.types.is_numeric_dtype(cells) and not pd.api.types.is_bool_dtype(cells):
        try:
            number = float(value)
        except ValueError:
            raise TableError(
                f"{flag}: column {column} of {path} is numeric, but {value!r} is not a number"
            ) from None
        values = cells.to_numpy(dtype=float)
        mask = np.isclose(values, number, rtol=1e-9, atol=0.0) | (values == number)
        shown = np.unique(values[np.isfinite(values)])
        shown = [f"{v:g}" for v in shown]
    else:
        text = cells.astype(str).str.strip()
        mask = (text == value.strip()).to_numpy() & cells.notna().to_numpy()
        shown = sorted(set(text[cells.notna()]))
    if not mask.any():
        raise TableError(
            f"{flag}: no row of {path} has {column} = {value} ({column} values: {_listed(shown)})"
        )
    return mask


def _selection(table: Any, split: str | None, where: list[str] | None, path: Path) -> Any:
    """The rows chosen by ``--split``/``--where`` (boolean mask; None without either)."""
    import numpy as np

    from liquidtouch.errors import TableError

    if split is None and not where:
        return None
    mask = np.ones(len(table), dtype=bool)
    if split is not None:
        mask &= _column_equals(table, "split", split, f"--split {split}", path)
    for condition in where or []:
        column, sep, value = condition.partition("=")
        if not sep or not column.strip():
            raise TableError(f"--where takes COLUMN=VALUE (e.g. split=train), got {condition!r}")
        mask &= _column_equals(table, column.strip(), value, f"--where {condition}", path)
    if not mask.any():
        chosen = " ".join(
            ([f"--split {split}"] if split is not None else [])
            + [f"--where {w}" for w in where or []]
        )
        raise TableError(f"no row of {path} matches {chosen} (each alone matches some rows)")
    return mask


def _selection_json(mask: Any, split: str | None, where: list[str] | None) -> Any:
    if mask is None:
        return None
    return {
        "split": split,
        "where": list(where or []),
        "n_selected": int(mask.sum()),
        "n_not_selected": int((~mask).sum()),
    }


def _labelled(table: Any, column: str) -> Any:
    """Mask of rows with a usable label in ``column`` (finite number, or non-empty text)."""
    import numpy as np
    import pandas as pd

    if column not in table.columns:
        return np.zeros(len(table), dtype=bool)
    cells = table[column]
    if pd.api.types.is_numeric_dtype(cells):
        return np.isfinite(cells.to_numpy(dtype=float))
    return (cells.notna() & (cells.astype(str).str.strip() != "")).to_numpy()


def _regression_errors(fitted: Any, rest: Any, targets: list[str]) -> dict[str, dict]:
    """Per target with labelled rows in ``rest``: ``{"n_rows", "mae"}`` of ``fitted``."""
    import numpy as np
    import pandas as pd

    from liquidtouch.io.tables import feature_matrix

    out = {}
    for target in targets:
        rows = rest[_labelled(rest, target)]
        if rows.empty:
            continue
        truth = pd.to_numeric(rows[target], errors="coerce").to_numpy(dtype=float)
        mean, _ = fitted.predict(feature_matrix(rows))[target]
        out[target] = {"n_rows": len(rows), "mae": float(np.mean(np.abs(mean - truth)))}
    return out


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
    split: str | None = typer.Option(
        None, "--split", metavar="NAME", help=_SPLIT_HELP, show_default=False
    ),
    where: list[str] | None = typer.Option(
        None, "--where", metavar="COLUMN=VALUE", help=_WHERE_HELP, show_default=False
    ),
    as_json: options.Json = False,
) -> None:
    """Train one regressor per --target on a features table and save them in one model file."""
    from liquidtouch.cli.format import number
    from liquidtouch.io.tables import numeric_column
    from liquidtouch.models.modelfile import save_model
    from liquidtouch.models.property_model import train_regression
    from liquidtouch.progress import on_terminal, progress_bar

    kind = str(model)
    table, X, skipped = _read_training_table(features)
    chosen = _selection(table, split, where, features)
    rest = None if chosen is None else table[~chosen]
    if chosen is not None:
        table, X = table[chosen], X[chosen]
    targets = {t: numeric_column(table, t) for t in dict.fromkeys(target)}
    with progress_bar(f"training {kind}", len(targets), enabled=on_terminal()) as advance:
        fitted = train_regression(X, targets, kind, advance)
    held_out = None if rest is None else _regression_errors(fitted, rest, list(targets))
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
                    "selection": _selection_json(chosen, split, where),
                    "training_mae": fitted.training_mae(),
                    "held_out": held_out,
                    "models": {t: r.describe() for t, r in fitted.regressors.items()},
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


def classify(
    features: Path = typer.Argument(
        ..., help="Features CSV with decay_rate, angular_frequency.", show_default=False
    ),
    label: str = typer.Option("liquid", "--label", "-l", help="Class label column."),
    out: Path = typer.Option(..., *options.OUT, help="Model file to write (JSON)."),
    split: str | None = typer.Option(
        None, "--split", metavar="NAME", help=_SPLIT_HELP, show_default=False
    ),
    where: list[str] | None = typer.Option(
        None, "--where", metavar="COLUMN=VALUE", help=_WHERE_HELP, show_default=False
    ),
    as_json: options.Json = False,
) -> None:
    """Train the RBF-SVM liquid classifier (with class probabilities) and save it."""
    import numpy as np

    from liquidtouch.cli.format import percent
    from liquidtouch.io.tables import feature_matrix, label_column
    from liquidtouch.models.modelfile import save_model
    from liquidtouch.models.property_model import train_classifier

    table, X, skipped = _read_training_table(features)
    chosen = _selection(table, split, where, features)
    rest = None if chosen is None else table[~chosen]
    if chosen is not None:
        table, X = table[chosen], X[chosen]
    fitted = train_classifier(X, label_column(table, label), label=label)
    held_out = None
    if rest is not None:
        rows = rest[_labelled(rest, label)]
        held_out = {"n_rows": len(rows), "accuracy": None}
        if len(rows):
            predicted, _ = fitted.predict_proba(feature_matrix(rows))
            truth = rows[label].astype(str).str.strip().to_numpy()
            held_out["accuracy"] = float(np.mean(predicted == truth))
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
                    "n_skipped": skipped,
                    "selection": _selection_json(chosen, split, where),
                    "training_accuracy": fitted.training_mae()["accuracy"],
                    "held_out": held_out,
                    "C": clf.C_,
                    "gamma": clf.gamma_,
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
) -> None:
    """Predict properties (mean and std) or the liquid (with probabilities) for each row.

    Rows whose feature extraction failed are kept with empty predictions (a warning
    per row); rows outside the model's training domain are flagged in the
    ``out_of_domain`` column (and a warning): their predictions are extrapolations.
    --json prints the counts, the output path (or the rows) as one JSON object.
    """
    import numpy as np

    from liquidtouch.batch.inputs import read_prediction_input
    from liquidtouch.io import atomic
    from liquidtouch.io.tables import feature_matrix
    from liquidtouch.models.feature_rows import error_messages, failed_rows, row_list
    from liquidtouch.models.modelfile import load_model

    fitted = load_model(model_file)
    table = read_prediction_input(input_path)
    failed = failed_rows(table)
    if failed is None:
        failed = np.zeros(len(table), dtype=bool)
    else:
        messages = error_messages(table)
        for i in np.flatnonzero(failed):
            who = f"trial {table['trial'].iloc[i]}" if "trial" in table.columns else f"row {i + 1}"
            _warn(f"{who}: {messages.iloc[i] or 'empty decay_rate or angular_frequency'}")
    good = table[~failed]
    predicted = fitted.predict_table(good)
    result = table.copy()
    for column in predicted.columns:
        if column not in table.columns or column.startswith(("predicted_", "probability_")):
            result[column] = predicted[column].reindex(table.index)
    outside = np.zeros(len(table), dtype=bool)
    outside[np.flatnonzero(~failed)] = ~fitted.in_domain(feature_matrix(good))
    result["out_of_domain"] = outside
    if outside.any():
        _warn(
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
            "failed_rows": [int(i) + 1 for i in np.flatnonzero(failed)],
        }
        if out is None:  # the predictions themselves, NaN as null
            records = json.loads(result.to_json(orient="records", double_precision=15))
            summary["rows"] = records
        typer.echo(json.dumps(summary, ensure_ascii=False))
    elif out is None:
        typer.echo(result.to_csv(index=False), nl=False)
    else:
        extra = f", {int(failed.sum())} without features" if failed.any() else ""
        typer.echo(f"wrote {out} ({len(table)} rows{extra}; predicted {', '.join(fitted.targets)})")


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
    from liquidtouch.cli.format import number
    from liquidtouch.errors import TableError
    from liquidtouch.io.tables import numeric_column
    from liquidtouch.models.modelfile import load_model, save_model
    from liquidtouch.models.transfer import fit_transfer

    fitted = load_model(model_file)
    table, X, _ = _read_training_table(tune)
    chosen = _selection(table, split, where, tune)
    rest = None if chosen is None else table[~chosen]
    if chosen is not None:
        table, X = table[chosen], X[chosen]
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
        before = _regression_errors(fitted, rest, labelled)
        after = _regression_errors(result.model, rest, labelled)
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
                    "selection": _selection_json(chosen, split, where),
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
    app.command("predict")(predict)
    app.command("transfer")(transfer)
