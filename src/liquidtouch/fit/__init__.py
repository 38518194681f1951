"""The oscillation fit: a signal u(t) in, :class:`OscillationFit` out.

``model`` is the damped-oscillation model (two damped cosines + quadratic drift)
and its loss, ``start`` finds start values, ``solve`` runs the optimisers,
``oscillation`` is the public fit (decay rate λ [1/s], angular frequency ω
[rad/s], their std), ``example`` a built-in signal and ``plot`` its figure.
"""

from liquidtouch.fit.oscillation import OscillationFit, example_signal, fit_oscillation

__all__ = ["OscillationFit", "example_signal", "fit_oscillation"]
