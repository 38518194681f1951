"""The documentation site: it builds with ``--strict``, documents every public name, and
renders in a browser.

The site (``mkdocs.yml``, pages in ``docs/``) is built once per module into a temporary
directory, as ``make test`` builds it: a broken link, a missing page or a ``:::``
reference mkdocstrings cannot resolve fails the build. Every name of
``liquidtouch.__all__`` must be documented by a ``:::`` directive of an API page
(``docs/api/*.md``) that names the very object, and rendered into the built page. The home
page and one API page are opened in headless Chromium (Debian's ``chromium``; without it
the browser test skips locally and fails when ``CI`` is set): the screenshots land in the
test's temporary directory.
"""

from __future__ import annotations

import importlib
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from helpers import REPO, chromium_or_skip
from PIL import Image

import liquidtouch
from liquidtouch.testing.report_page import dump_dom, screenshot

BIN = Path(sys.executable).parent  # the venv's bin: mkdocs
API_PAGES = REPO / "docs" / "api"
DIRECTIVE = re.compile(r"^:::[ \t]+([\w.]+)[ \t]*$", re.MULTILINE)
BUILD_TIMEOUT_S = 180  # a few seconds on an idle machine; mkdocs imports griffe and Material


def api_directives() -> dict[str, Path]:
    """Every ``::: dotted.path`` of the API pages -> the page that holds it."""
    found = {}
    for page in sorted(API_PAGES.glob("*.md")):
        for path in DIRECTIVE.findall(page.read_text(encoding="utf-8")):
            found[path] = page
    return found


def resolve(dotted: str) -> object:
    """The object a ``:::`` directive names: the longest importable module, then attributes."""
    parts = dotted.split(".")
    for split in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:split]))
        except ModuleNotFoundError:
            continue
        for attribute in parts[split:]:
            obj = getattr(obj, attribute)
        return obj
    raise ModuleNotFoundError(dotted)


def page_html(site: Path, page: str) -> str:
    """The built HTML of a documentation page (``api/fit.md`` -> ``api/fit/index.html``)."""
    stem = page.removesuffix(".md")
    path = site / "index.html" if stem == "index" else site / stem / "index.html"
    return path.read_text(encoding="utf-8")


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("site")
    done = subprocess.run(
        [str(BIN / "mkdocs"), "build", "--strict", "--site-dir", str(out)],
        cwd=REPO,  # mkdocs.yml's paths (src, the snippets' base) are relative to the root
        capture_output=True,
        text=True,
        timeout=BUILD_TIMEOUT_S,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},
    )
    assert done.returncode == 0, f"mkdocs build --strict failed:\n{done.stderr[-4000:]}"
    return out


def test_every_public_name_has_a_directive_in_the_api_reference() -> None:
    documented = {}
    for dotted, page in api_directives().items():
        documented.setdefault(dotted.rsplit(".", 1)[-1], []).append((dotted, page))
    missing, wrong = [], []
    for name in liquidtouch.__all__:
        if name == "__version__":
            continue
        entries = documented.get(name, [])
        if not entries:
            missing.append(name)
        elif not any(resolve(dotted) is getattr(liquidtouch, name) for dotted, _ in entries):
            wrong.append(f"{name}: {[dotted for dotted, _ in entries]}")
    assert not missing, f"public names with no `::: path` in docs/api/*.md: {missing}"
    assert not wrong, f"`:::` directives that name another object: {wrong}"


def test_the_check_sees_a_directive_that_names_another_object() -> None:
    assert resolve("liquidtouch.fit.oscillation.fit_oscillation") is liquidtouch.fit_oscillation
    assert resolve("liquidtouch.signal.tactile.tactile_signal") is not liquidtouch.fit_oscillation
    with pytest.raises(AttributeError):
        resolve("liquidtouch.fit.oscillation.no_such_name")


@pytest.mark.slow(seconds=8)
def test_the_built_api_pages_render_every_directive(site: Path) -> None:
    for dotted, page in api_directives().items():
        html = page_html(site, f"api/{page.name}")
        assert f'id="{dotted}"' in html, f"{dotted} is not rendered in the built {page.name}"
    fit = page_html(site, "api/fit.md")
    assert "decay_rate" in fit and "Parameters" in fit  # the docstring, not just a heading


@pytest.mark.slow(seconds=8)
def test_the_results_page_includes_benchmarks_results(site: Path) -> None:
    results = (REPO / "benchmarks" / "RESULTS.md").read_text(encoding="utf-8")
    first_heading = re.search(r"^## (.+)$", results, re.MULTILINE).group(1)
    html = page_html(site, "results.md")
    assert "Benchmark results" in html and first_heading.split(" — ")[0] in html


@pytest.mark.slow(seconds=8)
def test_the_command_line_page_has_every_commands_help(site: Path) -> None:
    html = page_html(site, "cli.md")
    for command in ("fit", "dataset add", "simulate trial", "rig serve", "run-trial", "live"):
        assert f"Usage: liquidtouch {command} [OPTIONS]" in html, command
    assert "&lt;!-- cli-reference --&gt;" not in html and "cli-reference" not in html


@pytest.mark.slow(seconds=20)
def test_the_home_page_and_an_api_page_render_in_a_browser(site: Path, tmp_path: Path) -> None:
    browser = chromium_or_skip()
    for page, expected in [("index.md", "Getting started"), ("api/fit.md", "fit_oscillation")]:
        html = site / ("index.html" if page == "index.md" else "api/fit/index.html")
        png = tmp_path / f"{page.replace('/', '_')}.png"
        screenshot(html, png, browser=browser, window=(1280, 1600))
        dom = dump_dom(html, browser=browser)
        title = re.search(r"<title>(.*?)</title>", dom, re.S)
        assert title and "liquidtouch" in title.group(1), title
        assert 'class="md-nav' in dom and "md-header" in dom, f"{page}: no Material navigation"
        assert expected in dom, f"{page}: {expected!r} is not on the page"
        with Image.open(png) as image:
            colours = image.convert("RGB").getcolors(maxcolors=1 << 20)
        assert colours is None or len(colours) > 50, f"{page}: the screenshot is nearly blank"
