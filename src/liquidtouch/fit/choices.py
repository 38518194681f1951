"""The oscillation fit's choices and its one default model (no heavy imports: the CLI reads it).

``DEFAULT_MODEL`` is the model of :func:`~liquidtouch.fit.oscillation.fit_oscillation`,
of :class:`~liquidtouch.extraction.fit_settings.FitSettings` (``extract``, ``features``, ``live``)
and of the command line's ``--model``: defined here only.
"""

from __future__ import annotations

#: losses of ``fit_oscillation``: the paper's relative loss, or plain least squares
LOSSES = ("paper", "ls")
#: ``"auto"``: every model of :data:`AUTO_CANDIDATES` is fitted and the data choose one
#: by an information criterion (:mod:`liquidtouch.fit.selection`)
AUTO = "auto"
#: the models a fit can be asked for
MODELS = (AUTO, "two-mode", "single-mode", "amplitude", "drifting-line", "amplitude-two-mode")
#: the models ``"auto"`` weighs, simplest first (ties go to the simpler model): one mode; one
#: mode whose damping grows with its amplitude; one mode whose damping and frequency both move
#: with its amplitude (:mod:`liquidtouch.fit.drifting_line`); the paper's two modes; the
#: amplitude-damped mode and a second, exponentially damped mode together
AUTO_CANDIDATES = ("single-mode", "amplitude", "drifting-line", "two-mode", "amplitude-two-mode")
#: the models fitted unless one is asked for, by the API and the command line alike
DEFAULT_MODEL = AUTO
#: noise assumptions of the standard errors: white noise and the model right; noise that was
#: low-pass filtered (Newey–West); that plus the blocked jackknife of the window, for a model
#: that is not exactly right (:mod:`liquidtouch.fit.jackknife`)
NOISE_MODELS = ("white", "correlated", "jackknife")
#: the standard errors reported unless others are asked for, by the API and the command line
#: alike: the only ones whose coverage of the truth was measured to be right
DEFAULT_NOISE = "jackknife"
