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
"""

from __future__ import annotations

import numpy as np

from liquidtouch.fit.model import profile_cost_grid

#: decay rates [1/s] tried on the profile grid
RATE_GRID = np.geomspace(0.01, 8.0, 22)


def spectral_peaks(
    tau: np.ndarray, u_detrended: np.ndarray, band_rad_s: tuple[float, float], n_peaks: int = 3
) -> list[float]:
    """Angular frequencies [rad/s] of the strongest spectral peaks inside the band.

    Falls back to the band's geometric centre when the band holds no local maximum.
    """
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
    x: np.ndarray,
    u: np.ndarray,
    sqrt_w: np.ndarray,
    peaks: list[float],
    band_rad_s: tuple[float, float],
) -> list[tuple[float, float, float]]:
    """Best (cost, λ, ω) of the single-mode profile grid around each spectral peak."""
    starts = []
    for peak in peaks:
        freqs = peak * np.linspace(0.93, 1.07, 7)
        freqs = np.clip(freqs, band_rad_s[0], band_rad_s[1])
        cost = profile_cost_grid(tau, x, u, sqrt_w, RATE_GRID, freqs)
        i, j = np.unravel_index(np.argmin(cost), cost.shape)
        starts.append((float(cost[i, j]), float(RATE_GRID[i]), float(freqs[j])))
    starts.sort()
    return starts
