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
    "fit_oscillation": "fit",
    "OscillationFit": "fit",
    "example_signal": "fit",
    "read_signal_csv": "io.signal_csv",
    "write_signal_csv": "io.signal_csv",
    "plot_fit": "fit.plot",
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
    "free_decay": "segment",
    # properties
    "GPRegressor": "models",
    "QuadraticRegressor": "models",
    "PhysicsGPRegressor": "models.physics_prior",
    "LiquidClassifier": "models.classifier",
    "PropertyModel": "models.property_model",
    "train_regression": "models.property_model",
    "train_classifier": "models.property_model",
    "fit_transfer": "models.transfer",
    "save_model": "models.modelfile",
    "load_model": "models.modelfile",
    # datasets and batch work
    "TrialMeta": "io.dataset",
    "read_trial_meta": "io.dataset",
    "read_manifest": "io.dataset",
    "extract_features": "batch.features",
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
