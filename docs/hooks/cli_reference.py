"""MkDocs hook: the command line page's reference, generated from the commands themselves.

``<!-- cli-reference -->`` in a page is replaced by the ``--help`` of every command and
subcommand of ``liquidtouch``, in the order ``liquidtouch --help`` lists them, so the site
documents each option as the installed command line has it, never from a hand-kept copy.
"""

from __future__ import annotations

import contextlib
import io
import os
import re
from collections.abc import Iterator
from typing import Any

from liquidtouch.cli import main

MARKER = "<!-- cli-reference -->"
#: columns of the help text: wide enough to read, narrow enough for the page's code blocks
WIDTH = "92"
COMMAND_LINE = re.compile(r"^  ([a-z][a-z0-9-]*)\s", re.MULTILINE)


@contextlib.contextmanager
def _columns(width: str) -> Iterator[None]:
    """Help text wrapped at ``width`` columns, whatever terminal runs the build."""
    before = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = width
    try:
        yield
    finally:
        if before is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = before


def help_text(args: list[str]) -> str:
    """``liquidtouch ARGS --help``, as the console script prints it."""
    out = io.StringIO()
    with _columns(WIDTH), contextlib.redirect_stdout(out):
        status = main([*args, "--help"])
    if status != 0:
        raise RuntimeError(f"liquidtouch {' '.join(args)} --help exited with {status}")
    return out.getvalue().rstrip()


def subcommands(text: str) -> list[str]:
    """The command names of a help text's ``Commands:`` section (none: a plain command)."""
    _, found, section = text.partition("\nCommands:\n")
    return COMMAND_LINE.findall(section) if found else []


def reference() -> str:
    """One section per command (a group's subcommands under it), each its help text."""
    parts = []
    for command in subcommands(help_text([])):
        text = help_text([command])
        nested = subcommands(text)
        for args in [[command, sub] for sub in nested] if nested else [[command]]:
            title = " ".join(args)
            parts.append(f"### `liquidtouch {title}`\n\n```text\n{help_text(args)}\n```\n")
    return "\n".join(parts)


def on_page_markdown(markdown: str, **kwargs: Any) -> str:
    """MkDocs event: fill in the marker where a page has it."""
    return markdown.replace(MARKER, reference()) if MARKER in markdown else markdown
