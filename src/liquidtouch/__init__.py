"""liquidtouch: liquid properties in a closed bottle from GelSight sloshing signals.

The public API is re-exported here lazily, so ``import liquidtouch`` stays
fast and each stage can be used on its own from a notebook.
"""

from __future__ import annotations

import importlib
from typing import Any

__version__ = "0.1.0"

# public name -> module that defines it
_EXPORTS: dict[str, str] = {
    "LiquidTouchError": "errors",
    "SignalError": "errors",
    "NoOscillationError": "errors",
    "fit_oscillation": "oscillation",
    "OscillationFit": "oscillation",
}

__all__ = ["__version__", *_EXPORTS]


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'liquidtouch' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"liquidtouch.{module}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(__all__)
