"""Extraction: videos (or a trial) in, tracks, signal and fit out.

``pipeline`` runs frames → marker tracks → u(t) → fit (:func:`extract`,
:class:`Extraction`), ``fit_settings`` is the trial's fit (the free decay, the model,
the loss), ``codec_check`` warns of codecs that freeze small motion, ``wrench`` fits the
wrist force-torque signal, and ``plot`` draws an extraction.
"""

from __future__ import annotations

from liquidtouch._core.lazy import lazy_exports

__all__ = [
    "Extraction",
    "FitSettings",
    "extract",
    "extract_signal",
    "extract_trial",
    "plot_extraction",
]

_LAZY = {
    "Extraction": "liquidtouch.extraction.pipeline",
    "FitSettings": "liquidtouch.extraction.fit_settings",
    "extract": "liquidtouch.extraction.pipeline",
    "extract_signal": "liquidtouch.extraction.pipeline",
    "extract_trial": "liquidtouch.extraction.pipeline",
    "plot_extraction": "liquidtouch.extraction.plot",
}


# lazy (PEP 562), so that importing one module of the stage (the command line reads its
# defaults) does not import the rest of it, nor SciPy, OpenCV or PyAV
__getattr__ = lazy_exports(__name__, _LAZY)
