"""The README and the getting-started page run as written.

Every fenced block preceded by ``<!-- runnable -->`` is run, in page order, in one fresh
directory per page: the bash blocks with ``bash -euo pipefail`` (each ``liquidtouch`` call
under a timeout), the python blocks with this interpreter. The files the tour says it
writes must exist afterwards. Every ``liquidtouch <command>`` the README or a page of the
documentation site mentions, in a code block or an inline code span, must exist
(``--help`` exits 0).
"""

from __future__ import annotations

import itertools
import os
import re
import shlex
import subprocess
import sys
import time
from pathlib import Path
from typing import NamedTuple

import pytest
from helpers import REPO

from liquidtouch.cli import main

README = REPO / "README.md"
GETTING_STARTED = REPO / "docs" / "getting-started.md"
BIN = Path(sys.executable).parent  # the venv's bin: liquidtouch, python
COMMAND_TIMEOUT_S = 150  # one liquidtouch call of the tour
BLOCK_TIMEOUT_S = 400  # one whole block (the dataset loop)

FENCE = re.compile(r"^```(\w*)\n(.*?)^```\s*$", re.DOTALL | re.MULTILINE)
RUNNABLE = re.compile(
    r"<!--\s*runnable\s*-->\s*\n```(\w+)\n(.*?)^```\s*$", re.DOTALL | re.MULTILINE
)
INLINE_CODE = re.compile(r"`([^`\n]+)`")
# not `import liquidtouch as lt`
MENTION = re.compile(r"(?<![\w/.-])(?<!import )liquidtouch((?:[ \t]+[a-z][a-z0-9-]*){1,2})")
OUTPUT_OPTIONS = {"--out", "-o", "--signal-out", "--tracks-out", "--plot"}

# What each tour says it writes (besides every --out/-o/--signal-out/--tracks-out/--plot path).
TRIAL_FILES = [
    "trial/meta.json",
    "trial/force.csv",
    "trial/wrench.csv",
    "trial/left.mp4",
    "trial/right.mp4",
]
TOUR_FILES = {
    README: [*TRIAL_FILES, "olive-oil-28/meta.json", "olive-oil-height.json"],
    GETTING_STARTED: [
        *TRIAL_FILES,
        "trial/truth_tracks.npz",
        "trial/loads.png",
        "mine/.liquidtouch-dataset",
        "mine/manifest.csv",
        "mine/features.csv",
        "mine/water/h25/meta.json",
    ],
}
#: the languages of each page's runnable blocks
TOUR_LANGUAGES = {README: {"bash", "python"}, GETTING_STARTED: {"bash"}}

# A shell function in front of the console script: each call gets a timeout.
PREAMBLE = f"""
liquidtouch() {{ timeout {COMMAND_TIMEOUT_S} {shlex.quote(str(BIN / "liquidtouch"))} "$@"; }}
"""


class Help(NamedTuple):
    """Exit status and output of a ``--help``."""

    returncode: int
    stdout: str
    stderr: str


def page_text(page: Path) -> str:
    return page.read_text(encoding="utf-8")


def documentation_pages() -> list[Path]:
    """The README and every Markdown page of the documentation site."""
    return [README, *sorted((REPO / "docs").rglob("*.md"))]


def runnable_blocks(text: str) -> list[tuple[str, str]]:
    """(language, code) of every block marked runnable, in page order."""
    return [(lang, code) for lang, code in RUNNABLE.findall(text)]


def logical_lines(code: str) -> list[str]:
    """The shell lines of a block: continuations joined, comments and blanks dropped."""
    joined = re.sub(r"\\\n", " ", code)
    lines = []
    for line in joined.splitlines():
        try:
            tokens = shlex.split(line, comments=True)
        except ValueError:
            continue
        if tokens:
            lines.append(shlex.join(tokens))
    return lines


def declared_outputs(code: str) -> list[str]:
    """The paths given to output options in a bash block (not those built from $variables)."""
    outputs = []
    for line in logical_lines(code):
        tokens = shlex.split(line)
        for option, value in itertools.pairwise(tokens):
            if option in OUTPUT_OPTIONS and not value.startswith("-") and "$" not in value:
                outputs.append(value)
    return outputs


def mentioned_commands(text: str) -> set[tuple[str, ...]]:
    """Every ``liquidtouch <command> [<subcommand>]`` in a page's code (not its prose).

    Code is the bash and unlabelled fenced blocks and the inline code spans; python blocks
    are left out (``import liquidtouch as lt``).
    """
    code_parts = [code for lang, code in FENCE.findall(text) if lang in ("", "bash", "sh")]
    prose = FENCE.sub("", text)
    code_parts += INLINE_CODE.findall(prose)
    found = set()
    for part in code_parts:
        for match in MENTION.finditer(part):
            found.add(tuple(match.group(1).split()))
    return found


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["PATH"] = f"{BIN}{os.pathsep}{env.get('PATH', '')}"
    env["PYTHONUNBUFFERED"] = "1"
    env.pop("PYTHONPATH", None)
    return env


def _help(args: list[str], capsys: pytest.CaptureFixture[str]) -> Help:
    """``liquidtouch ARGS --help`` in this process (the command line's own ``main``: the
    same commands as the console script, without a Python start-up per command)."""
    capsys.readouterr()
    status = main([*args, "--help"])
    out, err = capsys.readouterr()
    return Help(status, out, err)


README_MAX_LINES = 170  # a front door, not a manual: the rest lives in docs/ (issue 37)
DATE = re.compile(r"\b20\d\d-\d\d-\d\d\b")
LINK = re.compile(r"\]\(([^)#\s]+)(?:#[^)]*)?\)")


def test_the_readme_is_a_front_door() -> None:
    """Short, no dated timings, and every relative link leads to a file of the repository."""
    text = page_text(README)
    assert len(text.splitlines()) <= README_MAX_LINES
    assert not DATE.findall(text), "dated numbers belong in benchmarks/RESULTS.md"
    targets = [t for t in LINK.findall(text) if "://" not in t]
    assert "docs/getting-started.md" in targets and "docs/api/index.md" in targets
    missing = [t for t in targets if not (REPO / t).exists()]
    assert not missing, f"README links to files that do not exist: {missing}"


@pytest.mark.parametrize("page", list(TOUR_LANGUAGES), ids=lambda p: p.name)
def test_the_tours_mark_runnable_blocks(page: Path) -> None:
    blocks = runnable_blocks(page_text(page))
    languages = {lang for lang, _ in blocks}
    assert languages == TOUR_LANGUAGES[page], languages
    for _, code in blocks:
        assert "[--" not in code and "..." not in code, (
            f"a placeholder in a runnable block:\n{code}"
        )


def test_every_mentioned_command_exists(capsys: pytest.CaptureFixture[str]) -> None:
    mentions = set().union(*(mentioned_commands(page_text(p)) for p in documentation_pages()))
    assert ("simulate", "trial") in mentions and ("features",) in {m[:1] for m in mentions}
    helps: dict[tuple[str, ...], Help] = {}

    def help_of(command: tuple[str, ...]) -> Help:
        if command not in helps:
            helps[command] = _help(list(command), capsys)
        return helps[command]

    missing = set()
    for mention in sorted(mentions):
        top = help_of(mention[:1])
        if top.returncode != 0:
            missing.add(f"liquidtouch {mention[0]}: {top.stderr.strip() or top.stdout.strip()}")
        elif len(mention) == 2 and "Commands:" in top.stdout:  # a group: its subcommand too
            sub = help_of(mention)
            if sub.returncode != 0:
                missing.add(f"liquidtouch {' '.join(mention)}: {sub.stderr.strip()}")
    assert not missing, "the docs mention commands that do not exist:\n" + "\n".join(
        sorted(missing)
    )


@pytest.mark.parametrize(
    "page",
    [
        pytest.param(README, marks=pytest.mark.slow(seconds=15)),
        pytest.param(GETTING_STARTED, marks=pytest.mark.slow(seconds=55, exclusive=True)),
    ],
    ids=lambda p: p.name,
)  # the getting-started tour runs features -j 2
def test_the_tour_runs_as_written(page: Path, tmp_path: Path) -> None:
    blocks = runnable_blocks(page_text(page))
    expected = list(TOUR_FILES[page])
    timings = []
    for index, (lang, code) in enumerate(blocks):
        start = time.monotonic()
        if lang == "bash":
            expected += declared_outputs(code)
            command = ["bash", "-euo", "pipefail", "-c", PREAMBLE + code]
        elif lang == "python":
            command = [sys.executable, "-c", code]
        else:
            pytest.fail(f"runnable block {index} has no runner for language {lang!r}")
        try:
            result = subprocess.run(
                command,
                cwd=tmp_path,
                capture_output=True,
                text=True,
                timeout=BLOCK_TIMEOUT_S,
                env=_env(),
            )
        except subprocess.TimeoutExpired as exc:
            pytest.fail(f"runnable block {index} ({lang}) timed out:\n{code}\n{exc.stderr}")
        timings.append(f"block {index} ({lang}): {time.monotonic() - start:.1f} s")
        assert result.returncode == 0, (
            f"runnable block {index} ({lang}) failed with exit status {result.returncode}:\n"
            f"{code}\n--- stdout (end)\n{result.stdout[-3000:]}\n--- stderr (end)\n"
            f"{result.stderr[-3000:]}"
        )
    print("\n".join(timings))
    missing = [path for path in expected if not (tmp_path / path).exists()]
    assert not missing, f"the {page.name} tour said it writes these, but missing: {missing}"
