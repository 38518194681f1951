"""Lazy re-exports (PEP 562) for the stage packages' faces.

A stage's ``__init__`` names each public name's defining module and sets
``__getattr__ = lazy_exports(__name__, {...})``: importing one module of the stage (the
command line reads its defaults) then imports neither the rest of it nor SciPy, OpenCV
or PyAV, and ``from liquidtouch.<stage> import name`` still works.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from typing import Any


def lazy_exports(package: str, exports: Mapping[str, str]) -> Callable[[str], Any]:
    """A module ``__getattr__`` for ``package`` that imports ``exports[name]`` on first use.

    ``exports`` maps each public name to the full name of the module defining it.
    """

    def __getattr__(name: str) -> Any:
        module = exports.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        return getattr(importlib.import_module(module), name)

    return __getattr__
