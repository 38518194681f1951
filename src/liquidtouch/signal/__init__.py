"""The tactile signal: marker tracks in, one signal u(t) out.

``lowpass`` is the zero-phase low-pass of the marker motions (across the gaps of the
frames that came), ``tactile`` resamples every sensor onto one clock, keeps the markers
that move most and takes the first principal component: :class:`TactileSignal`
(``t`` [s], ``u`` [px], the explained variance).
"""

from __future__ import annotations

from liquidtouch._core.lazy import lazy_exports

__all__ = [
    "DEFAULT_LOWPASS_HZ",
    "SLOSH_MAX_HZ",
    "TactileSignal",
    "check_signal_options",
    "first_component",
    "lowpass",
    "tactile_signal",
]

_LAZY = {
    "DEFAULT_LOWPASS_HZ": "liquidtouch.signal.lowpass",
    "SLOSH_MAX_HZ": "liquidtouch.signal.lowpass",
    "TactileSignal": "liquidtouch.signal.tactile",
    "check_signal_options": "liquidtouch.signal.tactile",
    "first_component": "liquidtouch.signal.tactile",
    "lowpass": "liquidtouch.signal.lowpass",
    "tactile_signal": "liquidtouch.signal.tactile",
}


# lazy (PEP 562), so that importing one module of the stage (the command line reads its
# defaults) does not import the rest of it, nor SciPy, OpenCV or PyAV
__getattr__ = lazy_exports(__name__, _LAZY)
