"""One progress bar for all long work: a rich bar on stderr, or nothing.

The commands show bars only when stderr is a terminal (:func:`on_terminal`), so
a redirected or captured run (``--json``, scripts, tests) gets no bar output.
"""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Callable, Iterator


def on_terminal() -> bool:
    """Whether stderr is an interactive terminal: where the commands show progress bars."""
    try:
        return sys.stderr.isatty()
    except (AttributeError, ValueError):  # no stderr, or a closed one
        return False


@contextlib.contextmanager
def progress_bar(
    description: str, total: int | None, *, enabled: bool = True
) -> Iterator[Callable[..., None]]:
    """Yield ``advance(*_)`` that moves a rich bar (stderr) by one step; a no-op when disabled.

    ``advance`` takes and ignores any arguments, so it can be passed straight
    as a per-item callback (``on_frame``, ``progress(target)``).
    """
    if not enabled or not on_terminal():  # a redirected stderr would get blank lines only
        yield lambda *_: None
        return
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TimeRemainingColumn

    columns = (
        "[progress.description]{task.description}",
        BarColumn(),
        MofNCompleteColumn(),
        TimeRemainingColumn(),
    )
    with Progress(*columns, console=Console(stderr=True), transient=True) as bar:
        task = bar.add_task(description, total=total)
        yield lambda *_: bar.advance(task)
