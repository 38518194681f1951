"""The std of a streamed λ and ω: how far they may still be from the stream's final values.

**ω: the streaming fit's own std.** Each streaming fit reports the blocked jackknife
of its window (:data:`~liquidtouch.live.refresh.REFRESH_NOISE`, the final fit's std
model: the larger of it and the correlated-noise std; :mod:`liquidtouch.fit.jackknife`),
and that is ω's std. It follows each liquid's own scatter, which one curve of the
window's length (the earlier ``F0 e^{−window_s/T'}`` term, 1 % falling by e every
1.5 s) could not: 1-2 s into the ring-down it claimed 0.41-0.65 % of ω for every liquid
while streamed ω lay 0.07 % (RMS) from the final ω for water, 0.13-0.36 % for the
oils, mirin and sugar water and 4.8 % for detergent (``time_to_answer.py``, held-out
seeds 41 and 43, 10 streams per liquid; the jackknife: median 0.05 % water,
0.12-0.26 % others, 2.2 % detergent). Per liquid, the RMS z of streamed ω at 1-2 s
about the final ω went from 0.15-0.73 (over-cautious) and 8.2 (detergent) to 0.52-1.96
and 4.4; about the simulator's true ω from 0.16-0.88 and 2.46 to 1.13-2.14 and 1.25 (the
fits' ω of the oils lies ~0.3 % from the simulator's, an offset the models are trained
on; ``benchmarks/RESULTS.md``, calibration). No window term is kept: what it still
under-covers (water's 0.07 % against 0.05 %) moves a property by far less than the
property's own std.

**λ: the fit's std and the window's terms.** A short window's λ differs from the final
one by more than the fit's std: the slosh's damping is not exactly exponential. That
difference shrinks with the number of e-foldings the window has seen, ``n = λ · window_s``,
the same for every liquid (a viscous liquid's 1 s shows as much of its decay as 7 s of
water). It is added in quadrature, as a relative std calibrated on simulated trials of
every liquid in the catalogue (26 trials of 10 s with the GelSight Mini, the amplitude
model streamed and final)::

    std(λ)² = std_fit(λ)² + (λ · b)²,   b² = (B0 e^{−n/N})² + (C0 e^{−window_s/T})² + FLOOR²
    std(ω)² = std_fit(ω)² + (ω · FREQ_FLOOR)²

with the RMS of ``log(λ_t / λ_final)`` per bin of ``n``: 0.38 (n < 0.5), 0.28
(0.5-0.75), 0.17 (0.75-1), 0.087 (1-1.5), 0.069 (1.5-2), 0.03 (2-3), 0.014
(beyond 3, about the fit's own std). The first refreshes after the push
(window < 1.5 s) are off by more again, whatever the liquid — the push's end
and the filter's edge weigh on a window of a few periods — hence the term in
window seconds.

**The floors** (:data:`DECAY_REL_STD_FLOOR`, :data:`FREQ_REL_STD_FLOOR`) are the scatter
of the final fit's λ and ω about the stream's when both see the whole record (the final
fit is ``auto``, the stream the amplitude model; fitted on ``time_to_answer.py --seed 11``,
grid search for every bin's RMS z nearest 1). They are in the λ and ω the stream shows.

**What a property model gets** (``floor=False``, :func:`property_feature_std`): the fit's
std and λ's window terms, not the floors. A property model was trained, and its std
calibrated, on final fits: the out-of-fold errors its conformal scale comes from already
hold that scatter, so adding the floors counted it twice (held-out seed 31: GPR height
RMS z from 2 s on 0.81-0.89 with them, 0.84-0.93 without).
"""

from __future__ import annotations

import math

#: relative std of a streamed λ at the start of the decay (n = 0 e-foldings)
SHORT_WINDOW_REL_STD = 0.5
#: e-foldings over which that std falls by e
SHORT_WINDOW_EFOLDINGS = 0.8
#: relative std of a streamed λ on a window of 0 s (C0), falling by e every SHORT_DECAY_WINDOW_S
SHORT_DECAY_REL_STD = 1.0
#: [s], see SHORT_DECAY_REL_STD
SHORT_DECAY_WINDOW_S = 0.3
#: relative std of a streamed λ however long the window (the final fit's record and its
#: choice of model differ from the stream's)
DECAY_REL_STD_FLOOR = 0.025
#: relative std of a streamed ω however long the window (the final fit's choice of model)
FREQ_REL_STD_FLOOR = 0.0015


def window_rel_std(decay_rate: float, window_s: float, *, floor: bool = True) -> float:
    """b: the relative std of λ from the window alone (``n = λ · window_s`` e-foldings);
    ``floor=False`` leaves out :data:`DECAY_REL_STD_FLOOR` (module docstring)."""
    window_s = max(float(window_s), 0.0)
    efoldings = max(float(decay_rate) * window_s, 0.0)
    few = SHORT_WINDOW_REL_STD * math.exp(-efoldings / SHORT_WINDOW_EFOLDINGS)
    short = SHORT_DECAY_REL_STD * math.exp(-window_s / SHORT_DECAY_WINDOW_S)
    return math.hypot(few, short, DECAY_REL_STD_FLOOR if floor else 0.0)


def streamed_decay_rate_std(
    decay_rate: float, fit_std: float, window_s: float, *, floor: bool = True
) -> float:
    """std of a streamed λ [1/s] from the fit's std [1/s] and the window [s] (module docstring);
    ``floor=False``: the std a property model gets (without :data:`DECAY_REL_STD_FLOOR`).

    NaN when λ or the window is not finite; a NaN fit std counts as 0.
    """
    lam = float(decay_rate)
    if not (math.isfinite(lam) and math.isfinite(float(window_s))):
        return math.nan
    fit = float(fit_std) if math.isfinite(float(fit_std)) else 0.0
    return math.hypot(fit, abs(lam) * window_rel_std(lam, window_s, floor=floor))


def streamed_frequency_std(
    angular_frequency: float, fit_std: float, *, floor: bool = True
) -> float:
    """std of a streamed ω [rad/s] from the streaming fit's own (jackknife) std [rad/s]
    (module docstring); ``floor=False``: the std a property model gets (without
    :data:`FREQ_REL_STD_FLOOR`).

    NaN when ω is not finite; a NaN fit std counts as 0.
    """
    omega = float(angular_frequency)
    if not math.isfinite(omega):
        return math.nan
    fit = float(fit_std) if math.isfinite(float(fit_std)) else 0.0
    return math.hypot(fit, abs(omega) * FREQ_REL_STD_FLOOR if floor else 0.0)


def property_feature_std(
    decay_rate: float,
    decay_rate_fit_std: float,
    angular_frequency: float,
    angular_frequency_fit_std: float,
    window_s: float,
) -> tuple[float, float]:
    """(std λ [1/s], std ω [rad/s]) of a streamed fit as a property model gets them: the
    fit's own std and λ's window terms, without the floors (module docstring)."""
    return (
        streamed_decay_rate_std(decay_rate, decay_rate_fit_std, window_s, floor=False),
        streamed_frequency_std(angular_frequency, angular_frequency_fit_std, floor=False),
    )
