"""The report as a reader sees it: report.html opened in headless Chromium.

The report of the seven experiments on the synthetic tables of
``liquidtouch.testing.experiment_tables`` (conftest's ``synthetic_report``, built once per
run and also checked by ``test_experiments.py``) is rendered to a screenshot and
to its DOM by ``liquidtouch.testing.report_page``: every image is an embedded PNG that
decodes, the page is not blank, the headline table is there and no text says "wt%".
Without Chromium the tests skip locally, and fail when the environment variable
``CI`` is set (CI must not skip them silently; ``.ci/run`` installs Debian's
``chromium``).
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from helpers import chromium_or_skip

from liquidtouch.testing.report_page import check_report


@pytest.fixture(scope="module")
def browser() -> str:
    return chromium_or_skip()


@pytest.fixture(scope="module")
def report_html(synthetic_report: Path) -> Path:
    return synthetic_report / "report.html"  # conftest: shared with test_experiments.py


def test_report_renders_with_all_images_and_the_headline_table(
    browser, report_html, tmp_path
) -> None:
    png = tmp_path / "screenshot.png"  # not beside the shared report
    check = check_report(report_html, png, browser=browser)
    assert check.problems == [], check.problems
    assert check.images == check.images_loaded == 8  # one figure per experiment
    assert check.colours > 500  # text and eight figures, not a blank page
    from PIL import Image

    with Image.open(png) as im:
        assert im.size == (1280, 4000)


def test_the_check_catches_a_broken_image_and_wt_percent(browser, report_html, tmp_path) -> None:
    page = report_html.read_text(encoding="utf-8")
    broken = re.sub(
        r"src='data:image/png;base64,[^']{0,200}", "src='data:image/png;base64,AAAA", page, count=1
    )
    broken = broken.replace("<h2>Summary</h2>", "<h2>Summary</h2><p>c [wt%]</p>", 1)
    path = tmp_path / "broken.html"
    path.write_text(broken, encoding="utf-8")
    problems = check_report(path, tmp_path / "broken.png", browser=browser).problems
    assert any("7 of 8 images decoded" in p for p in problems), problems
    assert any("wt%" in p for p in problems), problems


def test_the_check_catches_a_blank_page(browser, tmp_path) -> None:
    path = tmp_path / "blank.html"
    path.write_text("<!DOCTYPE html><html><body></body></html>", encoding="utf-8")
    problems = check_report(path, tmp_path / "blank.png", browser=browser).problems
    assert any("blank" in p for p in problems), problems
    assert any("no headline" in p for p in problems), problems
