"""Dataset-scale commands: ``features``, ``reproduce`` and ``demo``."""

from __future__ import annotations

import os
from pathlib import Path

import typer

DEFAULT_JOBS = max(1, min(2, os.cpu_count() or 1))


def _print_summary(reproduction) -> None:
    from rich.console import Console
    from rich.markup import escape
    from rich.table import Table

    table = Table(title="liquidtouch reproduction: ours vs the paper")
    for column in ("experiment", "metric", "ours", "paper", "unit"):
        table.add_column(column, justify="left" if column in ("experiment", "metric") else "right")
    for row in reproduction.summary.itertuples(index=False):
        paper = "" if row.paper != row.paper else f"{row.paper:.3g}"
        # metrics carry units in brackets ("h [mm]"), which rich would read as markup
        table.add_row(row.experiment, escape(row.metric), f"{row.ours:.3g}", paper, row.unit)
    console = Console()
    console.print(table)
    console.print(
        f"report: {reproduction.report_html}  (and {reproduction.report_md.name} beside it)"
    )


def register(app: typer.Typer) -> None:
    """Register ``features``, ``reproduce`` and ``demo``."""

    @app.command()
    def features(
        dataset: Path = typer.Argument(..., help="Dataset directory (with manifest.csv)."),
        out: Path | None = typer.Option(
            None, "--out", help="Output CSV [default: DATASET/features.csv]."
        ),
        jobs: int = typer.Option(1, "--jobs", "-j", help="Worker processes."),
        dask: str | None = typer.Option(
            None, "--dask", help="Dask scheduler address (tcp://HOST:PORT)."
        ),
        source: str = typer.Option(
            "gelsight", "--source", help="gelsight (videos) or wrench (wrist F/T)."
        ),
    ) -> None:
        """Extract (λ, ω) and fit quality for every trial of a dataset → features.csv.

        Parallel, cached per trial (unchanged trials are not redone), resumable;
        a bad trial is recorded with its error and the others go on.
        """
        from liquidtouch.batch.features import extract_features

        table = extract_features(dataset, out=out, jobs=jobs, dask_address=dask, source=source)
        failed = table[table["error"].astype(str) != ""]
        target = out or Path(dataset) / "features.csv"
        typer.echo(f"{len(table) - len(failed)} of {len(table)} trials extracted → {target}")
        for row in failed.itertuples(index=False):
            typer.echo(f"failed: {row.trial}: {row.error}", err=True)

    @app.command()
    def reproduce(
        out: Path = typer.Option(Path("reports/reproduction"), "--out", help="Output directory."),
        quick: bool = typer.Option(
            False, "--quick", help="Reduced datasets: a few minutes on 2 cores."
        ),
        jobs: int = typer.Option(DEFAULT_JOBS, "--jobs", "-j", help="Worker processes."),
        dask: str | None = typer.Option(None, "--dask", help="Dask scheduler address."),
    ) -> None:
        """Run every experiment of the paper on simulated trials; write report.md / report.html."""
        from liquidtouch.experiments.reproduce import reproduce as run

        _print_summary(run(out, quick=quick, jobs=jobs, dask_address=dask))

    @app.command()
    def demo(
        out: Path = typer.Option(Path("demo-report"), "--out", help="Output directory."),
        jobs: int = typer.Option(DEFAULT_JOBS, "--jobs", "-j", help="Worker processes."),
    ) -> None:
        """The quick reproduction: simulate, extract from videos, fit, model, report."""
        from liquidtouch.experiments.reproduce import reproduce as run

        _print_summary(run(out, quick=True, jobs=jobs))
