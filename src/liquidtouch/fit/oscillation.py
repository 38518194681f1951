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
reports for λ and ω the larger of that (averaged over the models, below) and the blocked
jackknife of the model average (:func:`~liquidtouch.fit.jackknife.averaged_jackknife_std`:
how much the average moves when a tenth (at most) of the window is left out, every model re-solved
and re-weighed there), the one of the three whose coverage of the truth was measured right
(``benchmarks/fit/fit_std.py``).

Model selection
---------------
``model="auto"`` (the default, :data:`~liquidtouch.fit.choices.DEFAULT_MODEL`)
fits every model of :data:`~liquidtouch.fit.choices.AUTO_CANDIDATES`: one mode, the
amplitude-dependent damping (:mod:`liquidtouch.fit.amplitude`: one mode whose decay rate
grows with its amplitude; it reports the small-amplitude λ0, which does not depend on how
hard the container was pushed), the drifting line (:mod:`liquidtouch.fit.drifting_line`:
damping and frequency both move with the amplitude, λ0 and ω0 reported), the paper's two
modes, and the amplitude-damped mode beside a second one. The information criterion alone
weighs them (:mod:`liquidtouch.fit.selection`: BIC under the noise the fit estimates near
the slosh); no rule leaves a candidate out. Each candidate is solved from several starts
and its local optimum of lowest RSS is the one weighed
(:func:`~liquidtouch.fit.solve.best_optimum`): the criterion's measure, not the loss each
solve minimises. ``decay_rate``, ``angular_frequency`` and their std are the average over
the candidates by their criterion weights, with the law of total variance: where the data
cannot tell two models apart (two modes inside one line, or one line whose frequency
drifts), the ± holds the spread between them; where one part of the window alone carries
the choice, the jackknife of the average does. ``model`` of the result names the candidate
of most weight, ``model_weight`` its weight, ``model_reason`` why (the
criteria and the weights), and ``delta_bic_*`` the criterion of each candidate over it.
Asking for ``"two-mode"`` weighs one and two modes the same way (fast-mode fields NaN when
one mode leads: ``model == "single-mode"``); ``"amplitude"`` keeps a gain of 0 (λ0 the
single-mode λ) unless the gain lowers the criterion; ``"single-mode"`` fits one mode only.

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

from liquidtouch._core.checks import MIN_FIT_DURATION_S, MIN_FIT_SAMPLES, check_times
from liquidtouch.errors import NoOscillationError, SignalError
from liquidtouch.fit import model as om
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
    MODELS,
    NOISE_MODELS,
)
from liquidtouch.fit.drifting_line import EXPONENT as DRIFT_EXPONENT
from liquidtouch.fit.drifting_line import DriftingLineState, optimise_drifting_line
from liquidtouch.fit.jackknife import averaged_jackknife_std
from liquidtouch.fit.result import OscillationFit
from liquidtouch.fit.selection import Selection, select_model
from liquidtouch.fit.solve import FitState, optimise_single_mode, optimise_two_mode

__all__ = ["fit_oscillation", "validate_signal"]

DEFAULT_DELTA_REL = 1.0
MIN_SAMPLES = MIN_FIT_SAMPLES
#: most samples a fit takes: time and memory grow linearly (200 000 samples: 23 s CPU,
#: 270 MB peak; 1 000 000: 160 s, 850 MB). A 3 Hz slosh needs ~30 samples/s: resample
MAX_SAMPLES = 200_000
MIN_DURATION_S = MIN_FIT_DURATION_S
#: u varying by less than this fraction of its magnitude is flat (float precision)
FLAT_RELATIVE = 1e-12
#: energy of the fitted oscillation over the local noise level below which it is noise
#: (pure white or low-passed noise reaches ~18 at most)
MIN_OSCILLATION_SNR = 30.0
#: a step between samples longer than this many median steps is a gap (samples missing)
GAP_STEPS = 1.5
#: the amplitude-damped mode and a second mode together
COMBINED = "amplitude-two-mode"
#: models the criterion gives a smaller weight than this are left out of the average (their
#: jackknife is not computed): they could move λ̄, ω̄ by at most this share of their distance
MIN_MODEL_WEIGHT = 1e-3


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


def _check_above_noise(single: FitState) -> None:
    snr = float(single.mode_snr()[0])
    if snr < MIN_OSCILLATION_SNR:
        raise NoOscillationError(
            f"no oscillation above the noise (noise only: the best damped cosine's energy is "
            f"{snr:.3g}× the local noise level, need {MIN_OSCILLATION_SNR:g}); check that the "
            "container was pushed and that the signal is the slosh"
        )


def _check_oscillates(state: FitState, band: tuple[float, float]) -> None:
    """The reported mode of the chosen model (not the one-mode fit: beside a push's
    transient, one damped cosine is a compromise between the two, at ω ≈ 2λ)."""
    mode = state.reported_mode()
    lam, omega = state.rates[mode], state.freqs[mode]
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
    # the time the samples cover: a record with a stall of minutes has as few slow shapes
    # to tell apart as its samples span, not as its clock does
    observed_s = min(float(tau[-1]), tau.size * float(np.median(np.diff(tau))))
    drift_basis = om.drift_columns(tau, om.drift_turns(observed_s, band[0]))
    mean, scale = float(u.mean()), float(u.std())
    if not 0 < scale < math.inf:  # under- or overflow of u² (|u| ~ 1e-160 or 1e+160)
        peak = float(np.max(np.abs(u)))
        mean, scale = float((u / peak).mean()) * peak, float((u / peak).std()) * peak
    u_n = (u - mean) / scale

    drift_coef, *_ = np.linalg.lstsq(drift_basis, u_n, rcond=None)
    u_detrended = u_n - drift_basis @ drift_coef
    power = float(np.mean(u_detrended**2))
    if power < 1e-20:
        raise NoOscillationError("no oscillation: the signal is only a slow drift (noise-free)")
    delta_n = delta_rel * power if loss == "paper" else math.nan
    weights = 1.0 / (u_detrended**2 + delta_n) if loss == "paper" else np.ones_like(u_n)
    weights /= weights.mean()
    sqrt_w = np.sqrt(weights)
    single = optimise_single_mode(tau, drift_basis, u_n, u_detrended, sqrt_w, band, warm_start)
    if check_oscillation:
        _check_above_noise(single)
    candidates: dict[str, FitState] = {"single-mode": single}
    wanted = AUTO_CANDIDATES if model == AUTO else (model,)
    two = None
    if {"amplitude", "drifting-line", COMBINED} & set(wanted):
        ends = optimise_amplitude_ends(tau, drift_basis, u_n, sqrt_w, band, single)
        at_two = next(e for e in ends if e.exponent == TWO_MODE_EXPONENT)
        if "amplitude" in wanted:
            candidates["amplitude"] = optimise_amplitude(ends, band)
        if "drifting-line" in wanted:
            candidates["drifting-line"] = optimise_drifting_line(band, at_two)
    if "two-mode" in wanted or COMBINED in wanted:
        two = optimise_two_mode(tau, drift_basis, u_n, sqrt_w, band, single)
        if two is not None and "two-mode" in wanted:
            candidates["two-mode"] = two
    if COMBINED in wanted:
        candidates[COMBINED] = optimise_amplitude_two_mode(
            tau, drift_basis, u_n, sqrt_w, band, at_two, two
        )
    selection = select_model(candidates)
    chosen = candidates[selection.chosen]
    if check_oscillation:
        _check_oscillates(chosen, band)
    if model == "amplitude" and selection.chosen == "single-mode":
        chosen = without_gain(single, candidates["amplitude"].exponent)
    fit = _build_result(chosen, weights, noise, loss, delta_n * scale**2, t, mean, scale)
    why = "auto" if model == AUTO else f"{model} asked for"
    fit = replace(fit, **_selection_fields(selection, why), gap_share=gap_share(t))
    states = {n: chosen if n == selection.chosen else candidates[n] for n in selection.bic}
    kept = {n: w for n, w in selection.weights().items() if w >= MIN_MODEL_WEIGHT}
    correlated = noise != "white"
    features = {n: _features(states[n], weights, correlated) for n in kept}
    average = _model_average(features, kept)
    if noise == "jackknife":  # the larger: conservative when the models are right
        centre = np.array([average["decay_rate"], average["angular_frequency"]])
        ratio = single.n / selection.n_effective
        jack = averaged_jackknife_std(states, selection.chosen, centre, ratio, band)
        if math.isfinite(jack[0]):
            average["decay_rate_std"] = max(average["decay_rate_std"], jack[0])
            average["angular_frequency_std"] = max(average["angular_frequency_std"], jack[1])
    fit = replace(fit, **average)
    if isinstance(chosen, AmplitudeState):
        gain_std = chosen.damping_gain_std(weights, correlated=noise != "white", scale=scale)
        fit = replace(
            fit,
            model=COMBINED if chosen.second else "amplitude",
            damping_gain=chosen.damping_gain(scale),
            damping_gain_std=gain_std,
            damping_exponent=float(chosen.exponent),
        )
    if isinstance(chosen, DriftingLineState):
        correlated = noise != "white"
        harmonic_amplitude, harmonic_phase = chosen.harmonic()
        fit = replace(
            fit,
            model="drifting-line",
            damping_gain=chosen.damping_gain(scale),
            damping_gain_std=chosen.damping_gain_std(weights, correlated=correlated, scale=scale),
            damping_exponent=DRIFT_EXPONENT,
            frequency_shift=chosen.shift,
            frequency_shift_std=chosen.shift_std(weights, correlated=correlated),
            harmonic_amplitude=harmonic_amplitude * scale,
            harmonic_phase=harmonic_phase,
        )
    return fit


def _features(state: FitState, weights: np.ndarray, correlated: bool) -> np.ndarray:
    """``[λ, ω, σ_λ, σ_ω]`` of ``state``'s reported mode [1/s, rad/s]: the standard errors
    under correlated or white noise (module docstring, Uncertainty)."""
    mode = state.reported_mode()
    std = state.standard_errors(weights, correlated=correlated)[2 * mode : 2 * mode + 2]
    return np.array([state.rates[mode], state.freqs[mode], *std])


def _model_average(features: dict[str, np.ndarray], weights: dict[str, float]) -> dict[str, float]:
    """λ, ω and their std averaged over the models by their weights (module docstring, Model
    selection): the weighted means, and the law of total variance ``Σ w (σ² + (θ − θ̄)²)``.
    A model whose std is not finite (a singular covariance) leaves it NaN."""
    w = np.array([weights[n] for n in features])
    w /= w.sum()
    values = np.array(list(features.values()))  # (models, [λ, ω, σ_λ, σ_ω])
    mean = w @ values[:, :2]
    variance = w @ (values[:, 2:] ** 2 + (values[:, :2] - mean) ** 2)
    lead = max(weights, key=weights.__getitem__)
    return {
        "decay_rate": float(mean[0]),
        "angular_frequency": float(mean[1]),
        "decay_rate_std": float(np.sqrt(variance[0])),
        "angular_frequency_std": float(np.sqrt(variance[1])),
        "model_weight": float(w[list(features).index(lead)]),
    }


def _selection_fields(selection: Selection, why: str) -> dict[str, object]:
    """``model_reason`` (``why`` the candidates, then the criteria) and ``delta_bic_*`` of
    the result (module docstring)."""
    reason = why if len(selection.bic) == 1 else f"{why}; {selection.reason()}"
    return {
        "model_reason": reason,
        "delta_bic_single_mode": selection.delta("single-mode"),
        "delta_bic_two_mode": selection.delta("two-mode"),
        "delta_bic_amplitude": selection.delta("amplitude"),
        "delta_bic_drifting_line": selection.delta("drifting-line"),
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
    d0, d1, d2, *cosines = state.drift()
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
        drift_cosines=tuple(float(c * scale) for c in cosines),
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
