"""liquidtouch: liquid properties in a closed bottle from GelSight sloshing signals.

The public API is re-exported here lazily, so ``import liquidtouch`` stays
fast and each stage can be used on its own from a notebook.
"""

from __future__ import annotations

import importlib
from typing import Any

__version__ = "0.1.0"

# public name -> the stage that exports and documents it: a stage package whose
# ``__init__`` lists the name in its ``__all__`` (``fit``, ``tracking``, ``io``,
# ``models``, ``batch``, ``sim``), or a plain module (``signal``, ``extraction``,
# ``io.frames``, ...)
_EXPORTS: dict[str, str] = {
    # errors
    "LiquidTouchError": "errors",
    "SignalError": "errors",
    "NoOscillationError": "errors",
    # oscillation fit
    "fit_oscillation": "fit",
    "OscillationFit": "fit",
    "example_signal": "fit",
    "plot_fit": "fit.plot",
    "read_signal_csv": "io",
    "write_signal_csv": "io",
    # video -> markers -> signal
    "iter_frames": "io.frames",
    "read_frames": "io.frames",
    "MarkerTracks": "tracking",
    "detect_markers": "tracking",
    "track_markers": "tracking",
    "TactileSignal": "signal",
    "tactile_signal": "signal",
    "extract": "extraction",
    "extract_signal": "extraction",
    "Extraction": "extraction",
    "free_decay": "ring_down",
    "plot_extraction": "extraction",
    # properties
    "GPRegressor": "models",
    "QuadraticRegressor": "models",
    "PhysicsGPRegressor": "models",
    "LiquidClassifier": "models",
    "PropertyModel": "models",
    "train_regression": "models",
    "train_classifier": "models",
    "fit_transfer": "models",
    "save_model": "models",
    "load_model": "models",
    "combine_ring_downs": "models",
    # datasets and batch work
    "TrialMeta": "io",
    "read_trial_meta": "io",
    "read_manifest": "io",
    "extract_features": "batch",
    # simulator
    "simulate_trial": "sim",
    "write_trial": "sim",
    "simulate_dataset": "sim",
    "write_sensor_videos": "sim",
    "FingerLoads": "sim",
    # experiments
    "reproduce": "experiments.reproduce",
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
