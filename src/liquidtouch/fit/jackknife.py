"""The blocked jackknife of the reported λ and ω: how much they depend on which part of the
window was fitted.

The fit's own standard errors (:mod:`liquidtouch.fit.solve`) assume the model is right.
A real ring-down is not exactly any candidate's curve (the envelope of a slosh whose damping
grows with its amplitude, the low-pass's response, drift), and then the answer moves with
the part of the record that is fitted more than the noise explains: on simulated trials the
correlated-noise errors covered the true λ at ±1σ in about half of them (RMS z ~2).
Leaving out each of :data:`N_BLOCKS` contiguous blocks of the window in turn and
re-solving from the optimum (no start search) measures that movement (the blocked,
delete-a-group jackknife; Künsch 1989), each block weighted by its share of the
information (:func:`jackknife_std`). With ``noise="jackknife"`` the fit reports the larger
of its correlated-noise std and this one (``benchmarks/RESULTS.md``, "# fit_std").
"""

from __future__ import annotations

import itertools
import math
from dataclasses import replace

import numpy as np
from scipy.optimize import least_squares

from liquidtouch.fit.solve import FitState

__all__ = ["N_BLOCKS", "jackknife_std", "refit"]

#: contiguous blocks of the window left out in turn (each 1/5 of the samples)
N_BLOCKS = 5
#: fewest converged block fits a jackknife std is computed from
MIN_BLOCK_FITS = 3


def refit(state: FitState, keep: np.ndarray) -> FitState | None:
    """``state``'s model re-solved on the samples ``keep`` (bool), from ``state``'s optimum.

    A local solve (Levenberg–Marquardt, no start search); the parameters the state holds
    fixed stay fixed. ``None`` when it does not converge to finite parameters.
    """
    sub = replace(
        state, tau=state.tau[keep], x=state.x[keep], u=state.u[keep], sqrt_w=state.sqrt_w[keep]
    )
    free = state.free_parameters()

    def at(values: np.ndarray) -> FitState:
        theta = state.theta.copy()
        theta[free] = values
        return replace(sub, theta=theta)

    def fun(values: np.ndarray) -> np.ndarray:
        return sub.sqrt_w * (at(values).model_curve() - sub.u)

    def jac(values: np.ndarray) -> np.ndarray:
        return sub.sqrt_w[:, None] * at(values).theta_jacobian()[:, free]

    with np.errstate(all="ignore"):
        res = least_squares(fun, state.theta[free], jac=jac, method="lm")
    if not (res.success and np.all(np.isfinite(res.x))):
        return None
    return replace(at(res.x), cost=float(2.0 * res.cost))


def jackknife_std(state: FitState) -> tuple[float, float]:
    """Blocked-jackknife std of the reported mode's (λ [1/s], ω [rad/s]) (module docstring).

    The window is cut into contiguous blocks of equal information (each ``1/K`` of the
    leverage ``Σ_i J_i B⁻¹ J_iᵀ``, ``B = Jᵀ W J``), and ``Σ_k (1 − h_k) (θ_k − θ̂)²`` is summed
    over the block fits ``θ_k``, ``h_k = tr(B⁻¹ B_k) / p`` block ``k``'s share (Hinkley 1977's
    weighting; ``(K − 1)/K Σ`` when the shares are equal). NaN when fewer than
    :data:`MIN_BLOCK_FITS` converge.
    """
    free = state.free_parameters()
    jac = state.theta_jacobian()[:, free] * state.sqrt_w[:, None]
    try:
        inverse = np.linalg.inv(jac.T @ jac)
    except np.linalg.LinAlgError:
        return math.nan, math.nan
    mode = state.reported_mode()
    centre = np.array([state.rates[mode], state.freqs[mode]])
    # blocks of equal information, not of equal length: a ring-down that dies early carries
    # nearly all of it in its first samples, and a block holding it all estimates nothing
    leverage = np.einsum("ij,jk,ik->i", jac, inverse, jac) / len(free)  # per sample, Σ = 1
    edges = np.searchsorted(np.cumsum(leverage), np.arange(1, N_BLOCKS) / N_BLOCKS) + 1
    edges = np.unique(np.concatenate([[0], np.clip(edges, 1, state.n - 1), [state.n]]))
    total, fits = np.zeros(2), 0
    for lo, hi in itertools.pairwise(edges):
        keep = np.ones(state.n, bool)
        keep[lo:hi] = False
        sub = refit(state, keep)
        if sub is None:
            continue
        k = sub.reported_mode()
        deviation = np.array([sub.rates[k], sub.freqs[k]]) - centre
        total += (1.0 - float(leverage[lo:hi].sum())) * deviation**2
        fits += 1
    if fits < MIN_BLOCK_FITS:
        return math.nan, math.nan
    return float(np.sqrt(total[0])), float(np.sqrt(total[1]))
