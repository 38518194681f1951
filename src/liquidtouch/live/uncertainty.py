"""The std of a streamed λ and ω: how far they may still be from the stream's final values.

A streaming fit's own standard error (correlated-noise, Newey–West:
:data:`~liquidtouch.live.refresh.REFRESH_NOISE`) only describes the noise of
the window fitted so far. The final fit — whose λ and ω the property models
were trained on — sees a longer record, and the slosh's damping is not
exactly exponential, so a short window's λ differs from the final one by more
than its noise. That difference shrinks with the number of e-foldings the
window has seen, ``n = λ · window_s``, the same for every liquid (a viscous
liquid's 1 s shows as much of its decay as 7 s of water). It is added in
quadrature, as a relative std calibrated on simulated trials of every liquid
in the catalogue (water, oils, mirin, detergent, sugar water; 26 trials of
10 s with the GelSight Mini, the amplitude model streamed and final)::

    std(λ)² = std_fit(λ)² + (λ · b)²,   b² = (B0 e^{−n/N})² + (C0 e^{−window_s/T})² + FLOOR²
    std(ω)² = std_fit(ω)² + ω² ((F0 e^{−window_s/T'})² + FREQ_FLOOR²)

with the RMS of ``log(λ_t / λ_final)`` per bin of ``n``: 0.38 (n < 0.5), 0.28
(0.5-0.75), 0.17 (0.75-1), 0.087 (1-1.5), 0.069 (1.5-2), 0.03 (2-3), 0.014
(beyond 3, about the fit's own std). The first refreshes after the push
(window < 1.5 s) are off by more again, whatever the liquid — the push's end
and the filter's edge weigh on a window of a few periods — hence the terms in
window seconds; for ω they are the main one (how many periods resolve the
frequency): ω was outside ±2σ of the fit's std in more than half of them.
With these terms, streamed λ covered the final λ at ±1σ / ±2σ in 78 % / 94 %
of all refreshes (windows < 1 s: 62 % / 95 %; the fit's std alone: 23-86 %
at ±1σ, worst on short windows); ω in 83 % / 94 % (windows < 1 s: 57 % /
86 %; the fit's std alone: 25-80 % / 46-93 %).
``benchmarks/time_to_answer.py`` measures it on other trials.

Refitted after the final fit became ``auto`` (issue 23; the stream still fits the
amplitude model, and the final fit's choice of model moves λ by a few % and ω by
~0.2 %): on the 46 good test streams of ``time_to_answer.py --seed 11`` (2 more had
a failed final fit), streamed ω was 0.2-0.9 % from the final ω against a claimed
0.06-0.26 % (RMS z 2.0-3.2 per ring-down bin) and λ RMS z 1.3-2.2. The floors
(:data:`DECAY_REL_STD_FLOOR`, :data:`FREQ_REL_STD_FLOOR`) and ω's window term are the
values that brought every bin's RMS z nearest 1 (λ 0.96-1.34, ω 0.89-1.16, grid search).
Held-out seed 23: per liquid ω RMS z 0.2-1.4 and λ ≤ 1.3, except detergent (ω 4-8,
λ 2.8-3.7: its final fit of a < 1 s ring-down differs from the streamed one).

**What a property model gets** (``floor=False``): the fit's std and the window terms, not
the floors. The floors are the scatter of the final fit's λ and ω about the stream's
when both see the whole record (the final fit's choice of model, its longer record).
A property model was trained, and its std calibrated, on final fits: the out-of-fold
errors its conformal scale comes from already hold that scatter, so adding the floors
counted it twice. Measured (``time_to_answer.py --seed 23``, 4 Hz low-pass): from 2 s on,
the height of a streamed fit is as far from the truth as the final fit's (GPR RMS z of
the model's std alone 0.97-1.00 against 0.94 at the final), while streamed ω lay
0.01-0.04 % from the final ω for water and sugar water against the floor's 0.15 %;
with the floors the height's RMS z fell to 0.87-0.90. Held-out seed 31, the same rows with
and without the floors: GPR height from 2 s on 0.81/0.88/0.89 → 0.84/0.91/0.93, ±2σ
98-100 % → 96-99 %. The window terms stay: they are what a short window adds over the
whole record, which the training rows never saw.
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
#: relative std of a streamed ω on a window of 0 s (F0), falling by e every SHORT_FREQ_WINDOW_S
SHORT_FREQ_REL_STD = 0.01
#: [s], see SHORT_FREQ_REL_STD
SHORT_FREQ_WINDOW_S = 1.5


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
    angular_frequency: float, fit_std: float, window_s: float, *, floor: bool = True
) -> float:
    """std of a streamed ω [rad/s] from the fit's std [rad/s] and the window [s] (module
    docstring); ``floor=False``: the std a property model gets (without
    :data:`FREQ_REL_STD_FLOOR`).

    NaN when ω or the window is not finite; a NaN fit std counts as 0.
    """
    omega = float(angular_frequency)
    if not (math.isfinite(omega) and math.isfinite(float(window_s))):
        return math.nan
    fit = float(fit_std) if math.isfinite(float(fit_std)) else 0.0
    short = SHORT_FREQ_REL_STD * math.exp(-max(float(window_s), 0.0) / SHORT_FREQ_WINDOW_S)
    return math.hypot(fit, abs(omega) * math.hypot(short, FREQ_REL_STD_FLOOR if floor else 0.0))
