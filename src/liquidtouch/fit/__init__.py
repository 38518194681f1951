"""The oscillation fit: a signal u(t) in, :class:`OscillationFit` out.

``model`` is the paper's damped-oscillation model (two damped cosines + quadratic
drift) and its loss, ``amplitude`` the model whose damping grows with the amplitude
(λ(A) = λ0 (1 + κ A²), the pipeline's default), ``start`` finds start values,
``solve`` runs the optimisers, ``oscillation`` is the public fit and model selection,
``result`` its :class:`OscillationFit` (decay rate λ [1/s], angular frequency ω
[rad/s], their std), ``example`` a built-in signal, ``synthetic`` non-linearly
damped test signals with known λ0, and ``plot`` the figure of a fit.
"""

from liquidtouch.fit.example import example_signal
from liquidtouch.fit.oscillation import fit_oscillation
from liquidtouch.fit.result import OscillationFit

__all__ = ["OscillationFit", "example_signal", "fit_oscillation"]
