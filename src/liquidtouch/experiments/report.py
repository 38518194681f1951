"""The reproduction report: ``report.md`` and a self-contained ``report.html``.

Each experiment hands back an :class:`ExperimentResult`; this module lays
them out next to the paper's published numbers (:mod:`.paper`). The HTML
embeds its figures (base64 PNG), so it opens in a browser with no server and
no other files. Text columns are left-aligned, numbers right-aligned.
"""

from __future__ import annotations

import base64
import html
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from liquidtouch._core import atomic
from liquidtouch.experiments.paper import CITATION, PaperValue

SUMMARY_COLUMNS = ["experiment", "metric", "ours", "paper", "unit", "note", "paper source"]


@dataclass
class Headline:
    """One number of the summary table: ours next to the paper's.

    ``note`` says what the number means when it could mislead on its own (a
    0 % that is "no answer" rather than "all wrong"); ``source`` is where the
    paper gives its number.
    """

    experiment: str
    metric: str
    ours: float
    paper: float | None = None
    unit: str = ""
    note: str = ""
    source: str = ""

    @classmethod
    def vs(
        cls,
        experiment: str,
        metric: str,
        ours: float,
        reference: PaperValue | None,
        unit: str = "",
        note: str = "",
    ) -> Headline:
        """A headline against ``reference`` (its value, unit and source; None: not in the paper)."""
        if reference is None:
            return cls(experiment, metric, ours, None, unit, note)
        return cls(
            experiment, metric, ours, reference.value, unit or reference.unit, note,
            reference.source,
        )  # fmt: skip


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


def _numeric_columns(table: pd.DataFrame) -> list[bool]:
    """Which columns hold numbers (right-aligned) rather than text (left-aligned)."""
    return [
        pd.api.types.is_numeric_dtype(table[c]) and not pd.api.types.is_bool_dtype(table[c])
        for c in table.columns
    ]


def markdown_table(table: pd.DataFrame) -> str:
    """Render ``table`` as a GitHub-flavoured markdown table (no extra dependency)."""
    header = "| " + " | ".join(str(c) for c in table.columns) + " |"
    rule = "|" + "|".join("---:" if num else ":---" for num in _numeric_columns(table)) + "|"
    body = [
        "| " + " | ".join(_fmt(v).replace("|", "\\|") for v in row) + " |"
        for row in table.itertuples(index=False)
    ]
    return "\n".join([header, rule, *body])


def html_table(table: pd.DataFrame, css_class: str = "") -> str:
    """Render ``table`` as HTML: text columns left-aligned, number columns right-aligned."""
    numeric = _numeric_columns(table)
    cls = [" class='num'" if num else "" for num in numeric]
    head = "".join(
        f"<th{c}>{html.escape(str(name))}</th>" for c, name in zip(cls, table.columns, strict=True)
    )
    rows = [
        "<tr>"
        + "".join(f"<td{c}>{_html_text(_fmt(v))}</td>" for c, v in zip(cls, row, strict=True))
        + "</tr>"
        for row in table.itertuples(index=False)
    ]
    klass = f" class='{css_class}'" if css_class else ""
    return f"<table{klass}><thead><tr>{head}</tr></thead><tbody>{''.join(rows)}</tbody></table>"


def summary_table(results: list[ExperimentResult]) -> pd.DataFrame:
    """All headline numbers of all experiments, ours next to the paper's (with its source)."""
    rows = [
        {
            "experiment": h.experiment,
            "metric": h.metric,
            "ours": h.ours,
            "paper": math.nan if h.paper is None else h.paper,
            "unit": h.unit,
            "note": h.note,
            "paper source": h.source,
        }
        for r in results
        for h in r.headlines
    ]
    return pd.DataFrame(rows, columns=SUMMARY_COLUMNS)


UNITS_NOTE = (
    "Units: h = fill height [mm]; c = sugar concentration in g sugar per 100 g water (a ratio "
    "to the water, not a mass fraction: 160 g/100 g water is 61.5 % sugar by mass); "
    "μ = log10 ν with ν the kinematic viscosity in cSt "
    "[log10 cSt], so an MAE of μ is in decades of viscosity; λ = decay rate [1/s]; "
    "ω = angular frequency [rad/s]."
)

_STYLE = (
    "body{font-family:system-ui,sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;"
    "color:#222;line-height:1.4}table{border-collapse:collapse;margin:1em 0;font-size:14px}"
    "td,th{padding:4px 10px;border-bottom:1px solid #ddd;text-align:left;vertical-align:top}"
    "th{background:#f3f3f3}td:first-child{white-space:nowrap}td.num,th.num{text-align:right;font-variant-numeric:tabular-nums}"
    "table.summary td:nth-child(6),table.summary td:nth-child(7){font-size:12px;color:#555;"
    "max-width:260px}table.summary td:nth-child(5){white-space:nowrap}"
    "table.provenance td:first-child{font-weight:600;white-space:nowrap}"
    "img{max-width:100%;border:1px solid #eee;margin:.5em 0}.time,.note{color:#777}"
)


def write_report(
    results: list[ExperimentResult],
    out_dir: str | Path,
    *,
    title: str,
    preamble: str,
    provenance: dict[str, str] | None = None,
) -> tuple[Path, Path]:
    """Write ``report.md``, ``report.html``, ``summary.csv`` and each table as CSV into ``out_dir``.

    ``provenance``: what produced the report (versions, commit, seeds, machine),
    shown as a two-column table.
    """
    out_dir = Path(out_dir)
    summary = summary_table(results)
    atomic.write_text(out_dir / "summary.csv", summary.to_csv(index=False))
    sources = f"Paper: {CITATION}. “paper source” names the experiment each number is from."
    md = [f"# {title}", "", preamble, "", UNITS_NOTE, ""]
    body = [
        f"<h1>{html.escape(title)}</h1>",
        f"<p>{_html_text(preamble)}</p>",
        f"<p class='note'>{_html_text(UNITS_NOTE)}</p>",
    ]
    md += ["## Summary", "", sources, "", markdown_table(summary), ""]
    body += [
        "<h2>Summary</h2>",
        f"<p class='note'>{_html_text(sources)}</p>",
        html_table(summary, "summary"),
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
            body += [f"<h3>{html.escape(caption)}</h3>", html_table(table)]
        for figure in result.figures:
            md += [f"![{figure.stem}]({figure.name})", ""]
            data = base64.b64encode(Path(figure).read_bytes()).decode("ascii")
            body.append(
                f"<img alt='{html.escape(figure.stem)}' src='data:image/png;base64,{data}'>"
            )
    if provenance:
        table = pd.DataFrame({"item": list(provenance), "value": list(provenance.values())})
        md += ["## Provenance", "", markdown_table(table), ""]
        body += ["<h2>Provenance</h2>", html_table(table, "provenance")]
    page = (
        "<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
        f"<title>{html.escape(title)}</title><style>{_STYLE}</style></head><body>"
        + "\n".join(body)
        + "</body></html>\n"
    )
    md_path, html_path = out_dir / "report.md", out_dir / "report.html"
    atomic.write_text(md_path, "\n".join(md) + "\n")
    atomic.write_text(html_path, page)
    return md_path, html_path
