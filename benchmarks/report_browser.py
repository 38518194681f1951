"""Open a reproduction report in headless Chromium and check what a reader would see.

    python benchmarks/report_browser.py REPORT_DIR/report.html [--png shot.png]

Chromium (Debian's ``chromium`` package) renders ``report.html`` twice: once
to a screenshot (``--screenshot``, 1280 px wide) and once to its DOM
(``--dump-dom``), the latter on a copy of the page with a small script that
records, after the load event, how many images decoded. Checks:

- every ``<img>`` is an embedded ``data:image/png`` URI and decoded in the browser
  (``naturalWidth > 0``);
- the screenshot is not blank (not one uniform colour: it has text and figures);
- the summary (headline) table is there, with its columns;
- no text says "wt%" (the sugar concentration is g sugar per 100 g water).

Used by ``tests/test_report_browser.py``; exit status 1 when a check fails.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")
WINDOW = (1280, 4000)
#: runs of a stuck Chromium before giving up
ATTEMPTS = 2
SUMMARY_COLUMNS = ("experiment", "metric", "ours", "paper", "unit")

# appended to a copy of the page: after load, write the image counts into the DOM
_PROBE = (
    "<script>window.addEventListener('load',function(){var i=[].slice.call("
    "document.images);document.body.setAttribute('data-images',i.length);"
    "document.body.setAttribute('data-images-loaded',i.filter(function(x){"
    "return x.complete&&x.naturalWidth>0}).length);});</script>"
)


def find_chromium() -> str | None:
    """Path of a Chromium-family browser, or None."""
    for name in BROWSERS:
        path = shutil.which(name)
        if path:
            return path
    return None


def _chromium(browser: str, *args: str, timeout: float) -> subprocess.CompletedProcess:
    """Run headless Chromium with ``args``; a run stuck past ``timeout`` s is run again.

    Once in CI a ``--screenshot`` run with ``--virtual-time-budget`` never finished: a
    stuck run is killed with its child processes and started afresh, up to ``ATTEMPTS``.
    """
    for attempt in range(1, ATTEMPTS + 1):
        with tempfile.TemporaryDirectory(prefix="lt-chromium-") as profile:
            command = [
                browser,
                "--headless",
                "--no-sandbox",  # root in a container has no user namespace sandbox
                "--disable-gpu",
                "--disable-dev-shm-usage",
                "--hide-scrollbars",
                "--no-first-run",
                "--allow-file-access-from-files",
                f"--user-data-dir={profile}",
                *args,
            ]
            process = subprocess.Popen(
                command,
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                text=True,
                start_new_session=True,  # its own process group: killed with its children
            )
            try:
                stdout, stderr = process.communicate(timeout=timeout)
            except subprocess.TimeoutExpired:
                os.killpg(process.pid, signal.SIGKILL)
                process.communicate()
                print(
                    f"chromium: nothing after {timeout:.0f} s, killed (attempt {attempt} of "
                    f"{ATTEMPTS})",
                    file=sys.stderr,
                )
                continue
            return subprocess.CompletedProcess(command, process.returncode, stdout, stderr)
    raise RuntimeError(f"chromium was stuck {ATTEMPTS} times for {timeout:.0f} s: {args}")


def screenshot(
    html: Path, png: Path, *, browser: str | None = None, window=WINDOW, timeout: float = 120
) -> Path:
    """Render ``html`` to ``png`` (``window`` = width, height in px)."""
    browser = browser or find_chromium()
    if browser is None:
        raise FileNotFoundError("no chromium on PATH")
    png.parent.mkdir(parents=True, exist_ok=True)
    png.unlink(missing_ok=True)
    done = _chromium(
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
        done = _chromium(
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


def _screenshot_colours(png: Path) -> int:
    """Number of distinct colours of the screenshot (1: blank)."""
    from PIL import Image

    with Image.open(png) as im:
        colours = im.convert("RGB").getcolors(maxcolors=1 << 20)
    return len(colours) if colours is not None else 1 << 20


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

    check.colours = _screenshot_colours(check.png)
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


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("html", type=Path, help="report.html")
    parser.add_argument("--png", type=Path, help="screenshot [default: beside the report]")
    args = parser.parse_args(argv)
    png = args.png or args.html.with_name("report_screenshot.png")
    if find_chromium() is None:
        print("no chromium on PATH (apt-get install chromium)", file=sys.stderr)
        return 2
    check = check_report(args.html, png)
    print(f"screenshot: {check.png} ({check.colours} colours)")
    print(f"images: {check.images_loaded}/{check.images} decoded")
    for problem in check.problems:
        print(f"problem: {problem}")
    return 1 if check.problems else 0


if __name__ == "__main__":
    raise SystemExit(main())
