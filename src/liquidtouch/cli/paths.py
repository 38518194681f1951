"""Output-path options of the command line, checked as typed (before typer makes them Paths).

Typer turns ``--out model.json/`` into ``Path("model.json")``, losing the
trailing slash that says "a directory". So before conversion every output
option of every command is checked on its raw value:

- a **file output** (``--out`` of ``train``/``classify``/``predict``/``transfer``/
  ``features``, ``--plot``, ``--signal-out``, ``--tracks-out``) must not be
  empty, end in a slash, or name an existing directory;
- a **directory output** (``simulate trial --out``, ``simulate dataset --out``,
  ``reproduce --out``, ``demo --out``) must not be empty or name an existing
  file.

An empty value of any path option or argument (inputs too) is refused:
``Path("")`` would silently mean the current directory.

Which options are outputs: a ``Path`` option declared ``dir_okay=False`` is a
file output and one declared ``file_okay=False`` a directory output. An
undeclared ``Path`` option named ``--out``/``-o``/``--plot``/``--signal-out``/
``--tracks-out`` is a directory output if its help text says "directory",
else a file output. Arguments (inputs) are never touched.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, get_args, get_origin

try:  # typer >= 0.25 vendors click
    from typer._click import exceptions as click_exc
except ImportError:  # pragma: no cover - older typer uses click itself
    from click import exceptions as click_exc

OUTPUT_OPTION_NAMES = frozenset({"--out", "-o", "--plot", "--signal-out", "--tracks-out"})
"""Option names that are outputs unless declared otherwise."""


def _path_flags(param: Any) -> tuple[bool, bool, bool]:
    """``(is_path, file_okay, dir_okay)`` of a command parameter, for typer and plain click."""
    descriptor = getattr(param, "type_descriptor", None)
    if descriptor is not None:  # typer >= 0.29: a runtime type descriptor
        annotation = descriptor.annotation
        info = descriptor.parameter_info
        if get_origin(annotation) in (list, tuple) and get_args(annotation):
            annotation = get_args(annotation)[0]  # list[Path]: several paths
        is_path = isinstance(annotation, type) and issubclass(annotation, Path)
        return is_path, bool(info.file_okay), bool(info.dir_okay)
    kind = getattr(param, "type", None)
    is_path = type(kind).__name__ == "Path" and hasattr(kind, "dir_okay")
    return is_path, bool(getattr(kind, "file_okay", True)), bool(getattr(kind, "dir_okay", True))


def output_kind(param: Any) -> str | None:
    """``"file"``, ``"dir"`` or ``None`` (not an output path) for a command parameter."""
    if getattr(param, "param_type_name", None) != "option" or getattr(param, "is_flag", False):
        return None
    is_path, file_okay, dir_okay = _path_flags(param)
    if not is_path:
        return None
    if file_okay and not dir_okay:
        return "file"
    if dir_okay and not file_okay:
        return "dir"
    if not set(param.opts) & OUTPUT_OPTION_NAMES:
        return None
    return "dir" if "directory" in (param.help or "").lower() else "file"


def output_path_problem(kind: str, value: object) -> str | None:
    """Why ``value`` (as typed) cannot be a ``kind`` (``"file"``/``"dir"``) output; else None."""
    if value is None or not isinstance(value, (str, os.PathLike)):
        return None
    text = os.fspath(value)
    if isinstance(text, bytes):
        text = os.fsdecode(text)
    if text.strip() == "":
        return "an empty path; give a file name" if kind == "file" else "an empty path"
    path = Path(text)
    if kind == "file":
        if text.endswith(("/", os.sep)):
            return f"{text!r} ends with {text[-1]!r}, so it names a directory; give a file name"
        if path.is_dir():
            return f"{text!r} is a directory; give a file name"
    elif path.exists() and not path.is_dir():
        return f"{text!r} exists and is not a directory; give a directory path"
    return None


def _is_empty(value: object) -> bool:
    if isinstance(value, (list, tuple)):
        return any(_is_empty(item) for item in value)
    return isinstance(value, str) and value.strip() == ""


def _guard(param: Any, kind: str | None) -> None:
    original = param.process_value

    def process_value(ctx: Any, value: Any) -> Any:
        if kind is not None:
            problem = output_path_problem(kind, value)
        else:
            problem = "an empty path" if _is_empty(value) else None
        if problem is not None:
            raise click_exc.BadParameter(problem, ctx=ctx, param=param)
        return original(ctx, value)

    param.process_value = process_value


def guard_output_paths(command: Any) -> Any:
    """Check the raw value of every path parameter of ``command`` and its subcommands.

    Output paths get :func:`output_path_problem`; every other path parameter is
    only refused when empty.
    """
    for param in getattr(command, "params", ()):
        kind = output_kind(param)
        if kind is not None or _path_flags(param)[0]:
            _guard(param, kind)
    for sub in getattr(command, "commands", {}).values():
        guard_output_paths(sub)
    return command
