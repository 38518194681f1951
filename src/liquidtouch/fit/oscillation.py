"""Fit the damped two-mode oscillation of a tactile signal (the oscillation-fit stage).

Model (Huang, Guo, Yuan, RSS 2022)::

    u(t) ≈ B e^{-λτ} cos(ωτ+ψ) + B' e^{-λ'τ} cos(ω'τ+ψ') + c2 τ² + c1 τ + c0,   τ = t - t0

with ``t0`` the first time stamp, ``λ' = λ + Δ`` and ``Δ > 0`` (so the slow mode,
the reported feature, is the less damped one by construction) and ``ω, ω' > 0``
inside the frequency band.

Losses
------
``loss="paper"`` (default) minimises ``Σ (u − û)² / (u² + δ)``, the paper's loss,
which weighs the late, small-amplitude part of the decay. Here ``u`` in the
weight is the signal minus its quadratic drift (so the weight does not depend
on an arbitrary offset of ``u``) and ``δ = delta_rel · mean(u²)`` with
``delta_rel = 1`` by default: relative to the signal's power, so it does not
depend on units. Because the weights come from the noisy data, the paper's
loss is biased towards faster decay when the late signal is near the noise
(Monte-Carlo, λ=0.4/s, noise 5 % of the amplitude: +18 % at ``delta_rel=0.05``,
+4 % at 0.5, +2 % at 1); ``delta_rel = 1`` keeps the late-decay emphasis while
keeping that bias small. ``loss="ls"`` is plain least squares: the maximum-likelihood fit
under white Gaussian noise, and the statistically efficient choice for signals
that follow the model.

Uncertainty
-----------
Standard errors come from the Jacobian ``J`` at the optimum and the residual
variance ``σ² = Σ (u − û)² / (n − p)``, assuming the residuals are independent
with a common variance (white noise, model correct). For the paper's weighted
loss the weights ``W`` are fixed numbers, so the sandwich
``(JᵀWJ)⁻¹ (σ² JᵀW²J) (JᵀWJ)⁻¹`` is used — the covariance of the weighted
estimator under the same white-noise assumption (it reduces to ``σ² (JᵀJ)⁻¹``
for least squares) (``noise="white"``). With ``noise="correlated"`` the middle term is a
Newey–West (Bartlett-kernel) estimate from the residuals, for signals whose
noise was low-pass filtered; white-noise errors are then too small. Both assume the
model is right; ``noise="jackknife"`` (the default, :data:`~liquidtouch.fit.choices.DEFAULT_NOISE`)
reports for λ and ω the larger of that and the blocked jackknife of the window
(:mod:`liquidtouch.fit.jackknife`: how much they move when a fifth of the window is
left out), the one of the three whose coverage of the truth was measured right
(``benchmarks/fit_std.py``).

Model selection
---------------
``model="auto"`` (the default, :data:`~liquidtouch.fit.choices.DEFAULT_MODEL`)
fits the single-mode model, the paper's two-mode model and the amplitude-dependent
damping (:mod:`liquidtouch.fit.amplitude`: one mode whose decay rate grows with
its amplitude; it reports the small-amplitude λ0, which does not depend on how hard
the container was pushed) and keeps the one with the lowest information criterion
under the correlated noise the fit estimates (:mod:`liquidtouch.fit.selection`).
``model`` of the result says which was fitted, ``model_reason`` why, and
``delta_bic_*`` the criterion of each candidate over the chosen one. Asking for
``"two-mode"`` chooses between one and two modes the same way (fast-mode fields NaN
when one mode is kept: ``model == "single-mode"``); ``"amplitude"`` keeps a gain
of 0 (λ0 the single-mode λ) unless the gain lowers the criterion; ``"single-mode"``
fits one mode only. Two oscillating modes closer together than the one-mode fit's λ
(the half-width of its spectral line), each about as broad as the line, cannot be told
apart from one mode whose frequency drifts through the ring-down (a shear-thinning
liquid's damping changes as it decays; a non-linear slosh's frequency moves with its
amplitude): ``"auto"`` leaves out a fit with two such modes. Fitted anyway, the pair
trades its parameters: the reported mode moved ω by up to 15 % on simulated detergent
and came out as λ 2.1 ± 9.4 1/s, ω 14 ± 13 rad/s on a corn-oil trial (the one-mode fit:
λ +3 %, ω +0.6 % of the simulator's). A far narrower mode inside the line is kept: it
outlives the ring-down, so the record tells it apart (a persistent 12.4 rad/s component
beside a 13.0 rad/s slosh at λ 1.1 1/s in simulated force signals; left out, the one
mode left took λ 40-54 % low) — unless the ring-down loses more than a factor e per
cycle (single-mode ω/λ < 2π): ~3 cycles above the noise are too few to tell any second
mode inside the line from the drift.

Gaps
----
The samples need not be uniform: a signal with gaps (samples never observed, e.g.
a camera stall) is fitted on the samples it has, and ``gap_share`` reports the
share of the fitted time span that lies in gaps (steps over :data:`GAP_STEPS` ×
the median step).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from liquidtouch._core.checks import check_times
from liquidtouch.errors import NoOscillationError, SignalError
from liquidtouch.fit.amplitude import TWO_MODE_EXPONENT, AmplitudeState
from liquidtouch.fit.amplitude_solve import (
    optimise_amplitude,
    optimise_amplitude_ends,
    optimise_amplitude_two_mode,
    without_gain,
)
from liquidtouch.fit.choices import (
    AUTO,
    AUTO_CANDIDATES,
    DEFAULT_MODEL,
    DEFAULT_NOISE,
    LOSSES,
    MIN_LINE_WIDTH_SHARE,
    MIN_QUALITY_FOR_TWO_MODES,
    MODELS,
    NOISE_MODELS,
)
from liquidtouch.fit.jackknife import jackknife_std
from liquidtouch.fit.result import OscillationFit
from liquidtouch.fit.selection import Selection, select_model
from liquidtouch.fit.solve import FitState, optimise_single_mode, optimise_two_mode

__all__ = ["fit_oscillation", "validate_signal"]

DEFAULT_DELTA_REL = 1.0
MIN_SAMPLES = 20
#: most samples a fit takes: time and memory grow linearly (200 000 samples: 23 s CPU,
#: 270 MB peak; 1 000 000: 160 s, 850 MB). A 3 Hz slosh needs ~30 samples/s: resample
MAX_SAMPLES = 200_000
MIN_DURATION_S = 2.0
#: u varying by less than this fraction of its magnitude is flat (float precision)
FLAT_RELATIVE = 1e-12
#: energy of the fitted oscillation over the local noise level below which it is noise
#: (pure white or low-passed noise reaches ~18 at most)
MIN_OSCILLATION_SNR = 30.0
#: a step between samples longer than this many median steps is a gap (samples missing)
GAP_STEPS = 1.5
#: the amplitude-damped mode and a second mode together
COMBINED = "amplitude-two-mode"


def validate_signal(
    t: np.ndarray, u: np.ndarray, min_duration_s: float = MIN_DURATION_S
) -> tuple[np.ndarray, np.ndarray]:
    """``(t, u)`` as float arrays if they are a usable signal [s]; SignalError otherwise."""
    try:
        t = np.asarray(t, dtype=float)
        u = np.asarray(u, dtype=float)
    except (TypeError, ValueError):
        raise SignalError("t and u must be arrays of real numbers (time [s], signal)") from None
    if t.ndim != 1 or u.ndim != 1 or t.shape != u.shape:
        raise SignalError(
            f"t and u must be 1-D arrays of equal length (got shapes {t.shape} and {u.shape})"
        )
    if t.size < MIN_SAMPLES:
        raise SignalError(
            f"signal too short: {t.size} samples, need at least {MIN_SAMPLES}; record longer"
        )
    if t.size > MAX_SAMPLES:
        raise SignalError(
            f"signal too long: {t.size} samples, the fit takes at most {MAX_SAMPLES}; "
            "resample it (a 3 Hz low-passed slosh needs ~30 samples per second) or cut it "
            "to the free decay"
        )
    bad = ~np.isfinite(u)
    if bad.any():
        raise SignalError(
            f"u holds {int(bad.sum())} NaN/inf value(s) (first at sample "
            f"{int(np.argmax(bad))}); drop or interpolate them before fitting"
        )
    check_times(t, "the time stamps t", SignalError)
    duration = t[-1] - t[0]
    if duration < min_duration_s:
        raise SignalError(
            f"signal too short: {duration:.3g} s, need at least {min_duration_s:g} s of sloshing"
        )
    # relative: u may be in any unit, so u × 1e-15 is as good a signal as u
    if not np.ptp(u) > FLAT_RELATIVE * float(np.max(np.abs(u))):
        raise SignalError("signal is flat (constant u); nothing moved — check the sensor signal")
    return t, u


def _band(band_hz: tuple[float, float], t: np.ndarray) -> tuple[float, float]:
    try:
        lo, hi = (float(v) for v in band_hz)
    except (TypeError, ValueError):
        raise SignalError(f"band_hz must be a pair (low, high) in Hz (got {band_hz!r})") from None
    if not (0 < lo < hi):
        raise SignalError(f"band_hz must satisfy 0 < low < high (got {band_hz})")
    nyquist_hz = 0.5 / float(np.median(np.diff(t)))
    if lo >= 0.9 * nyquist_hz:
        raise SignalError(
            f"band low edge {lo:g} Hz is at or above the Nyquist frequency {nyquist_hz:.3g} Hz "
            "of the samples; sample faster or lower the band"
        )
    return 2 * math.pi * lo, 2 * math.pi * min(hi, 0.9 * nyquist_hz)


def _check_is_oscillation(state: FitState, band: tuple[float, float]) -> None:
    snr = float(state.mode_snr()[0])
    if snr < MIN_OSCILLATION_SNR:
        raise NoOscillationError(
            f"no oscillation above the noise (noise only: the best damped cosine's energy is "
            f"{snr:.3g}× the local noise level, need {MIN_OSCILLATION_SNR:g}); check that the "
            "container was pushed and that the signal is the slosh"
        )
    lam, omega = state.rates[0], state.freqs[0]
    at_edge = min(abs(omega - band[0]) / band[0], abs(omega - band[1]) / band[1]) < 0.01
    if omega < 2 * lam or at_edge:
        raise NoOscillationError(
            f"no oscillation: the signal looks overdamped (best fit λ = {lam:.3g}/s, "
            f"ω = {omega:.3g} rad/s, fewer than one visible cycle or no peak inside the band "
            f"{band[0] / (2 * math.pi):.3g}–{band[1] / (2 * math.pi):.3g} Hz)"
        )


def fit_oscillation(
    t: np.ndarray,
    u: np.ndarray,
    *,
    loss: str = "paper",
    model: str = DEFAULT_MODEL,
    band_hz: tuple[float, float] = (0.3, 5.0),
    delta_rel: float = DEFAULT_DELTA_REL,
    noise: str = DEFAULT_NOISE,
    check_oscillation: bool = True,
    min_duration_s: float = MIN_DURATION_S,
    warm_start: tuple[float, float] | None = None,
) -> OscillationFit:
    """Fit the damped-oscillation model to a tactile signal ``u`` at times ``t`` [s].

    Parameters
    ----------
    t, u : 1-D arrays
        Time stamps [s] (strictly increasing, need not be uniform) and signal (any unit).
    loss : ``"paper"`` | ``"ls"``
        The paper's relative loss ``Σ (u − û)² / (u² + δ)`` or plain least squares.
    model : ``"auto"`` | ``"two-mode"`` | ``"single-mode"`` | ``"amplitude"``
        Model to fit (default :data:`~liquidtouch.fit.choices.DEFAULT_MODEL`,
        ``"auto"``: the one of the three the data support best, by an information
        criterion; see the module docstring). ``"two-mode"`` falls back to one mode
        when the data do not support a fast mode. ``"amplitude"``: one mode whose
        decay rate grows with its amplitude, ``λ(A) = λ0 (1 + κ A^p)``
        (:mod:`liquidtouch.fit.amplitude`); ``decay_rate`` is then λ0 and
        ``damping_gain`` κ.
    band_hz : (low, high)
        Frequency band [Hz] for both modes (high is clipped below Nyquist).
    delta_rel : float
        ``δ`` of the paper's loss relative to the detrended signal's mean power.
    noise : ``"jackknife"`` | ``"correlated"`` | ``"white"``
        Noise assumption for the standard errors (default
        :data:`~liquidtouch.fit.choices.DEFAULT_NOISE`; module docstring, Uncertainty).
    check_oscillation : bool
        Refuse a signal with no oscillation above the noise, or an overdamped one
        (``NoOscillationError``). ``False`` gives the best-effort fit anyway (the
        paper's wrist F/T baseline): its numbers then describe noise, not a slosh.
    min_duration_s : float
        Shortest signal accepted [s] (default :data:`MIN_DURATION_S`). The streaming
        estimator (:mod:`liquidtouch.live`) lowers it and judges a short window by the
        fit's standard errors instead.
    warm_start : (λ [1/s], ω [rad/s]) or None
        A previous fit of (most of) the same signal, e.g. the last streaming refresh:
        the single-mode optimiser starts there and at the spectral peak instead of its
        full start search (the λ profile), which is most of a fit's time.

    Raises
    ------
    SignalError
        ``t``/``u`` not 1-D of one length, too short (< 2 s or < 20 samples),
        too long (> :data:`MAX_SAMPLES`), NaN/inf, flat (``u`` varying by less
        than 1e-12 of its magnitude, whatever its unit) or non-increasing time;
        an unknown ``loss``/``model``/``noise``,
        a band not ``0 < low < high`` below Nyquist, or ``delta_rel`` not finite > 0.
    NoOscillationError
        No oscillation: noise only, or overdamped (the message says which).
    """
    if loss not in LOSSES:
        raise SignalError(f"unknown loss {loss!r}; use one of {', '.join(LOSSES)}")
    if model not in MODELS:
        raise SignalError(f"unknown model {model!r}; use one of {', '.join(MODELS)}")
    if noise not in NOISE_MODELS:
        raise SignalError(f"unknown noise model {noise!r}; use one of {', '.join(NOISE_MODELS)}")
    if not 0 < delta_rel < math.inf:
        raise SignalError(f"delta_rel must be a finite number > 0 (got {delta_rel}); 1 is usual")
    t, u = validate_signal(t, u, min_duration_s)
    band = _band(band_hz, t)
    tau = t - t[0]
    x = tau / tau[-1]
    mean, scale = float(u.mean()), float(u.std())
    if not 0 < scale < math.inf:  # under- or overflow of u² (|u| ~ 1e-160 or 1e+160)
        peak = float(np.max(np.abs(u)))
        mean, scale = float((u / peak).mean()) * peak, float((u / peak).std()) * peak
    u_n = (u - mean) / scale

    drift_design = np.vander(x, 3)
    drift_coef, *_ = np.linalg.lstsq(drift_design, u_n, rcond=None)
    u_detrended = u_n - drift_design @ drift_coef
    power = float(np.mean(u_detrended**2))
    if power < 1e-20:
        raise NoOscillationError("no oscillation: the signal is only a slow drift (noise-free)")
    delta_n = delta_rel * power if loss == "paper" else math.nan
    weights = 1.0 / (u_detrended**2 + delta_n) if loss == "paper" else np.ones_like(u_n)
    weights /= weights.mean()
    sqrt_w = np.sqrt(weights)
    single = optimise_single_mode(tau, x, u_n, u_detrended, sqrt_w, band, warm_start)
    if check_oscillation:
        _check_is_oscillation(single, band)
    candidates: dict[str, FitState] = {"single-mode": single}
    wanted = AUTO_CANDIDATES if model == AUTO else (model,)
    amp = two = None
    if "amplitude" in wanted or COMBINED in wanted:
        ends = optimise_amplitude_ends(tau, x, u_n, sqrt_w, band, single)
        amp = optimise_amplitude(ends, band)
        if "amplitude" in wanted:
            candidates["amplitude"] = amp
    if "two-mode" in wanted or COMBINED in wanted:
        two = optimise_two_mode(tau, x, u_n, sqrt_w, band, single)
        if two is not None and "two-mode" in wanted:
            candidates["two-mode"] = two
    if COMBINED in wanted:
        at_two = next(e for e in ends if e.exponent == TWO_MODE_EXPONENT)
        both = optimise_amplitude_two_mode(tau, x, u_n, sqrt_w, band, at_two, two)
        candidates[COMBINED] = both
    candidates, why = _identifiable(candidates, model)
    selection = select_model(candidates)
    chosen = candidates[selection.chosen]
    if model == "amplitude" and selection.chosen == "single-mode":
        chosen = without_gain(single, candidates["amplitude"].exponent)
    fit = _build_result(chosen, weights, noise, loss, delta_n * scale**2, t, mean, scale)
    fit = replace(fit, **_selection_fields(selection, why), gap_share=gap_share(t))
    if noise == "jackknife":  # the larger: conservative when the model is right
        decay_jk, freq_jk = jackknife_std(chosen)
        if math.isfinite(decay_jk):
            fit = replace(
                fit,
                decay_rate_std=max(fit.decay_rate_std, decay_jk),
                angular_frequency_std=max(fit.angular_frequency_std, freq_jk),
            )
    if isinstance(chosen, AmplitudeState):
        gain_std = chosen.damping_gain_std(weights, correlated=noise != "white", scale=scale)
        fit = replace(
            fit,
            model=COMBINED if chosen.second else "amplitude",
            damping_gain=chosen.damping_gain(scale),
            damping_gain_std=gain_std,
            damping_exponent=float(chosen.exponent),
        )
    return fit


def _identifiable(candidates: dict[str, FitState], model: str) -> tuple[dict[str, FitState], str]:
    """The candidates ``"auto"`` may choose, and why: all of them but a fit with two
    oscillating modes closer together than the one-mode line's half-width λ, both about as
    broad as the line (:data:`~liquidtouch.fit.choices.MIN_LINE_WIDTH_SHARE`) or any two
    when the ring-down rings for only a few cycles
    (:data:`~liquidtouch.fit.choices.MIN_QUALITY_FOR_TWO_MODES`): module docstring. A second
    mode further off (e.g. the low-pass filter's ringing) or a transient stays."""
    if model != AUTO:
        return candidates, f"{model} asked for"
    single = candidates["single-mode"]
    half_width = float(single.rates[0])
    quality = float(single.freqs[0]) / max(half_width, 1e-300)
    narrowest = 0.0 if quality < MIN_QUALITY_FOR_TWO_MODES else MIN_LINE_WIDTH_SHARE * half_width

    def one_drifting_line(state: FitState) -> bool:
        return (
            state.n_modes == 2
            and bool(state.oscillates().all())
            and abs(float(np.diff(state.freqs)[0])) < half_width
            and float(state.rates.min()) >= narrowest
        )

    kept = {name: s for name, s in candidates.items() if not one_drifting_line(s)}
    if len(kept) == len(candidates):
        return candidates, "auto"
    return kept, f"auto, no two modes within the line (|Δω| < λ {half_width:.3g} 1/s)"


def _selection_fields(selection: Selection, why: str) -> dict[str, object]:
    """``model_reason`` (``why`` the candidates, then the criteria) and ``delta_bic_*`` of
    the result (module docstring)."""
    reason = why if len(selection.bic) == 1 else f"{why}; {selection.reason()}"
    return {
        "model_reason": reason,
        "delta_bic_single_mode": selection.delta("single-mode"),
        "delta_bic_two_mode": selection.delta("two-mode"),
        "delta_bic_amplitude": selection.delta("amplitude"),
        "delta_bic_amplitude_two_mode": selection.delta(COMBINED),
        "n_effective": selection.n_effective,
    }


def gap_share(t: np.ndarray) -> float:
    """Share of the time span of ``t`` [s] that lies in gaps (steps > ``GAP_STEPS`` × median)."""
    steps = np.diff(np.asarray(t, dtype=float))
    if steps.size == 0:
        return 0.0
    typical = float(np.median(steps))
    missing = np.where(steps > GAP_STEPS * typical, steps - typical, 0.0)
    return float(missing.sum() / (t[-1] - t[0]))


def _build_result(
    state: FitState,
    weights: np.ndarray,
    noise: str,
    loss: str,
    delta: float,
    t: np.ndarray,
    mean: float,
    scale: float,
) -> OscillationFit:
    std = state.standard_errors(weights, correlated=noise != "white")
    amps, phases = state.amplitudes_phases()
    rates, freqs = state.rates, state.freqs
    d0, d1, d2 = state.drift()
    length = t[-1] - t[0]
    two = state.n_modes == 2
    nan = math.nan
    if state.reported_mode() == 1:  # report the slosh first, the other mode second
        amps, phases, rates, freqs = amps[::-1], phases[::-1], rates[::-1], freqs[::-1]
        std = [std[2], std[3], std[0], std[1]]
    return OscillationFit(
        decay_rate=float(rates[0]),
        angular_frequency=float(freqs[0]),
        amplitude=float(amps[0] * scale),
        phase=float(phases[0]),
        fast_decay_rate=float(rates[1]) if two else nan,
        fast_angular_frequency=float(freqs[1]) if two else nan,
        fast_amplitude=float(amps[1] * scale) if two else nan,
        fast_phase=float(phases[1]) if two else nan,
        drift_c0=float(d0 * scale + mean),
        drift_c1=float(d1 * scale / length),
        drift_c2=float(d2 * scale / length**2),
        decay_rate_std=std[0],
        angular_frequency_std=std[1],
        fast_decay_rate_std=std[2] if two else nan,
        fast_angular_frequency_std=std[3] if two else nan,
        r2=state.r2(),
        noise_std=state.noise_var() ** 0.5 * scale,
        loss=loss,
        delta=delta,
        model="two-mode" if two else "single-mode",
        t0=float(t[0]),
        n_samples=int(t.size),
        duration_s=float(length),
    )
