"""The oscillation fit's choices and its one default model (no heavy imports: the CLI reads it).

``DEFAULT_MODEL`` is the model of :func:`~liquidtouch.fit.oscillation.fit_oscillation`,
of :class:`~liquidtouch.extraction.fit_settings.FitSettings` (``extract``, ``features``, ``live``)
and of the command line's ``--model``: defined here only.
"""

from __future__ import annotations

import math

#: losses of ``fit_oscillation``: the paper's relative loss, or plain least squares
LOSSES = ("paper", "ls")
#: ``"auto"``: every model of :data:`AUTO_CANDIDATES` is fitted and the data choose one
#: by an information criterion (:mod:`liquidtouch.fit.selection`)
AUTO = "auto"
#: the models a fit can be asked for
MODELS = (AUTO, "two-mode", "single-mode", "amplitude", "amplitude-two-mode")
#: the models ``"auto"`` chooses among, simplest first (ties go to the simpler model):
#: one mode; one mode whose damping grows with its amplitude; the paper's two modes; both
#: together (the amplitude-damped mode and a second, exponentially damped mode)
AUTO_CANDIDATES = ("single-mode", "amplitude", "two-mode", "amplitude-two-mode")
#: ``"auto"`` leaves out a fit with two oscillating modes closer together than the one-mode
#: line's half-width λ — one line split in two by the drift of its own frequency — when
#: both modes are about as broad as the line (each decays at least this share of λ:
#: simulated detergent and corn oil 0.69-0.86); a far narrower mode (0.01-0.03 λ: a
#: persistent component beside the slosh in simulated force signals) outlives the ring-down
#: and stays ...
MIN_LINE_WIDTH_SHARE = 0.5
#: ... unless the ring-down loses more than a factor e per cycle (single-mode ω/λ below
#: this): ~3 cycles above the noise are too few to tell any second mode inside the line
#: from the drift (a shear-thinning liquid's damping changes through the ring-down); such
#: pairs moved the reported ω of simulated detergent trials by up to 15 % (ω/λ 3-5 there,
#: 7 or more for every other liquid)
MIN_QUALITY_FOR_TWO_MODES = 2 * math.pi
#: the models fitted unless one is asked for, by the API and the command line alike
DEFAULT_MODEL = AUTO
#: noise assumptions of the standard errors: white noise and the model right; noise that was
#: low-pass filtered (Newey–West); that plus the blocked jackknife of the window, for a model
#: that is not exactly right (:mod:`liquidtouch.fit.jackknife`)
NOISE_MODELS = ("white", "correlated", "jackknife")
#: the standard errors reported unless others are asked for, by the API and the command line
#: alike: the only ones whose coverage of the truth was measured to be right
DEFAULT_NOISE = "jackknife"
