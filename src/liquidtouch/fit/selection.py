"""Which model the data support: the Bayesian information criterion under correlated noise.

Each candidate model ``m`` (:data:`~liquidtouch.fit.choices.AUTO_CANDIDATES`) is
fitted to the same samples; its criterion is::

    BIC_m = n_eff · ln(RSS_m / n) + k_m · ln(n_eff)

with ``RSS_m`` the (unweighted) residual sum of squares (of the local optimum of
``m`` that scores best in it, :func:`~liquidtouch.fit.solve.best_optimum`), ``k_m`` its number of
free parameters and ``n_eff`` the effective number of independent samples of
the noise. For Gaussian noise of a common variance, ``−n/2 · ln(RSS/n)`` is the
maximised log-likelihood; noise that was low-pass filtered (the tactile signal is,
at 3 Hz) or is otherwise coloured is stronger at some frequencies than white noise of
its variance, and where it is stronger near the slosh the white-noise likelihood
overstates every difference between the models (the models differ near the slosh's
frequency): a mode fitted to coloured noise looks "significant". ``n_eff`` is
``n γ0 / S(ω)``, ``γ0`` the residual variance and ``S(ω)`` the residual's periodogram
near the reported mode's frequency ω (:func:`~liquidtouch.fit.solve.local_noise_ratio`;
the Whittle likelihood of a difference concentrated near ω), both from the residual of
the best-fitting candidate (so every model is judged against one noise level). Not the
long-run variance (the spectrum at zero frequency): AR(1) noise and a slow drift raise it
far above the noise at the slosh (~4× at ρ = 0.8), and two modes the data carry were then
taken for one. For white noise ``n_eff ≈ n`` and this is the textbook BIC.

The candidate with the lowest criterion is named; equal criteria go to the
simpler model. The criterion differences are reported
(``OscillationFit.delta_bic_*``: 0 for the chosen model, NaN for a model not
fitted): a difference above ~6 is strong evidence (Kass & Raftery 1995).

Where the criterion cannot tell the models apart, none is chosen outright: each gets its
posterior weight ``w_m ∝ exp(−BIC_m / 2)`` (the BIC approximation of the posterior model
probability under equal prior odds; Raftery 1995, Hoeting et al. 1999), and the fit
reports the weighted mean of the models' λ and ω with the law of total variance
``Σ w_m (σ_m² + (θ_m − θ̄)²)``: the ± then holds the spread between the models too
(:mod:`liquidtouch.fit.oscillation`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from liquidtouch.fit.solve import FitState, local_noise_ratio

__all__ = ["Selection", "select_model"]


@dataclass(frozen=True)
class Selection:
    """The outcome of :func:`select_model`.

    ``chosen``: the name of the model with the lowest criterion; ``bic``: the
    criterion per candidate (name → value); ``n_effective``: ``n_eff``.
    """

    chosen: str
    bic: Mapping[str, float]
    n_effective: float

    def weights(self) -> dict[str, float]:
        """Posterior weight of each candidate, ``exp(−ΔBIC/2)`` normalised (module docstring)."""
        raw = {name: math.exp(-0.5 * self.delta(name)) for name in self.bic}
        total = sum(raw.values())
        return {name: w / total for name, w in raw.items()}

    def delta(self, name: str) -> float:
        """``BIC_name − BIC_chosen`` (NaN when ``name`` was not a candidate)."""
        return self.bic[name] - self.bic[self.chosen] if name in self.bic else math.nan

    def reason(self) -> str:
        """One line: the chosen model, then the others with their BIC over its."""
        others = sorted((self.delta(n), n) for n in self.bic if n != self.chosen)
        tail = "".join(f", {name} {delta:+.1f}" for delta, name in others)
        weights = self.weights()
        mixed = sorted(((w, n) for n, w in weights.items() if w >= 0.005), reverse=True)
        mixture = "; weights " + ", ".join(f"{n} {w:.2f}" for w, n in mixed)
        return (
            f"lowest BIC of {len(self.bic)} (correlated noise, n_eff {self.n_effective:.0f}): "
            f"{self.chosen}{tail}{mixture if len(mixed) > 1 else ''}"
        )


def select_model(candidates: Mapping[str, FitState], noise_ratio: float | None = None) -> Selection:
    """The candidate (name → fitted state, simplest first) with the lowest BIC (module docstring).

    Every state must be fitted to the same samples. A state whose cost is not
    finite (a failed solve) is not a candidate. ``noise_ratio``: ``S(ω) / γ0`` of the noise
    when it is known (the same noise on part of the samples), else estimated from the
    residual of the best-fitting candidate.
    """
    fitted = {name: s for name, s in candidates.items() if math.isfinite(s.cost)}
    if not fitted:
        raise ValueError("no fitted candidate model")
    rss = {name: s.rss() for name, s in fitted.items()}
    best = min(rss, key=rss.__getitem__)
    n = next(iter(fitted.values())).n
    k_max = max(s.n_params for s in fitted.values())
    lead = fitted[best]
    ratio = noise_ratio or local_noise_ratio(
        lead.tau, lead.residual(), float(lead.freqs[lead.reported_mode()])
    )
    # a residual with no power near the mode (fitted exactly) gives no reason to discount n
    n_eff = float(np.clip(n / ratio, k_max + 2, n)) if ratio > 0 else float(n)
    tiny = 1e-300  # a noise-free signal fitted exactly
    bic = {
        name: n_eff * math.log(max(rss[name], tiny) / n) + s.n_params * math.log(n_eff)
        for name, s in fitted.items()
    }
    chosen = min(bic, key=bic.__getitem__)  # first of equal values: the simplest
    return Selection(chosen, bic, n_eff)
