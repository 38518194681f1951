"""The blocked jackknife of λ and ω (``noise="jackknife"``, the default std of a fit)."""

from __future__ import annotations

import numpy as np

from liquidtouch.fit.model import damped_cosine
from liquidtouch.fit.oscillation import fit_oscillation
from liquidtouch.fit.synthetic import cubic_damper_signal

T = np.arange(390) / 30.0


def test_a_right_model_gets_about_its_scatter() -> None:
    # signals drawn from the single-mode model: the default std is the larger of the
    # covariance's and the jackknife's, both estimates of the scatter here
    rng = np.random.default_rng(3)
    clean = damped_cosine(T, 1.0, 0.45, 12.0, 0.3) + 0.05
    fits = [
        fit_oscillation(T, clean + rng.normal(0, 0.05, T.size), model="single-mode", loss="ls")
        for _ in range(30)
    ]
    lam = np.array([f.decay_rate for f in fits])
    omega = np.array([f.angular_frequency for f in fits])
    lam_std = np.median([f.decay_rate_std for f in fits])
    omega_std = np.median([f.angular_frequency_std for f in fits])
    assert 0.5 < lam.std() / lam_std < 1.3
    assert 0.5 < omega.std() / omega_std < 1.3


def test_a_wrong_model_gets_the_spread_the_noise_does_not_explain() -> None:
    # a cubic damper (early decay ~2× the late one) fitted with one constant rate: the
    # answer depends on which part of the window is fitted, and the std says so; the
    # covariance's std, which assumes the model right, claims a precision it does not have
    # (the late half's λ 4.8 of its σ away, 3.1 of the default's: a tenth of the window
    # left out at a time measures less of a wrong model's drift than a fifth did, 1.7σ)
    rng = np.random.default_rng(5)
    u = cubic_damper_signal(T, 0.3, 10.0, 4.0, 0.01, rng)
    default = fit_oscillation(T, u, model="single-mode", loss="ls")
    model_only = fit_oscillation(T, u, model="single-mode", loss="ls", noise="correlated")
    assert default.decay_rate == model_only.decay_rate
    assert default.decay_rate_std > 1.4 * model_only.decay_rate_std
    late = fit_oscillation(T[T > 6.5], u[T > 6.5], model="single-mode", loss="ls")
    assert abs(late.decay_rate - default.decay_rate) < 4 * default.decay_rate_std
    assert abs(late.decay_rate - default.decay_rate) > 4 * model_only.decay_rate_std
