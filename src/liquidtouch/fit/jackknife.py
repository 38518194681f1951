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
information. With ``noise="jackknife"`` the fit reports the larger of its correlated-noise
std and the jackknife of the model average (:func:`averaged_jackknife_std`), which
re-weighs the candidate models on each block: a choice between models that one part of
the window alone carries (on a 3-cycle, low-passed ring-down, the filter's response at
its start taken for a second mode: λ −25 % with a ± of 4 %) then shows in the ±
(``benchmarks/RESULTS.md``, "fit_std", "validation").
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping
from dataclasses import replace

import numpy as np
from scipy.optimize import least_squares

from liquidtouch.fit.selection import select_model
from liquidtouch.fit.solve import MAX_EVALUATIONS, FitState, correlation_length

__all__ = ["MIN_BLOCKS", "N_BLOCKS", "averaged_jackknife_std", "refit"]

#: most contiguous blocks of the window left out in turn (each a tenth of its information).
#: The jackknife's variance from K blocks has K − 1 degrees of freedom, and the fit reports
#: the larger of it and the models' own: with 5 blocks (4 degrees) that maximum made the ±
#: 1.2-1.4× the scatter on the validation signals (RMS z 0.72 / 0.86, λ / ω) and on signals
#: drawn from the model (0.76 / 0.83, ±1σ 85 / 80 %); with up to 10, 0.77 / 0.91 and
#: 0.87 / 0.95 (±1σ 72 / 70 %) (``benchmarks/RESULTS.md``, "validation", "fit_std")
N_BLOCKS = 10
#: fewest blocks, the count the jackknife had before it had more. Fewer than
#: :data:`N_BLOCKS` while the shortest block would be shorter than the noise's correlation
#: length or than ``n^(1/3)`` samples (the order of the blocked jackknife's and bootstrap's
#: best block length, Hall, Horowitz & Jing 1995): a block of 2 samples in a 28-sample
#: streaming window of a detergent ring-down left the ± at half its ω error
MIN_BLOCKS = 5
#: fewest converged block fits a jackknife std is computed from
MIN_BLOCK_FITS = 3


def refit(state: FitState, keep: np.ndarray, band: tuple[float, float]) -> FitState | None:
    """``state``'s model re-solved on the samples ``keep`` (bool), from ``state``'s optimum.

    A local solve within the bounds of the full solves (``state.bounds(band)``, ``band``
    [rad/s]: decay rates and gains ≥ 0; a block's solve free of them finds a rising
    amplitude's gain below 0 on a plain decay and carries a model the full window gave no
    weight), no start search, at most :data:`~liquidtouch.fit.solve.MAX_EVALUATIONS`
    evaluations; the parameters the state holds fixed stay fixed. ``None`` when its
    parameters are not finite.
    """
    sub = replace(
        state,
        tau=state.tau[keep],
        drift_basis=state.drift_basis[keep],
        u=state.u[keep],
        sqrt_w=state.sqrt_w[keep],
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

    lo, hi = (b[free] for b in state.bounds(band))
    span = np.where(np.isfinite(hi - lo), hi - lo, 0.0)
    start = np.clip(state.theta[free], lo + 1e-9 * span, hi - 1e-9 * span)
    with np.errstate(all="ignore"):
        res = least_squares(
            fun, start, jac=jac, bounds=(lo, hi), method="trf", x_scale="jac",
            max_nfev=MAX_EVALUATIONS,
        )  # fmt: skip
    if not np.all(np.isfinite(res.x)):
        return None
    return replace(at(res.x), cost=float(2.0 * res.cost))


def _blocks(state: FitState) -> list[tuple[np.ndarray, float]] | None:
    """The samples kept when each of :data:`N_BLOCKS` (at least :data:`MIN_BLOCKS`; fewer
    while the shortest would be shorter than the residual's correlation length or
    ``n^(1/3)``) contiguous
    blocks of equal information of ``state``'s model is left out (each ``1/K`` of the
    leverage ``Σ_i J_i B⁻¹ J_iᵀ``, ``B = Jᵀ W J``), with the block's weight ``1 − h_k``,
    ``h_k = tr(B⁻¹ B_k) / p`` its share (Hinkley 1977's weighting; ``(K − 1)/K Σ`` when the
    shares are equal). ``None`` when ``state``'s information matrix is singular."""
    free = state.free_parameters()
    jac = state.theta_jacobian()[:, free] * state.sqrt_w[:, None]
    try:
        inverse = np.linalg.inv(jac.T @ jac)
    except np.linalg.LinAlgError:
        return None
    # blocks of equal information, not of equal length: a ring-down that dies early carries
    # nearly all of it in its first samples, and a block holding it all estimates nothing
    leverage = np.einsum("ij,jk,ik->i", jac, inverse, jac) / len(free)  # per sample, Σ = 1
    # a block shorter than the noise's correlation leaves out samples whose noise the kept
    # ones next to it still carry: the jackknife then sees too little of it (low-passed noise
    # in a ring-down's first samples). Fewer, longer blocks then, down to MIN_BLOCKS
    shortest = max(correlation_length(state.residual()), state.n ** (1 / 3))
    for count in range(N_BLOCKS, MIN_BLOCKS - 1, -1):
        edges = np.searchsorted(np.cumsum(leverage), np.arange(1, count) / count) + 1
        edges = np.unique(np.concatenate([[0], np.clip(edges, 1, state.n - 1), [state.n]]))
        if np.diff(edges).min() >= shortest:
            break
    out = []
    for lo, hi in itertools.pairwise(edges):
        keep = np.ones(state.n, bool)
        keep[lo:hi] = False
        out.append((keep, 1.0 - float(leverage[lo:hi].sum())))
    return out


def _std(deviations: list[tuple[np.ndarray, float]]) -> tuple[float, float]:
    """``√Σ_k (1 − h_k) (θ_k − θ̂)²`` of (λ, ω); NaN from fewer than :data:`MIN_BLOCK_FITS`."""
    if len(deviations) < MIN_BLOCK_FITS:
        return math.nan, math.nan
    total = sum(weight * deviation**2 for deviation, weight in deviations)
    return float(np.sqrt(total[0])), float(np.sqrt(total[1]))


def averaged_jackknife_std(
    candidates: Mapping[str, FitState],
    lead: str,
    centre: np.ndarray,
    noise_ratio: float,
    band: tuple[float, float],
) -> tuple[float, float]:
    """Blocked-jackknife std of the model-averaged (λ [1/s], ω [rad/s]) ``centre``: the
    choice between the models included.

    Each block (:func:`_blocks`, of the ``lead`` model) is left out in turn; every candidate
    is re-solved on the samples kept, the criterion weighs them there
    (:func:`~liquidtouch.fit.selection.select_model`), and the block's average is their
    weighted mean. Where the data carry the choice between two models in
    one part of the window (a start the models explain differently), leaving it out moves
    the average by the distance between them, and the std says so. A candidate that does not
    converge on a block is not weighed there. The criterion takes the noise's ``noise_ratio``
    (``S(ω) / γ0``, :func:`~liquidtouch.fit.selection.select_model`) of the whole window: the
    noise is the same without a block, and its estimate from a residual with a hole in it
    is not (a hole bridged by a straight line adds low frequencies; AR(1) noise: the weights
    flipped between one and two modes from block to block). NaN when fewer than
    :data:`MIN_BLOCK_FITS` blocks have a candidate. The std is ``√Σ_k (1 − h_k) (θ̄_k − θ̄)²``
    over the blocks.
    """
    blocks = _blocks(candidates[lead])
    if blocks is None:
        return math.nan, math.nan
    deviations = []
    for keep, weight in blocks:
        subs = {n: s for n, s in ((n, refit(s, keep, band)) for n, s in candidates.items()) if s}
        if not subs:
            continue
        weights = select_model(subs, noise_ratio).weights()
        features = np.array(
            [[s.rates[s.reported_mode()], s.freqs[s.reported_mode()]] for s in subs.values()]
        )
        average = np.array([weights[n] for n in subs]) @ features
        deviations.append((average - centre, weight))
    return _std(deviations)
