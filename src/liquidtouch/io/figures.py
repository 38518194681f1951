"""Saving figures: atomically, in the format the file name asks for, with no backend switch.

Figures are bare :class:`matplotlib.figure.Figure` objects (no pyplot), so
saving needs no display and leaves a notebook's inline backend alone.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

from liquidtouch._core import atomic
from liquidtouch.errors import OutputError

if TYPE_CHECKING:
    from matplotlib.figure import Figure

DEFAULT_FORMAT = "png"  # for a path without a suffix


def save_figure(
    fig: Figure, path: str | os.PathLike[str], *, dpi: float = 110, tight: bool = False
) -> Path:
    """Save ``fig`` atomically; the format is the path's suffix (``.png``, ``.pdf``, ``.svg``...).

    A sub-figure saves its whole (root) figure; ``tight`` trims the margins.
    An unknown suffix raises :class:`OutputError` before anything is written.
    """
    path = Path(path)
    fig = fig.figure  # the root figure (itself for a Figure)
    fmt = path.suffix[1:].lower() or DEFAULT_FORMAT
    supported = fig.canvas.get_supported_filetypes()
    if fmt not in supported:
        raise OutputError(
            f"cannot write {path}: unknown figure format '.{fmt}'; use one of "
            + ", ".join(f".{name}" for name in sorted(supported))
        )
    with atomic.atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=dpi, format=fmt, bbox_inches="tight" if tight else None)
    return path


def check_figure_path(path: str | os.PathLike[str]) -> None:
    """Raise :class:`OutputError` now if ``path``'s suffix names no figure format.

    Commands call this before long work, so a typo in ``--plot`` costs nothing.
    """
    from matplotlib.backend_bases import FigureCanvasBase

    fmt = Path(path).suffix[1:].lower() or DEFAULT_FORMAT
    supported = FigureCanvasBase.get_supported_filetypes()
    if fmt not in supported:
        raise OutputError(
            f"cannot write {path}: unknown figure format '.{fmt}'; use one of "
            + ", ".join(f".{name}" for name in sorted(supported))
        )
    if Path(path).is_dir():
        raise OutputError(f"cannot write {path}: it is a directory; give a file name")
