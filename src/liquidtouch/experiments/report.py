"""The reproduction report: ``report.md`` and a self-contained ``report.html``.

Each experiment hands back an :class:`ExperimentResult`; this module lays
them out next to the paper's published numbers. The HTML embeds its figures
(base64 PNG), so it opens in a browser with no server and no other files.
"""

from __future__ import annotations

import base64
import html
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from liquidtouch.io import atomic


@dataclass
class Headline:
    """One number of the summary table: ours next to the paper's."""

    experiment: str
    metric: str
    ours: float
    paper: float | None = None
    unit: str = ""


@dataclass
class ExperimentResult:
    """What one experiment produced."""

    key: str
    title: str
    summary: str
    tables: list[tuple[str, pd.DataFrame]] = field(default_factory=list)
    figures: list[Path] = field(default_factory=list)
    headlines: list[Headline] = field(default_factory=list)
    seconds: float = 0.0


def _fmt(value: object) -> str:
    if isinstance(value, float):
        if math.isnan(value):
            return "–"
        return f"{value:.3g}" if abs(value) < 1000 else f"{value:.0f}"
    return str(value)


def _html_text(text: str) -> str:
    """Escape ``text`` for HTML, rendering markdown `code` spans as <code>."""
    return re.sub(r"`([^`]+)`", r"<code>\1</code>", html.escape(text))


def markdown_table(table: pd.DataFrame) -> str:
    """Render ``table`` as a GitHub-flavoured markdown table (no extra dependency)."""
    header = "| " + " | ".join(str(c) for c in table.columns) + " |"
    rule = "|" + "|".join("---" for _ in table.columns) + "|"
    body = ["| " + " | ".join(_fmt(v) for v in row) + " |" for row in table.itertuples(index=False)]
    return "\n".join([header, rule, *body])


def summary_table(results: list[ExperimentResult]) -> pd.DataFrame:
    """All headline numbers of all experiments, ours next to the paper's."""
    rows = [
        {
            "experiment": h.experiment,
            "metric": h.metric,
            "ours": h.ours,
            "paper": math.nan if h.paper is None else h.paper,
            "unit": h.unit,
        }
        for r in results
        for h in r.headlines
    ]
    return pd.DataFrame(rows, columns=["experiment", "metric", "ours", "paper", "unit"])


def write_report(
    results: list[ExperimentResult], out_dir: str | Path, *, title: str, preamble: str
) -> tuple[Path, Path]:
    """Write ``report.md``, ``report.html`` and each table as CSV into ``out_dir``."""
    out_dir = Path(out_dir)
    summary = summary_table(results)
    atomic.write_text(out_dir / "summary.csv", summary.to_csv(index=False))
    md = [f"# {title}", "", preamble, "", "## Summary", "", markdown_table(summary), ""]
    body = [
        f"<h1>{html.escape(title)}</h1>",
        f"<p>{_html_text(preamble)}</p>",
        "<h2>Summary</h2>",
        summary.to_html(index=False, float_format=_fmt, na_rep="–", border=0),
    ]
    for result in results:
        md += [f"## {result.title}", "", result.summary, "", f"*({result.seconds:.0f} s)*", ""]
        body += [
            f"<h2>{html.escape(result.title)}</h2>",
            f"<p>{_html_text(result.summary)}</p>",
            f"<p class='time'>({result.seconds:.0f} s)</p>",
        ]
        for i, (caption, table) in enumerate(result.tables):
            name = f"{result.key}_{i}.csv" if len(result.tables) > 1 else f"{result.key}.csv"
            atomic.write_text(out_dir / name, table.to_csv(index=False))
            md += [f"**{caption}** ([{name}]({name}))", "", markdown_table(table), ""]
            body += [
                f"<h3>{html.escape(caption)}</h3>",
                table.to_html(index=False, float_format=_fmt, na_rep="–", border=0),
            ]
        for figure in result.figures:
            md += [f"![{figure.stem}]({figure.name})", ""]
            data = base64.b64encode(Path(figure).read_bytes()).decode("ascii")
            body.append(
                f"<img alt='{html.escape(figure.stem)}' src='data:image/png;base64,{data}'>"
            )
    style = (
        "body{font-family:system-ui,sans-serif;max-width:1000px;margin:2em auto;padding:0 1em;"
        "color:#222}table{border-collapse:collapse;margin:1em 0}td,th{padding:4px 10px;"
        "border-bottom:1px solid #ddd;text-align:right}th{background:#f3f3f3}"
        "img{max-width:100%;border:1px solid #eee;margin:.5em 0}.time{color:#888}"
    )
    page = (
        "<!DOCTYPE html><html><head><meta charset='utf-8'>"
        f"<title>{html.escape(title)}</title><style>{style}</style></head><body>"
        + "\n".join(body)
        + "</body></html>\n"
    )
    md_path, html_path = out_dir / "report.md", out_dir / "report.html"
    atomic.write_text(md_path, "\n".join(md) + "\n")
    atomic.write_text(html_path, page)
    return md_path, html_path
