"""What of a refresh the live estimate reports: the emission rule.

From the uncertainty, no time floor: ω is reported once its
std is below :data:`MAX_FREQ_REL_STD` of ω; λ once its std is below
:data:`MAX_DECAY_REL_STD` of λ. While streaming, the std is how far the value
may still be from the stream's final one (:mod:`liquidtouch.live.uncertainty`):
the streaming fit's own (jackknife) std of the window so far, for λ plus calibrated
terms for the window's length, in e-foldings of the decay and in seconds — the damping
of a real slosh is not exactly exponential, so the fit's std alone claims a precision a
short window does not have (simulated water: the first λ emitted was 38 % off the
final one while its std claimed 6 %). The final update keeps the final fit's
std. Properties do not wait for these gates: a regression model's targets are
predicted from every fit, the λ and ω std propagated and added to the model's
calibrated std (:mod:`liquidtouch.live.properties`), and a target with an
``until_std`` threshold is reported once its std meets it — or at once, when the threshold
lies below the model's own calibrated std at the estimated (λ, ω), which the fit's std only
adds to (it can never be met: ``until_std_unreachable`` and ``message`` say so) (so a height that
depends on ω answers before λ's std is below 10 %); a regression model gets the streamed
std without its floors (:mod:`liquidtouch.live.uncertainty`: its calibrated std holds
them). A classifier's probabilities wait until λ and ω are both reported.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping

import numpy as np

from liquidtouch.live.properties import classify_with_fit_std, out_of_domain, predict_with_fit_std
from liquidtouch.live.refresh import Refreshed
from liquidtouch.live.stopping import unreachable_here
from liquidtouch.live.uncertainty import (
    property_feature_std,
    streamed_decay_rate_std,
    streamed_frequency_std,
)
from liquidtouch.live.updates import LiveUpdate
from liquidtouch.models.predictions import unknown_rule

__all__ = ["MAX_DECAY_REL_STD", "MAX_FREQ_REL_STD", "emitted_update"]

#: ω is reported once its std is below this fraction of ω
MAX_FREQ_REL_STD = 0.01
#: λ is reported once its std (fit and window length) is below this fraction of λ
MAX_DECAY_REL_STD = 0.10


def emitted_update(
    result: Refreshed,
    frames: int,
    elapsed_s: float,
    due_s: float,
    *,
    final: bool,
    model: object | None = None,
    model_kind: str | None = None,
    until_std: Mapping[str, float] | None = None,
) -> LiveUpdate:
    """The :class:`LiveUpdate` of one refresh, with the emission rule applied (module
    docstring); ``model`` (``model_kind`` regression or classifier) adds properties."""
    decay_clock = result.t - (result.decay_start_s if result.phase != "waiting" else np.nan)
    update = LiveUpdate(
        t_s=result.now_s - result.decay_start_s,
        phase=result.phase,
        elapsed_s=elapsed_s,
        frames=frames,
        final=final,
        message=result.message,
        signal_t_s=decay_clock,
        signal_u=result.u,
        signal_fit=result.fit_curve(),
    )
    fit = result.fit
    if fit is not None:
        update.window_s, update.model = fit.duration_s, fit.model
        lam, omega = fit.decay_rate, fit.angular_frequency
        if final:
            lam_std, omega_std = fit.decay_rate_std, fit.angular_frequency_std
        else:
            lam_std = streamed_decay_rate_std(lam, fit.decay_rate_std, fit.duration_s)
            omega_std = streamed_frequency_std(omega, fit.angular_frequency_std)
        show_omega = final or omega_std < MAX_FREQ_REL_STD * abs(omega)
        show_lam = final or lam_std < MAX_DECAY_REL_STD * abs(lam)
        if show_omega:
            update.angular_frequency, update.angular_frequency_std = omega, omega_std
        if show_lam:
            update.decay_rate, update.decay_rate_std = lam, lam_std
        features = (lam, lam_std, omega, omega_std)
        if model_kind == "regression":
            if not final:  # the floors are in the model's calibrated std already
                lam_model_std, omega_model_std = property_feature_std(
                    lam, fit.decay_rate_std, omega, fit.angular_frequency_std, fit.duration_s
                )
                features = (lam, lam_model_std, omega, omega_model_std)
            # no λ/ω gate: a property is as good as its own propagated std says (a
            # height that hangs on ω answers before λ is known to 10 %); a target
            # with an until_std threshold is reported once its std meets it
            predicted = predict_with_fit_std(model, *features)
            gates = dict(until_std or {})
            # a threshold below the model's own std here can never be met, however long the
            # stream: such a target is shown as it comes, and the update says why
            update.until_std_unreachable = unreachable_here(model, lam, omega, gates)
            update.predicted = {
                t: (mean, std)
                for t, (mean, std) in predicted.items()
                if final or t in update.until_std_unreachable or std <= gates.get(t, math.inf)
            }
        elif model is not None and show_omega and show_lam:
            update.classified = classify_with_fit_std(model, *features)
            update.unknown_rule = unknown_rule(model)
        if update.predicted or update.classified:  # an answer: is it one the model knows?
            update.out_of_domain = out_of_domain(model, lam, omega, update.classified)
    if math.isfinite(due_s):
        update.lag_s = time.monotonic() - due_s
    return update
