"""The paper's experiments end to end: ``reproduce`` and ``demo``."""

from __future__ import annotations

import contextlib
import json
import math
import os
import sys
from pathlib import Path

import typer

from liquidtouch.cli import options

DEFAULT_JOBS = max(1, min(2, os.cpu_count() or 1))


def _print_summary(reproduction) -> None:
    from rich.console import Console
    from rich.markup import escape
    from rich.table import Table

    world = getattr(reproduction, "realism", "clean")
    table = Table(title=f"liquidtouch reproduction ({world} world): ours vs the paper")
    for column in ("experiment", "metric", "ours", "paper", "unit"):
        table.add_column(column, justify="right" if column in ("ours", "paper") else "left")
    notes = []
    for row in reproduction.summary.itertuples(index=False):
        paper = "" if row.paper != row.paper else f"{row.paper:.3g}"
        metric = row.metric
        if row.note:  # notes go under the table: in a column they squeeze the rest
            notes.append(f"({len(notes) + 1}) {row.metric}: {row.note}")
            metric += f" ({len(notes)})"
        # text may hold brackets ("[mm]"), which rich would read as markup
        table.add_row(row.experiment, escape(metric), f"{row.ours:.3g}", paper, escape(row.unit))
    console = Console()
    console.print(table)
    for note in notes:
        console.print(escape(note))
    console.print(
        f"report: {reproduction.report_html}  (and {reproduction.report_md.name} beside it)"
    )
    if reproduction.data_dir is not None:
        console.print(f"simulated data: {reproduction.data_dir}  (reused by the next run)")


def _number(value: float) -> float | None:
    """JSON has no NaN: a missing number is null."""
    return None if value is None or (isinstance(value, float) and math.isnan(value)) else value


def reproduction_json(reproduction) -> dict[str, object]:
    """The summary metrics and paths of a reproduction, as one JSON-ready object."""
    summary = [
        {
            key.replace(" ", "_"): _number(float(value)) if key in ("ours", "paper") else value
            for key, value in row.items()
        }
        for row in reproduction.summary.to_dict("records")
    ]
    return {
        "report_html": str(reproduction.report_html.resolve()),
        "report_md": str(reproduction.report_md.resolve()),
        "summary_csv": str(reproduction.summary_csv.resolve()),
        "data_dir": None if reproduction.data_dir is None else str(reproduction.data_dir.resolve()),
        "seed": reproduction.seed,
        "realism": reproduction.realism,
        "seconds": {k: round(v, 2) for k, v in reproduction.seconds.items()},
        "summary": summary,
    }


@contextlib.contextmanager
def _stdout_to_stderr():
    """Send everything written to stdout (this process and its workers) to stderr meanwhile."""
    sys.stdout.flush()
    try:
        fd = sys.__stdout__.fileno()
        saved = os.dup(fd)
        os.dup2(sys.__stderr__.fileno(), fd)
    except (AttributeError, OSError, ValueError):  # no real stdout (embedded, test runner)
        fd = saved = None
    try:
        with contextlib.redirect_stdout(sys.stderr):
            yield
    finally:
        if saved is not None:
            with contextlib.suppress(Exception):
                sys.__stdout__.flush()
            os.dup2(saved, fd)
            os.close(saved)


def _run_and_report(as_json: bool, **options) -> None:
    """Run the reproduction; print the summary table, or (``as_json``) one JSON object."""
    from liquidtouch._core.progress import on_terminal
    from liquidtouch.experiments.reproduce import reproduce as run

    if not on_terminal():  # no progress bars: one line per stage instead (a log, CI, a pipe)
        options["on_stage"] = stage_line
    if not as_json:
        _print_summary(run(**options))
        return
    with _stdout_to_stderr():
        reproduction = run(**options)
    typer.echo(json.dumps(reproduction_json(reproduction), ensure_ascii=False, allow_nan=False))


def stage_line(text: str) -> None:
    """One stage of the reproduction as a line on stderr, with the time of day."""
    import sys
    import time

    print(f"{time.strftime('%H:%M:%S')} {text}", file=sys.stderr, flush=True)


_JSON_HELP = "Print one JSON object (summary metrics and paths) on stdout; progress on stderr."
_DATA_HELP = (
    "Directory of the simulated datasets, reused by the next run "
    "(default: OUT-data, beside the report directory, not inside it)."
)


def register(app: typer.Typer) -> None:
    """Register ``reproduce`` and ``demo``."""

    @app.command()
    def reproduce(
        out: Path = typer.Option(
            Path("reports/reproduction"), *options.OUT, help="Report directory."
        ),
        data: Path | None = typer.Option(None, "--data", file_okay=False, help=_DATA_HELP),
        quick: bool = typer.Option(
            False, "--quick", help="Reduced datasets: a few minutes on 2 cores."
        ),
        seed: int = typer.Option(
            0, "--seed", min=0, help="Base seed of the simulated trials and the random draws."
        ),
        jobs: options.Jobs = DEFAULT_JOBS,
        dask: options.Dask = None,
        realism: options.Realism = options.RealismChoice.clean,
        sensor: str | None = typer.Option(
            None,
            "--sensor",
            metavar="NAME",
            help="GelSight profile of the simulated videos (default: 'mini', the GelSight Mini, "
            "320x240 at 25 fps; 'default': 640x480 at 30 fps, twice the time).",
            show_default=False,
        ),
        gel: options.Gel = None,
        as_json: bool = typer.Option(False, "--json", help=_JSON_HELP),
    ) -> None:
        """Run every experiment of the paper on simulated trials; write report.md / report.html."""
        from liquidtouch.experiments.reproduce import DEFAULT_SENSOR
        from liquidtouch.sim.sensors import with_gel

        sensor = sensor if gel is None else with_gel(sensor or DEFAULT_SENSOR, gel.value)
        _run_and_report(
            as_json,
            out_dir=out,
            data_dir=data,
            quick=quick,
            seed=seed,
            jobs=jobs,
            dask_address=dask,
            realism=realism.value,
            sensor=sensor,
        )

    @app.command()
    def demo(
        out: Path = typer.Option(Path("demo-report"), *options.OUT, help="Report directory."),
        data: Path | None = typer.Option(None, "--data", file_okay=False, help=_DATA_HELP),
        jobs: options.Jobs = DEFAULT_JOBS,
        as_json: bool = typer.Option(False, "--json", help=_JSON_HELP),
    ) -> None:
        """The quick reproduction: simulate, extract from videos, fit, model, report."""
        _run_and_report(as_json, out_dir=out, data_dir=data, quick=True, jobs=jobs)
