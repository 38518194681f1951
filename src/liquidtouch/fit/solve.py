"""Nonlinear least-squares solves of the oscillation model, multi-start, with their statistics.

Works on the normalised signal (zero mean, unit standard deviation) and on time
``tau`` [s] from the first sample; :mod:`liquidtouch.fit.oscillation` converts back.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TypeVar

import numpy as np
from scipy.optimize import least_squares

from liquidtouch.fit import model as om
from liquidtouch.fit.start import profile_starts, spectral_peaks

RATE_MAX = 60.0  # 1/s; far above any slosh mode at 30 Hz sampling
DELTA_MIN = 1e-6  # 1/s; keeps λ' > λ strictly
#: a mode whose ω is below this many times its λ (damping ratio above 1/√2: it decays by
#: e within a radian of its cycle and overshoots by under 4.3 %) is a transient, e.g. the
#: push's, not the slosh (detergent's slosh: ω/λ ≈ 3-4; the push's transient beside it
#: in a two-mode fit: 0.1-0.35)
MIN_OSCILLATION_OMEGA_OVER_LAMBDA = 1.0
#: a slow mode with less energy than this share of the fast mode's is a sliver (drift or
#: noise locked onto beside a short, heavily damped ring-down), not the slosh: slivers
#: on simulated trials 0.001-0.15 (detergent, ``tests/fit/data/detergent_short_ringdown.csv``
#: 0.10); the slow mode of exact two-mode signals whose optimum shares the energy
#: differently from the truth 0.69-0.72 (``benchmarks/fit/fit_accuracy.py``): any share
#: between the two clusters separates them, and 0.3 sits between them, not at either edge
SLIVER_ENERGY_SHARE = 0.3
#: half-width [Hz] of the band around a mode's frequency whose residual periodogram is its
#: local noise level (:meth:`FitState.mode_snr`, :func:`local_noise_ratio`): a slosh line
#: (λ ≤ 1 1/s: ±0.16 Hz) with its skirts, ~13 bins of a 13 s record to average
LOCAL_NOISE_HALF_WIDTH_HZ = 0.5
#: above this many samples, autocorrelations are computed by FFT
FFT_MIN_SAMPLES = 4096
#: most model evaluations of one local solve; its last iterate is taken when it has not
#: converged by then. Re-solves from an optimum on most of the same samples (the blocked
#: jackknife) took a median of 7, and 1.4 % of them more than this (validation signals and
#: ``tests/fit/data``), where a few ran to 1200 and took most of a fit's time
MAX_EVALUATIONS = 200

FitStateT = TypeVar("FitStateT", bound="FitState")


@dataclass
class FitState:
    """An optimum of the model on the normalised signal."""

    n_modes: int
    theta: np.ndarray
    tau: np.ndarray
    drift_basis: np.ndarray
    u: np.ndarray
    sqrt_w: np.ndarray
    cost: float  # Σ w (u - û)²

    @property
    def n(self) -> int:
        return self.tau.size

    @property
    def n_params(self) -> int:
        return self.theta.size

    @property
    def rates(self) -> np.ndarray:
        return om.rates_and_freqs(self.theta[: om.n_nonlinear(self.n_modes)], self.n_modes)[0]

    @property
    def freqs(self) -> np.ndarray:
        return om.rates_and_freqs(self.theta[: om.n_nonlinear(self.n_modes)], self.n_modes)[1]

    def model_curve(self) -> np.ndarray:
        """The model ``û`` at the samples (a subclass with another model overrides it)."""
        return om.curve(self.theta, self.tau, self.drift_basis, self.n_modes)

    def model_jacobian(self) -> np.ndarray:
        """``d û / d theta`` at the samples, shape ``(n, n_params)``."""
        return om.jacobian(self.theta, self.tau, self.drift_basis, self.n_modes)

    def theta_jacobian(self) -> np.ndarray:
        """``d û / d theta`` for every entry of ``theta`` (held ones too), ``(n, theta.size)``."""
        return self.model_jacobian()

    def free_parameters(self) -> np.ndarray:
        """Indices of ``theta`` the solve moves (all here)."""
        return np.arange(self.theta.size)

    def nonlinear_bounds(self, band: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
        """Bounds of the nonlinear parameters in the solve (``band`` [rad/s] for ω)."""
        return _nonlinear_bounds(self.n_modes, band)

    def bounds(self, band: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
        """Bounds of every entry of ``theta``: the nonlinear ones', the linear ones free."""
        return with_free_linear(*self.nonlinear_bounds(band), self.theta.size)

    def oscillates(self) -> np.ndarray:
        """Per mode: oscillates (ω ≥ ``MIN_OSCILLATION_OMEGA_OVER_LAMBDA`` λ), not a transient."""
        return self.freqs >= MIN_OSCILLATION_OMEGA_OVER_LAMBDA * self.rates

    def reported_mode(self) -> int:
        """Which mode is the slosh (0 or 1): the one that oscillates when the other is a
        transient (:meth:`oscillates`), else the less damped one, unless it is a sliver
        next to the other (a short, heavily damped ring-down)."""
        if self.n_modes != 2:
            return 0
        oscillates = self.oscillates()
        if oscillates[0] != oscillates[1]:
            return int(oscillates[1])
        return int(self.slow_mode_energy_share() < SLIVER_ENERGY_SHARE)

    def residual(self) -> np.ndarray:
        """Unweighted residual ``u - û``."""
        return self.u - self.model_curve()

    def rss(self) -> float:
        """Residual sum of squares Σ (u − û)² (unweighted): the likelihood the model
        criterion judges by (:mod:`liquidtouch.fit.selection`)."""
        r = self.residual()
        return float(r @ r)

    def noise_var(self) -> float:
        """Residual variance Σ (u − û)² / (n − p) (unweighted)."""
        return self.rss() / (self.n - self.n_params)

    def r2(self) -> float:
        centred = self.u - self.u.mean()
        return 1.0 - self.rss() / float(centred @ centred)

    def bic(self) -> float:
        return self.n * math.log(self.cost / self.n) + self.n_params * math.log(self.n)

    def is_weighted(self) -> bool:
        return bool(np.ptp(self.sqrt_w) > 0)

    def mode_snr(self) -> np.ndarray:
        """Energy Σ m_k² of each mode over the residual's local noise level at its frequency.

        The noise level is the residual periodogram averaged within ±0.5 Hz of the
        mode: for white noise it is the residual variance, for low-passed noise it is
        the (larger) in-band level, so noise that merely looks oscillatory is not
        mistaken for a mode.
        """
        k = om.n_nonlinear(self.n_modes)
        design = om.basis(self.tau, self.drift_basis, self.rates, self.freqs)
        lin = self.theta[k:]
        omega_bins, power = residual_periodogram(self.tau, self.residual())
        periodogram = power / (self.n - self.n_params)
        out = []
        for j in range(self.n_modes):
            near = np.abs(omega_bins - self.freqs[j]) <= 2 * np.pi * LOCAL_NOISE_HALF_WIDTH_HZ
            local_var = 2 * float(periodogram[near].mean()) if near.any() else self.noise_var()
            m = design[:, 2 * j : 2 * j + 2] @ lin[2 * j : 2 * j + 2]
            out.append(float(m @ m) / max(local_var, 1e-300))
        return np.array(out)

    def slow_mode_energy_share(self) -> float:
        """Energy of the slow mode over the window relative to the fast mode's.

        The reported (slow) mode is the sloshing itself; a nearly undamped
        sliver of some other frequency next to a strong "fast" mode is the fit
        locking onto drift or noise, not the paper's two-mode decay.
        """
        amplitudes, _ = self.amplitudes_phases()
        rates, _ = om.rates_and_freqs(self.theta[: om.n_nonlinear(self.n_modes)], self.n_modes)
        span = float(self.tau[-1])
        energy = amplitudes**2 * (1 - np.exp(-2 * rates * span)) / np.maximum(2 * rates, 1e-12)
        return float(energy[0] / energy[1])

    def amplitudes_phases(self) -> tuple[np.ndarray, np.ndarray]:
        """Amplitude B_k and phase ψ_k of each mode (a cos + b sin = B cos(· + ψ))."""
        lin = self.theta[om.n_nonlinear(self.n_modes) :]
        a, b = lin[0 : 2 * self.n_modes : 2], lin[1 : 2 * self.n_modes : 2]
        return np.hypot(a, b), np.arctan2(-b, a)

    def drift(self) -> np.ndarray:
        """The drift's coefficients (of :func:`~liquidtouch.fit.model.drift_columns`)."""
        return self.theta[-self.drift_basis.shape[1] :]

    def standard_errors(self, weights: np.ndarray, *, correlated: bool) -> list[float]:
        """Standard errors of [λ, ω, λ', ω'] (NaN for an absent fast mode)."""
        cov = self.covariance(weights, correlated=correlated)
        if cov is None:
            return [math.nan] * 4
        var = np.diag(cov)
        if self.n_modes == 1:
            return [std_from_variance(var[0]), std_from_variance(var[1]), math.nan, math.nan]
        var_fast_rate = var[0] + var[2] + 2 * cov[0, 2]
        return [
            std_from_variance(var[0]),
            std_from_variance(var[1]),
            std_from_variance(var_fast_rate),
            std_from_variance(var[3]),
        ]

    def covariance(self, weights: np.ndarray, *, correlated: bool) -> np.ndarray | None:
        """Sandwich covariance of ``theta`` (see ``oscillation``'s docstring); None if singular."""
        jac = self.model_jacobian()
        bread = jac.T @ (weights[:, None] * jac)
        score = weights[:, None] * jac  # per-sample W J
        if correlated:
            g = score * self.residual()[:, None]
            meat = _newey_west_meat(g, _bartlett_lags(self.residual()))
            meat *= self.n / (self.n - self.n_params)
        elif self.is_weighted():
            # the paper's weights come from the noisy data; the residual-based
            # (heteroscedasticity-robust) sandwich keeps the std honest there
            g = score * self.residual()[:, None]
            meat = (g.T @ g) * self.n / (self.n - self.n_params)
        else:
            meat = self.noise_var() * (score.T @ score)
        try:
            inv = np.linalg.inv(bread)
        except np.linalg.LinAlgError:
            return None
        return inv @ meat @ inv


def best_optimum(fits: Iterable[FitStateT]) -> FitStateT:
    """Of several local optima of one model (a multi-start), the one the model criterion
    scores best: the lowest unweighted RSS, so that one measure chooses between optima
    within a model and between models (:mod:`liquidtouch.fit.selection`). The paper's
    weighted loss, which each solve minimises, weighs the noisy tail of a ring-down most:
    ranked by it, a faint line fitted to the tail's noise beat a second mode the whole
    record carries. A failed solve (cost not finite) is chosen only when all failed.
    """
    fits = list(fits)
    finite = [f for f in fits if math.isfinite(f.cost)]
    return min(finite, key=lambda f: f.rss()) if finite else fits[0]


def std_from_variance(v: float) -> float:
    """The std of a variance ``v`` (NaN when it is negative or not finite)."""
    return math.sqrt(v) if v >= 0 and math.isfinite(v) else math.nan


def residual_periodogram(tau: np.ndarray, resid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Angular frequencies [rad/s] and ``|FFT|²`` of a residual at times ``tau`` [s], resampled
    to a uniform grid of as many samples (gaps are bridged by linear interpolation)."""
    n = tau.size
    dt = (tau[-1] - tau[0]) / (n - 1)
    uniform = np.interp(tau[0] + dt * np.arange(n), tau, resid)
    return 2 * np.pi * np.fft.rfftfreq(n, dt), np.abs(np.fft.rfft(uniform)) ** 2


def local_noise_ratio(tau: np.ndarray, resid: np.ndarray, omega: float) -> float:
    """The residual's noise level near ``omega`` [rad/s] over its variance: ``S(ω) / γ0``.

    The residual periodogram averaged within ±:data:`LOCAL_NOISE_HALF_WIDTH_HZ` of ω over
    its average over all frequencies (the variance): 1 for white noise, the noise's
    spectral density at the mode relative to its mean for coloured noise (Whittle: a model
    whose curve differs near ω is judged against the noise there). 1 when no bin is near.
    """
    omega_bins, power = residual_periodogram(tau, resid - resid.mean())
    near = np.abs(omega_bins - omega) <= 2 * np.pi * LOCAL_NOISE_HALF_WIDTH_HZ
    total = float(power[1:].mean())
    if not near.any() or total <= 0:
        return 1.0
    return float(power[near].mean()) / total


def _autocorrelation(r: np.ndarray) -> np.ndarray:
    """Autocorrelation of a centred series at lags 0..n−1 (by FFT for long series)."""
    n = r.size
    if n <= FFT_MIN_SAMPLES:
        return np.correlate(r, r, mode="full")[n - 1 :] / float(r @ r)
    spectrum = np.fft.rfft(r, 2 * n)  # O(n log n) instead of O(n²)
    return np.fft.irfft(spectrum * np.conj(spectrum), 2 * n)[:n] / float(r @ r)


def correlation_length(resid: np.ndarray) -> int:
    """The lag [samples] where the residual's autocorrelation first falls below 0.1 (a
    quarter of the samples when it never does): 1 for white noise, a few samples for
    low-passed noise."""
    r = resid - resid.mean()
    below = np.nonzero(_autocorrelation(r)[1:] < 0.1)[0]
    return int(below[0]) + 1 if below.size else r.size // 4


def _bartlett_lags(resid: np.ndarray) -> int:
    """Newey–West truncation lag: 4× the lag where the residual autocorrelation dies, ≥ 10.

    The Bartlett kernel down-weights long lags, so a generous lag is needed for
    low-passed noise (checked by Monte-Carlo in the tests).
    """
    return int(min(max(4 * correlation_length(resid), 10), resid.size // 4))


def _newey_west_meat(g: np.ndarray, lags: int) -> np.ndarray:
    """``Σ_t g_t g_tᵀ + Σ_{l=1..lags} (1 − l/(lags+1)) (Γ_l + Γ_lᵀ)``, ``Γ_l = Σ_t g_{t+l} g_tᵀ``.

    A lag loop for the usual short signal; for long signals with many lags the
    cross-correlations come from FFTs (O(p² n log n) instead of O(p² n · lags)).
    """
    n, p = g.shape
    meat = g.T @ g
    if lags * n <= FFT_MIN_SAMPLES * 256:
        for lag in range(1, lags + 1):
            gamma = g[lag:].T @ g[:-lag]
            meat += (1 - lag / (lags + 1)) * (gamma + gamma.T)
        return meat
    n_fft = 1 << int(np.ceil(np.log2(n + lags + 1)))
    weights = 1 - np.arange(1, lags + 1) / (lags + 1)
    spectra = [np.fft.rfft(g[:, i], n_fft) for i in range(p)]
    for i in range(p):
        for j in range(p):
            # r_ij(l) = Σ_t g_i[t+l] g_j[t] for l = 1..lags
            r = np.fft.irfft(spectra[i] * np.conj(spectra[j]), n_fft)[1 : lags + 1]
            meat[i, j] += weights @ r
            meat[j, i] += weights @ r
    return meat


def with_free_linear(
    lo_nl: np.ndarray, hi_nl: np.ndarray, size: int
) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of a ``size``-entry θ whose nonlinear entries ``lo_nl``-``hi_nl`` lead and
    whose linear coefficients after them are free."""
    n_lin = size - len(lo_nl)
    return (
        np.concatenate([lo_nl, np.full(n_lin, -np.inf)]),
        np.concatenate([hi_nl, np.full(n_lin, np.inf)]),
    )


def _nonlinear_bounds(n_modes: int, band: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    if n_modes == 1:
        return np.array([0.0, band[0]]), np.array([RATE_MAX, band[1]])
    return (
        np.array([0.0, band[0], DELTA_MIN, band[0]]),
        np.array([RATE_MAX, band[1], 2 * RATE_MAX, band[1]]),
    )


def _solve(
    theta_nl: np.ndarray,
    n_modes: int,
    tau: np.ndarray,
    drift_basis: np.ndarray,
    u: np.ndarray,
    sqrt_w: np.ndarray,
    band: tuple[float, float],
) -> FitState:
    lo_nl, hi_nl = _nonlinear_bounds(n_modes, band)
    span = hi_nl - lo_nl
    theta_nl = np.clip(theta_nl, lo_nl + 1e-6 * span, hi_nl - 1e-6 * span)
    rates, freqs = om.rates_and_freqs(theta_nl, n_modes)
    lin, _ = om.solve_linear(om.basis(tau, drift_basis, rates, freqs), u, sqrt_w)
    theta0 = np.concatenate([theta_nl, lin])
    lo, hi = with_free_linear(lo_nl, hi_nl, theta0.size)

    def fun(theta: np.ndarray) -> np.ndarray:
        return sqrt_w * (om.curve(theta, tau, drift_basis, n_modes) - u)

    def jac(theta: np.ndarray) -> np.ndarray:
        return sqrt_w[:, None] * om.jacobian(theta, tau, drift_basis, n_modes)

    res = least_squares(
        fun, theta0, jac=jac, bounds=(lo, hi), method="trf", x_scale="jac", max_nfev=MAX_EVALUATIONS
    )
    return FitState(n_modes, res.x, tau, drift_basis, u, sqrt_w, float(2 * res.cost))


def optimise_single_mode(
    tau: np.ndarray,
    drift_basis: np.ndarray,
    u: np.ndarray,
    u_detrended: np.ndarray,
    sqrt_w: np.ndarray,
    band: tuple[float, float],
    warm_start: tuple[float, float] | None = None,
) -> FitState:
    """Best single-mode optimum from starts at the spectral peaks and the λ profile.

    ``warm_start`` (λ [1/s], ω [rad/s]) of a previous fit: start there and at the
    strongest spectral peak (with that λ) only, skipping the λ profile.
    """
    if warm_start is not None:
        lam, omega = (float(v) for v in warm_start)
        if lam > 0 and band[0] < omega < band[1]:
            peak = spectral_peaks(tau, u_detrended, band, n_peaks=1)[0]
            starts = ([lam, omega], [lam, float(peak)])
            fits = [_solve(np.array(s), 1, tau, drift_basis, u, sqrt_w, band) for s in starts]
            best = best_optimum(fits)
            if math.isfinite(best.cost):
                return best
    peaks = spectral_peaks(tau, u_detrended, band, n_peaks=2)
    starts = profile_starts(tau, drift_basis, u, sqrt_w, peaks, band)
    fits = [
        _solve(np.array([lam, omega]), 1, tau, drift_basis, u, sqrt_w, band)
        for _, lam, omega in starts
    ]
    return best_optimum(fits)


def optimise_two_mode(
    tau: np.ndarray,
    drift_basis: np.ndarray,
    u: np.ndarray,
    sqrt_w: np.ndarray,
    band: tuple[float, float],
    single: FitState,
) -> FitState | None:
    """Best two-mode optimum, started from the single-mode fit and its residual's peaks."""
    lam, omega = float(single.rates[0]), float(single.freqs[0])
    resid_peaks = spectral_peaks(tau, single.residual(), band, n_peaks=2)
    gap = max(2.0 * lam, 0.5)
    starts = [
        # same frequency, faster decay: the non-linear early decay of one slosh mode
        (lam, omega, gap, omega * 1.02),
        # the single fit found the fast mode; the slow one hides in the residual
        (0.5 * lam, resid_peaks[0], 0.5 * lam + 0.3, omega),
    ]
    starts += [(lam, omega, gap, p) for p in resid_peaks if abs(p / omega - 1) > 0.05]
    fits = [_solve(np.array(s), 2, tau, drift_basis, u, sqrt_w, band) for s in starts]
    best = best_optimum(fits)
    return best if math.isfinite(best.cost) else None
