"""The damped-oscillation model of the tactile signal: curve, analytic Jacobian, linear part.

Each mode is a damped cosine ``B e^{-λτ} cos(ωτ + ψ)`` (:func:`damped_cosine`, the one
place it is written out) on a slow drift (:func:`drift_columns`): a quadratic, and on a long
record the slow cosines below the band the slosh is looked for in. For the fit the model
is written, in time ``tau`` [s] measured from the first sample, as::

    u(tau) = sum_k exp(-r_k tau) (a_k cos(w_k tau) + b_k sin(w_k tau))
             + d0 + d1 x + d2 x**2 + sum_{j=3..J} d_j cos(j pi x)

with ``x = tau / T`` (``T`` the record length, for conditioning; ``J`` from
:func:`drift_turns`), ``r_1 = λ`` (slow mode), ``r_2 = λ + Δ`` (fast mode, ``Δ > 0``),
``w_k > 0``. The cosine/sine amplitudes ``(a, b)`` and the drift's ``d_j`` keep the model
linear in everything but the rates and frequencies, so those can be solved exactly for any
start (variable projection). The drift's columns (``drift_basis``, one row per sample)
are built once per record and passed in.

Parameter vectors are ordered ``[λ, ω, a1, b1, d0, d1, d2, d3, ...]`` for one mode and
``[λ, ω, Δ, ω', a1, b1, a2, b2, d0, d1, d2, d3, ...]`` for two modes.
"""

from __future__ import annotations

import numpy as np

#: drift columns of the quadratic ``1, x, x²``, always held; it spans the first two
#: half-turns of a slow motion (one monotone change and one bend)
N_QUADRATIC = 3


def damped_cosine(
    tau: np.ndarray, amplitude: float, rate: float, angular_frequency: float, phase: float
) -> np.ndarray:
    """One mode, ``B e^{-λτ} cos(ωτ + ψ)``, at times ``tau`` [s] from the model's origin.

    ``amplitude`` B (unit of u), decay ``rate`` λ [1/s], ``angular_frequency`` ω
    [rad/s], ``phase`` ψ [rad].
    """
    tau = np.asarray(tau, dtype=float)
    return amplitude * np.exp(-rate * tau) * np.cos(angular_frequency * tau + phase)


def quadratic_drift(tau: np.ndarray, c0: float, c1: float, c2: float) -> np.ndarray:
    """The slow drift ``c0 + c1 τ + c2 τ²`` at times ``tau`` [s]."""
    tau = np.asarray(tau, dtype=float)
    return c0 + c1 * tau + c2 * tau * tau


def cosine_drift(tau: np.ndarray, amplitudes: np.ndarray, duration_s: float) -> np.ndarray:
    """``Σ_j a_j cos(jπτ/T)`` for ``j = 3, 4, ...`` (``amplitudes`` in that order, unit of
    u) at times ``tau`` [s] of a record of ``duration_s`` ``T`` [s]: the drift beyond the
    quadratic (:func:`drift_columns`)."""
    x = np.asarray(tau, dtype=float) / duration_s
    return _slow_cosines(x, N_QUADRATIC - 1 + len(amplitudes)) @ np.asarray(amplitudes, float)


def _slow_cosines(x: np.ndarray, turns: int) -> np.ndarray:
    """``cos(jπx)`` for ``3 ≤ j ≤ turns`` at ``x`` (time over the record's length), shape
    ``(n, max(0, turns − 2))``: the drift beyond the quadratic."""
    return np.cos(np.pi * np.outer(x, np.arange(N_QUADRATIC, turns + 1)))


def drift_turns(duration_s: float, band_low_rad_s: float) -> int:
    """Most half-turns ``J`` of a drift over a record of ``duration_s`` [s] that stays below
    the band the slosh is looked for in (lower edge ``band_low_rad_s`` [rad/s]):
    ``cos(Jπτ/T)`` is a ``J / (2 T)`` Hz motion, so ``J = ⌊2 T f_low⌋`` (also the number
    of independent shapes slower than ``f_low`` that ``T`` seconds of samples hold, Landau
    & Pollak 1962: ``T`` is the time the samples cover, without a long stall's).

    A 13 s hold in a 0.3 Hz band holds a thermal or creep drift that turns 7 times; a
    record shorter than ``3 / (2 f_low)`` keeps the quadratic alone. Cosines, not a
    polynomial of degree ``J``: a polynomial's turns crowd at the record's ends (its
    zeros ~``T / J²`` apart there), where a ring-down starts and the push's transient is,
    and there it follows them (degree 7 moved λ of the simulator's force ring-downs by
    1-2 % and took a detergent slosh's push transient for drift); a cosine turns evenly.
    """
    return int(2 * duration_s * band_low_rad_s / (2 * np.pi))


def drift_columns(tau: np.ndarray, turns: int) -> np.ndarray:
    """The drift's columns at times ``tau`` [s] (from 0, ``x = tau / tau[-1]``): ``1``,
    ``x``, ``x²`` and ``cos(jπx)`` for ``3 ≤ j ≤ turns`` (:func:`drift_turns`), shape
    ``(n, 3 + max(0, turns − 2))``."""
    x = np.asarray(tau, dtype=float) / tau[-1]
    return np.column_stack([np.ones_like(x), x, x * x, _slow_cosines(x, turns)])


def n_nonlinear(n_modes: int) -> int:
    """Number of nonlinear parameters (rates and frequencies) for ``n_modes`` modes."""
    return 2 * n_modes


def rates_and_freqs(theta_nl: np.ndarray, n_modes: int) -> tuple[np.ndarray, np.ndarray]:
    """Decay rates ``r_k`` [1/s] and angular frequencies ``w_k`` [rad/s] of each mode."""
    if n_modes == 1:
        return np.array([theta_nl[0]]), np.array([theta_nl[1]])
    lam, omega, delta, omega_fast = theta_nl[:4]
    return np.array([lam, lam + delta]), np.array([omega, omega_fast])


def basis(
    tau: np.ndarray, drift_basis: np.ndarray, rates: np.ndarray, freqs: np.ndarray
) -> np.ndarray:
    """Design matrix ``(n, 2 * n_modes + D + 1)`` of the linear parameters."""
    env = np.exp(-np.outer(tau, rates))
    phase = np.outer(tau, freqs)
    cols = np.empty((tau.size, 2 * rates.size + drift_basis.shape[1]))
    cols[:, 0 : 2 * rates.size : 2] = env * np.cos(phase)
    cols[:, 1 : 2 * rates.size : 2] = env * np.sin(phase)
    cols[:, 2 * rates.size :] = drift_basis
    return cols


def curve(theta: np.ndarray, tau: np.ndarray, drift_basis: np.ndarray, n_modes: int) -> np.ndarray:
    """The model's value at each sample."""
    k = n_nonlinear(n_modes)
    rates, freqs = rates_and_freqs(theta[:k], n_modes)
    return basis(tau, drift_basis, rates, freqs) @ theta[k:]


def jacobian(
    theta: np.ndarray, tau: np.ndarray, drift_basis: np.ndarray, n_modes: int
) -> np.ndarray:
    """Analytic Jacobian ``d curve / d theta``, shape ``(n, len(theta))``."""
    k = n_nonlinear(n_modes)
    rates, freqs = rates_and_freqs(theta[:k], n_modes)
    design = basis(tau, drift_basis, rates, freqs)
    lin = theta[k:]
    jac = np.empty((tau.size, theta.size))
    jac[:, k:] = design
    # per mode: m = e (a c + b s); dm/dr = -tau m; dm/dw = tau e (b c - a s)
    d_rate = []
    d_freq = []
    for j in range(n_modes):
        ec, es = design[:, 2 * j], design[:, 2 * j + 1]
        a, b = lin[2 * j], lin[2 * j + 1]
        d_rate.append(-tau * (a * ec + b * es))
        d_freq.append(tau * (b * ec - a * es))
    if n_modes == 1:
        jac[:, 0], jac[:, 1] = d_rate[0], d_freq[0]
    else:
        # λ moves both modes (λ' = λ + Δ); Δ moves only the fast one
        jac[:, 0] = d_rate[0] + d_rate[1]
        jac[:, 1] = d_freq[0]
        jac[:, 2] = d_rate[1]
        jac[:, 3] = d_freq[1]
    return jac


def solve_linear(design: np.ndarray, u: np.ndarray, sqrt_w: np.ndarray) -> tuple[np.ndarray, float]:
    """Weighted least-squares linear parameters for a fixed design; returns (params, cost)."""
    a = design * sqrt_w[:, None]
    b = u * sqrt_w
    params, *_ = np.linalg.lstsq(a, b, rcond=None)
    resid = a @ params - b
    return params, float(resid @ resid)


#: bytes of the (rates, freqs, n, 2 + D + 1) design array evaluated at once by profile_cost_grid
GRID_CHUNK_BYTES = 64 * 2**20


def profile_cost_grid(
    tau: np.ndarray,
    drift_basis: np.ndarray,
    u: np.ndarray,
    sqrt_w: np.ndarray,
    rates: np.ndarray,
    freqs: np.ndarray,
) -> np.ndarray:
    """Single-mode weighted cost on a (rate, freq) grid with the linear part solved exactly.

    Returns the cost array of shape ``(rates.size, freqs.size)``; vectorised with
    batched normal equations (the grid only seeds the optimiser, so their mild
    ill-conditioning is harmless). The rates are taken in chunks so the design
    array never exceeds :data:`GRID_CHUNK_BYTES` (one chunk for the usual signal
    of a few hundred samples).
    """
    rates = np.asarray(rates, dtype=float)
    per_rate = max(1, freqs.size * tau.size * (2 + drift_basis.shape[1]) * 8)
    step = max(1, GRID_CHUNK_BYTES // per_rate)
    if step >= rates.size:
        return _profile_cost_chunk(tau, drift_basis, u, sqrt_w, rates, freqs)
    return np.concatenate(
        [
            _profile_cost_chunk(tau, drift_basis, u, sqrt_w, rates[i : i + step], freqs)
            for i in range(0, rates.size, step)
        ]
    )


def _profile_cost_chunk(
    tau: np.ndarray,
    drift_basis: np.ndarray,
    u: np.ndarray,
    sqrt_w: np.ndarray,
    rates: np.ndarray,
    freqs: np.ndarray,
) -> np.ndarray:
    env = np.exp(-np.outer(rates, tau))  # (R, n)
    phase = np.outer(freqs, tau)  # (F, n)
    cos, sin = np.cos(phase), np.sin(phase)
    n = tau.size
    design = np.empty((rates.size, freqs.size, n, 2 + drift_basis.shape[1]))
    design[..., 0] = env[:, None, :] * cos[None, :, :]
    design[..., 1] = env[:, None, :] * sin[None, :, :]
    design[..., 2:] = drift_basis
    design *= sqrt_w[:, None]
    b = u * sqrt_w
    design_t = np.swapaxes(design, -1, -2)
    gram = design_t @ design
    rhs = design_t @ b
    gram += 1e-10 * np.eye(design.shape[-1]) * np.trace(gram, axis1=-2, axis2=-1)[..., None, None]
    params = np.linalg.solve(gram, rhs[..., None])[..., 0]
    # cost = |b|² - rhs·params at the normal-equation solution
    return float(b @ b) - np.sum(rhs * params, axis=-1)
