"""What a reader of the reproduction report sees in headless Chromium.

Chromium renders ``report.html`` twice: once to a screenshot (``--screenshot``, 1280 px
wide) and once to its DOM (``--dump-dom``), the latter on a copy of the page with a small
script that records, after the load event, how many images decoded. Checks:

- every ``<img>`` is an embedded ``data:image/png`` URI and decoded in the browser
  (``naturalWidth > 0``);
- the screenshot is not blank (not one uniform colour: it has text and figures);
- the summary (headline) table is there, with its columns;
- no text says "wt%" (the sugar concentration is g sugar per 100 g water).

Used by ``tests/experiments/test_report_browser.py`` and
``benchmarks/experiments/report_browser.py``.
"""

from __future__ import annotations

import re
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

from liquidtouch.testing.chromium import find_chromium, run_chromium, screenshot_colours

#: the browser window, width and height [px]
WINDOW = (1280, 4000)
SUMMARY_COLUMNS = ("experiment", "metric", "ours", "paper", "unit")

# appended to a copy of the page: after load, write the image counts into the DOM
_PROBE = (
    "<script>window.addEventListener('load',function(){var i=[].slice.call("
    "document.images);document.body.setAttribute('data-images',i.length);"
    "document.body.setAttribute('data-images-loaded',i.filter(function(x){"
    "return x.complete&&x.naturalWidth>0}).length);});</script>"
)


def screenshot(
    html: Path,
    png: Path,
    *,
    browser: str | None = None,
    window: tuple[int, int] = WINDOW,
    timeout: float = 120,
) -> Path:
    """Render ``html`` to ``png`` (``window`` = width, height [px]; ``timeout`` [s])."""
    browser = browser or find_chromium()
    if browser is None:
        raise FileNotFoundError("no chromium on PATH")
    png.parent.mkdir(parents=True, exist_ok=True)
    png.unlink(missing_ok=True)
    done = run_chromium(
        browser,
        f"--screenshot={png.resolve()}",
        f"--window-size={window[0]},{window[1]}",
        Path(html).resolve().as_uri(),
        timeout=timeout,
    )
    if not png.is_file():
        raise RuntimeError(f"chromium wrote no screenshot (exit {done.returncode}): {done.stderr}")
    return png


def dump_dom(html: Path, *, browser: str | None = None, timeout: float = 120) -> str:
    """The DOM of ``html`` after load, from a copy carrying the image probe."""
    browser = browser or find_chromium()
    if browser is None:
        raise FileNotFoundError("no chromium on PATH")
    page = Path(html).read_text(encoding="utf-8")
    with tempfile.TemporaryDirectory(prefix="lt-report-") as tmp:
        probe = Path(tmp) / "report_probe.html"
        probe.write_text(page.replace("</body>", _PROBE + "</body>", 1), encoding="utf-8")
        done = run_chromium(
            browser,
            "--virtual-time-budget=10000",
            "--dump-dom",
            probe.as_uri(),
            timeout=timeout,
        )
    if not done.stdout.strip():
        raise RuntimeError(f"chromium dumped no DOM (exit {done.returncode}): {done.stderr}")
    return done.stdout


@dataclass
class BrowserCheck:
    """What the browser showed, and what is wrong with it (``problems`` empty: all good)."""

    png: Path
    images: int = 0
    images_loaded: int = 0
    colours: int = 0
    problems: list[str] = field(default_factory=list)


def check_report(html: Path, png: Path, *, browser: str | None = None) -> BrowserCheck:
    """Screenshot ``html`` to ``png``, dump its DOM, and list what a reader would find wrong."""
    html = Path(html)
    check = BrowserCheck(png=screenshot(html, Path(png), browser=browser))
    dom = dump_dom(html, browser=browser)
    problems = check.problems

    tags = re.findall(r"<img\b[^>]*>", dom)
    sources = [re.search(r"src=\"([^\"]*)\"", tag) for tag in tags]
    if not tags:
        problems.append("no <img> in the rendered page")
    bad = [
        s.group(1)[:40] if s else "(no src)"
        for s in sources
        if not s or not s.group(1).startswith("data:image/png;base64,")
    ]
    if bad:
        problems.append(f"{len(bad)} image(s) not embedded as data:image/png: {bad[:3]}")
    counts = re.search(r"data-images=\"(\d+)\"[^>]*data-images-loaded=\"(\d+)\"", dom)
    if counts is None:
        problems.append("the image probe did not run (no data-images in the DOM)")
    else:
        check.images, check.images_loaded = int(counts.group(1)), int(counts.group(2))
        if check.images_loaded != check.images or check.images != len(tags):
            problems.append(
                f"{check.images_loaded} of {check.images} images decoded in the browser"
            )

    check.colours = screenshot_colours(check.png)
    if check.colours < 50:  # a page of text and figures has thousands
        problems.append(f"the screenshot is (nearly) blank: {check.colours} colour(s)")

    summary = re.search(
        r"<h2>Summary</h2>\s*(?:<p[^>]*>.*?</p>\s*)?<table[^>]*>(.*?)</table>", dom, re.S
    )
    if summary is None:
        problems.append("no headline (summary) table after the Summary heading")
    else:
        header = [
            re.sub(r"<[^>]+>", "", h).strip()
            for h in re.findall(r"<th[^>]*>(.*?)</th>", summary.group(1))
        ]
        missing = [c for c in SUMMARY_COLUMNS if c not in header]
        if missing:
            problems.append(f"the summary table lacks columns {missing}")
        if summary.group(1).count("<tr") < 2:
            problems.append("the summary table has no rows")

    text = re.sub(r"<[^>]+>", " ", re.sub(r"<(script|style)\b.*?</\1>", " ", dom, flags=re.S))
    if re.search(r"wt\s*%", text, re.I):
        problems.append("a text says wt% (c is g sugar per 100 g water)")
    return check
