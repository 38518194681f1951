"""The oscillation fit: a signal u(t) in, :class:`OscillationFit` out.

``model`` is the paper's damped-oscillation model (two damped cosines + quadratic
drift) and its loss, ``amplitude`` the model whose damping grows with the amplitude
(λ(A) = λ0 (1 + κ A^p)), ``choices`` the models and the one default (``"auto"``:
the data choose the model), ``selection`` the information criterion that chooses,
``start`` finds start values, ``solve`` and ``amplitude_solve`` run the optimisers,
``oscillation`` is the public fit,
``result`` its :class:`OscillationFit` (decay rate λ [1/s], angular frequency ω
[rad/s], their std), ``example`` a built-in signal, ``synthetic`` non-linearly
damped test signals with known λ0, and ``plot`` the figure of a fit.
"""

from __future__ import annotations

from liquidtouch._core.lazy import lazy_exports
from liquidtouch.fit.choices import DEFAULT_MODEL

__all__ = ["DEFAULT_MODEL", "OscillationFit", "example_signal", "fit_oscillation"]


#: public name -> the module that defines it
_LAZY = {
    "OscillationFit": "liquidtouch.fit.result",
    "example_signal": "liquidtouch.fit.example",
    "fit_oscillation": "liquidtouch.fit.oscillation",
}


# lazy (PEP 562), so that the command line reads DEFAULT_MODEL without importing SciPy
__getattr__ = lazy_exports(__name__, _LAZY)
