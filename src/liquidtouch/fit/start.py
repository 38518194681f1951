"""Start values for the oscillation fit, found without user input.

1. The caller removes the slow drift (a least-squares quadratic in time) so the
   spectrum shows the slosh (:func:`~liquidtouch.fit.oscillation.fit_oscillation`).
2. Spectral peaks of the detrended signal inside the frequency band (the signal
   is resampled to a uniform grid only for this step, so non-uniform time
   stamps are fine).
3. The decay rate: the single-mode cost is profiled over a log grid of decay
   rates and a narrow grid of frequencies around each peak, with amplitudes,
   phase and drift solved exactly at every grid point. This is a least-squares
   fit of the envelope — unlike a log-decrement of picked peaks it does not
   break down when noise hides the late peaks.

Start values need no more than a few thousand samples: a longer signal
(> :data:`START_MAX_SAMPLES`) is thinned for this search to every k-th sample,
as few as that many while still sampling at least :data:`THIN_MIN_RATE_OVER_BAND`
times faster than the band's top frequency (so the band stays below Nyquist);
the cost grid is evaluated in row chunks of bounded size. Memory and time of
the start search so stay bounded whatever the signal's length; the optimiser
then uses every sample.
"""

from __future__ import annotations

import numpy as np

from liquidtouch.fit.model import profile_cost_grid

#: decay rates [1/s] tried on the profile grid
RATE_GRID = np.geomspace(0.01, 8.0, 22)
#: most samples the start-value search works on (longer signals are thinned)
START_MAX_SAMPLES = 4096
#: a thinned signal still samples this many times faster than the band's top frequency
THIN_MIN_RATE_OVER_BAND = 4.0


def thin(tau: np.ndarray, *arrays: np.ndarray, band_high_rad_s: float) -> tuple[np.ndarray, ...]:
    """``tau`` and ``arrays`` at every k-th sample, for the start-value search.

    ``k`` is the smallest stride leaving at most :data:`START_MAX_SAMPLES`
    samples, but no larger than keeps the rate at least
    :data:`THIN_MIN_RATE_OVER_BAND` × the band's top frequency. Signals of at
    most :data:`START_MAX_SAMPLES` samples come back unchanged (the same objects).
    """
    n = tau.size
    if n <= START_MAX_SAMPLES:
        return (tau, *arrays)
    rate_hz = (n - 1) / float(tau[-1] - tau[0])
    top_hz = band_high_rad_s / (2 * np.pi)
    stride = min(-(-n // START_MAX_SAMPLES), int(rate_hz / (THIN_MIN_RATE_OVER_BAND * top_hz)))
    if stride <= 1:
        return (tau, *arrays)
    return tuple(a[::stride] for a in (tau, *arrays))


def spectral_peaks(
    tau: np.ndarray, u_detrended: np.ndarray, band_rad_s: tuple[float, float], n_peaks: int = 3
) -> list[float]:
    """Angular frequencies [rad/s] of the strongest spectral peaks inside the band.

    Falls back to the band's geometric centre when the band holds no local maximum.
    Signals longer than :data:`START_MAX_SAMPLES` are thinned first (:func:`thin`).
    """
    tau, u_detrended = thin(tau, u_detrended, band_high_rad_s=band_rad_s[1])
    n = tau.size
    dt = (tau[-1] - tau[0]) / (n - 1)
    grid = tau[0] + dt * np.arange(n)
    uniform = np.interp(grid, tau, u_detrended)
    n_fft = 1 << int(np.ceil(np.log2(8 * n)))
    power = np.abs(np.fft.rfft(uniform, n_fft)) ** 2
    omega = 2 * np.pi * np.fft.rfftfreq(n_fft, dt)
    inner = np.arange(1, power.size - 1)
    is_peak = (power[inner] >= power[inner - 1]) & (power[inner] > power[inner + 1])
    idx = inner[is_peak]
    idx = idx[(omega[idx] >= band_rad_s[0]) & (omega[idx] <= band_rad_s[1])]
    if idx.size == 0:
        return [float(np.sqrt(band_rad_s[0] * band_rad_s[1]))]
    idx = idx[np.argsort(power[idx])[::-1][:n_peaks]]
    peaks = []
    for i in idx:
        # parabolic refinement on log power
        lp = np.log(power[i - 1 : i + 2] + 1e-300)
        denom = lp[0] - 2 * lp[1] + lp[2]
        shift = 0.5 * (lp[0] - lp[2]) / denom if denom < 0 else 0.0
        peaks.append(float(omega[i] + shift * (omega[1] - omega[0])))
    return peaks


def profile_starts(
    tau: np.ndarray,
    drift_basis: np.ndarray,
    u: np.ndarray,
    sqrt_w: np.ndarray,
    peaks: list[float],
    band_rad_s: tuple[float, float],
) -> list[tuple[float, float, float]]:
    """Best (cost, λ, ω) of the single-mode profile grid around each spectral peak.

    Signals longer than :data:`START_MAX_SAMPLES` are thinned first (:func:`thin`).
    """
    tau, drift_basis, u, sqrt_w = thin(tau, drift_basis, u, sqrt_w, band_high_rad_s=band_rad_s[1])
    starts = []
    for peak in peaks:
        freqs = peak * np.linspace(0.93, 1.07, 7)
        freqs = np.clip(freqs, band_rad_s[0], band_rad_s[1])
        cost = profile_cost_grid(tau, drift_basis, u, sqrt_w, RATE_GRID, freqs)
        i, j = np.unravel_index(np.argmin(cost), cost.shape)
        starts.append((float(cost[i, j]), float(RATE_GRID[i]), float(freqs[j])))
    starts.sort()
    return starts


#: excess damping g = λ(A0)/λ0 − 1 at the window start tried by :func:`amplitude_starts`
GAIN_STARTS = (0.3, 1.5, 6.0)


def amplitude_starts(rate: float, angular_frequency: float) -> list[tuple[float, float, float]]:
    """Starts (λ0 [1/s], ω [rad/s], g) of the amplitude-damping fit from a single-mode fit.

    The single-mode λ averages the decay over the window, so it lies between
    λ0 and the early rate λ0 (1 + g); each start puts λ0 at ``λ / (1 + g/2)``.
    """
    return [(rate / (1.0 + 0.5 * g), angular_frequency, g) for g in GAIN_STARTS]
