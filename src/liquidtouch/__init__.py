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
    # errors
    "LiquidTouchError": "errors",
    "SignalError": "errors",
    "NoOscillationError": "errors",
    # oscillation fit
    "fit_oscillation": "oscillation",
    "OscillationFit": "oscillation",
    "example_signal": "oscillation",
    "read_signal_csv": "signal_io",
    "write_signal_csv": "signal_io",
    "plot_fit": "fitplot",
    # video -> markers -> signal
    "iter_frames": "frames",
    "read_frames": "frames",
    "MarkerTracks": "markers",
    "detect_markers": "markers",
    "track_markers": "markers",
    "TactileSignal": "signal",
    "tactile_signal": "signal",
    "extract": "extract",
    "extract_signal": "extract",
    "Extraction": "extract",
    "free_decay": "segment",
    # properties
    "GPRegressor": "properties",
    "QuadraticRegressor": "properties",
    "PhysicsGPRegressor": "physics_prior",
    "LiquidClassifier": "classify",
    "PropertyModel": "property_model",
    "train_regression": "property_model",
    "train_classifier": "property_model",
    "fit_transfer": "transfer",
    "save_model": "modelfile",
    "load_model": "modelfile",
    # datasets and batch work
    "TrialMeta": "dataset",
    "read_trial_meta": "dataset",
    "read_manifest": "dataset",
    "extract_features": "features",
    # simulator
    "simulate_trial": "sim.trial",
    "write_trial": "sim.trial_io",
    "simulate_dataset": "sim.presets",
    "write_sensor_videos": "sim.gelsight",
    "FingerLoads": "sim.loads",
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
