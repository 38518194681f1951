"""Open a reproduction report in headless Chromium and check what a reader would see.

    .venv/bin/python benchmarks/experiments/report_browser.py REPORT_DIR/report.html [--png PNG]

The checks are :func:`liquidtouch.testing.report_page.check_report`'s (embedded images
that decode, a screenshot that is not blank, the summary table, no "wt%"); the tests
run them too (``tests/experiments/test_report_browser.py``). Exit status 1 when a check
fails, 2 without Chromium.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from liquidtouch.testing.chromium import find_chromium
from liquidtouch.testing.report_page import check_report


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
