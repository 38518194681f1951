"""The amplitude-damping fit (``model="amplitude"``) recovers the small-amplitude λ0 and κ.

Signals come from numerically integrated non-linear oscillators
(:mod:`liquidtouch.fit.synthetic`: harmonic balance gives their λ0, κ, p) and from
the simulator, whose ``true_decay_rate`` is the small-amplitude rate; the paper's
two-mode fit on the same signals is the baseline the new model must beat.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.signal import butter, sosfiltfilt

from liquidtouch.extraction.fit_settings import FitSettings, fit_window
from liquidtouch.fit import amplitude as am
from liquidtouch.fit import model as om
from liquidtouch.fit.model import damped_cosine
from liquidtouch.fit.oscillation import fit_oscillation
from liquidtouch.fit.synthetic import cubic_damper_signal, quadratic_damper_signal
from liquidtouch.sim.trial import simulate_trial

T = np.arange(390) / 30.0  # 13 s at 30 Hz, as the tactile signal
NEW_KEYS = ("damping_gain", "damping_gain_std", "damping_exponent")


@pytest.mark.parametrize("exponent", [1, 2])
def test_envelope_solves_the_amplitude_ode(exponent: int) -> None:
    lam0, kappa, a0 = 0.4, 2.5, 1.3
    sol = solve_ivp(
        lambda _t, a: -lam0 * (1 + kappa * a**exponent) * a,
        (0, 10),
        [a0],
        t_eval=T[T <= 10],
        rtol=1e-11,
        atol=1e-13,
    )
    gain = kappa * a0**exponent
    closed = a0 * am.envelope(sol.t, lam0, gain, exponent)
    np.testing.assert_allclose(closed, sol.y[0], rtol=1e-7, atol=1e-10)


@pytest.mark.parametrize("exponent", [1, 2])
def test_jacobian_matches_finite_differences(exponent: int) -> None:
    x = om.drift_columns(T, 2)
    theta = np.array([0.35, 11.0, 1.7, 0.8, -0.3, 0.1, -0.2, 0.05])
    jac = am.jacobian(theta, T, x, exponent)
    step = 1e-6 * np.maximum(np.abs(theta), 1.0)
    for j in range(theta.size):
        hi, lo = theta.copy(), theta.copy()
        hi[j] += step[j]
        lo[j] -= step[j]
        numeric = (am.curve(hi, T, x, exponent) - am.curve(lo, T, x, exponent)) / (2 * step[j])
        np.testing.assert_allclose(jac[:, j], numeric, atol=1e-6)


@pytest.mark.parametrize("exponent", [1.0, 1.46, 2.0])
def test_exponent_derivative_matches_finite_differences(exponent: float) -> None:
    x = om.drift_columns(T, 2)
    theta = np.array([0.35, 11.0, 1.7, 0.8, -0.3, 0.1, -0.2, 0.05])
    step = 1e-6
    numeric = (am.curve(theta, T, x, exponent + step) - am.curve(theta, T, x, exponent - step)) / (
        2 * step
    )
    assert np.abs(numeric).max() > 1e-2  # p matters at this gain
    np.testing.assert_allclose(am.exponent_derivative(theta, T, x, exponent), numeric, atol=1e-6)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_cubic_damper_lambda0_and_gain(seed: int) -> None:
    # ε'' + 2λ0(1 + kε²)ε' + ω0²ε = 0: p = 2, κ = k/4 (u has the amplitude of ε)
    rng = np.random.default_rng(seed)
    lam0, k = 0.3, 4.0
    u = cubic_damper_signal(T, lam0, 10.0, k, 0.01, rng)
    fit = fit_oscillation(T, u, model="amplitude")
    single = fit_oscillation(T, u, model="single-mode")
    assert fit.model == "amplitude" and 1 <= fit.damping_exponent <= 2
    # p is free in [1, 2]: this damper's envelope (u = ε'', harmonic balance to first
    # order) is fitted best at p ≈ 1.46 even at this noise, which costs λ0 up to 4 %
    # (it was 1-3 % with p held at 2); the target is 5 %
    assert fit.decay_rate == pytest.approx(lam0, rel=0.05)
    assert abs(fit.decay_rate - lam0) < 0.5 * abs(single.decay_rate - lam0)  # single: +10 %
    # κ A0^p, the excess damping λ(A0)/λ0 − 1 at the window start (p = 2 truth: 0.9)
    assert _excess_damping(fit) == pytest.approx(k / 4 * fit.amplitude**2, rel=0.35)
    assert 0 < fit.damping_gain_std < 0.3 * fit.damping_gain
    assert fit.angular_frequency == pytest.approx(10.0, rel=0.005)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_velocity_squared_damper_lambda0_and_gain(seed: int) -> None:
    # ε'' + 2λ0ε' + c|ε'|ε' + ω0²ε = 0: p = 1, κ = 4cω0/(3πλ0); p is fitted in [1, 2]
    rng = np.random.default_rng(seed)
    lam0, omega, drag = 0.3, 10.0, 0.12
    u = quadratic_damper_signal(T, lam0, omega, drag, 0.01, rng)
    fit = fit_oscillation(T, u, model="amplitude")
    paper = fit_oscillation(T, u, model="two-mode")
    assert fit.damping_exponent < 1.5
    assert fit.decay_rate == pytest.approx(lam0, rel=0.05)
    assert abs(fit.decay_rate - lam0) < abs(paper.decay_rate - lam0)  # paper: +7 to +10 %
    kappa = 4 * drag * math.hypot(omega, lam0) / (3 * math.pi * lam0)
    assert _excess_damping(fit) == pytest.approx(kappa * fit.amplitude, rel=0.25)


def _excess_damping(fit) -> float:
    """κ A0^p: λ(A0)/λ0 − 1 at the window start (dimensionless)."""
    return fit.damping_gain * fit.amplitude**fit.damping_exponent


def _two_mode_state(damped: list[float], plain: list[float]) -> am.AmplitudeState:
    """An amplitude-damped mode (λ0, ω, g, amplitude) beside a plain one (λ', ω', amplitude)
    on a simulated trial's clock (11.6 s at 25 fps)."""
    tau = np.arange(0.0, 11.6, 1 / 25)
    (rate, omega, gain, a1), (rate_2, omega_2, a2) = damped, plain
    theta = np.array([rate, omega, gain, rate_2, omega_2, a1, 0.0, a2, 0.0, 0.0, 0.0, 0.0])
    ones = np.ones_like(tau)
    return am.AmplitudeState(2, theta, tau, om.drift_columns(tau, 2), ones, ones, 1.0, second=True)


def test_the_slosh_is_reported_whichever_mode_holds_it() -> None:
    """A demo olive-oil trial (λ 1.25 /s, ω 15.2 rad/s) was fitted with a faint persistent
    line (1 % of the amplitude, λ0 at 0, g 7000) in the amplitude-damped mode and the
    slosh in the plain one: λ was reported 3.5e-11 and the SVM called it water."""
    sliver = _two_mode_state([1e-11, 15.83, 7000.0, 0.0186], [1.29, 15.25, 1.717])
    assert sliver.reported_mode() == 1
    assert sliver.rates[1] == pytest.approx(1.29) and sliver.freqs[1] == pytest.approx(15.25)
    # the slosh in the damped mode beside the push's transient (ω' < λ'), stronger or not
    for transient_amplitude in (0.5, 3.0):
        slosh = _two_mode_state([1.25, 15.2, 0.5, 1.0], [16.0, 3.0, transient_amplitude])
        assert slosh.reported_mode() == 0
    # and beside a second line of comparable energy
    assert _two_mode_state([1.25, 15.2, 0.5, 1.0], [2.0, 17.0, 0.8]).reported_mode() == 0


def test_constant_rate_signal_falls_back_to_single_mode() -> None:
    # no amplitude dependence: κ not identifiable beyond 0, λ0 is the single-mode λ
    rng = np.random.default_rng(7)
    lam = 0.45
    u = damped_cosine(T, 1.0, lam, 12.0, 0.3) + 0.05 + rng.normal(0, 0.02, T.size)
    fit = fit_oscillation(T, u, model="amplitude")
    single = fit_oscillation(T, u, model="single-mode")
    assert fit.damping_gain < 2 * fit.damping_gain_std
    assert fit.decay_rate == pytest.approx(single.decay_rate, rel=0.02)
    assert abs(fit.decay_rate - lam) < 4 * fit.decay_rate_std
    assert fit.decay_rate_std == pytest.approx(single.decay_rate_std, rel=0.5)


def test_gain_std_matches_monte_carlo_scatter() -> None:
    # signals drawn from the model itself: the covariance's std of λ0 and κ is the scatter
    # (the default std adds the jackknife's, for a model that is not right: test_jackknife.py)
    lam0, kappa, amp, sigma = 0.3, 1.0, 1.0, 0.03
    clean = am.amplitude_damped_cosine(T, amp, lam0, 10.0, 0.4, kappa, 2) + 0.1
    rng = np.random.default_rng(3)
    fits = [
        fit_oscillation(T, u, model="amplitude", loss="ls", noise="correlated")
        for u in clean + rng.normal(0, sigma, (25, T.size))
    ]
    lam, gain = (np.array([getattr(f, k) for f in fits]) for k in ("decay_rate", "damping_gain"))
    lam_std = np.median([f.decay_rate_std for f in fits])
    gain_std = np.median([f.damping_gain_std for f in fits])
    assert abs(np.median(lam) - lam0) < 0.5 * lam_std + 0.002
    assert abs(np.median(gain) - kappa) < 0.5 * gain_std + 0.02
    assert 0.6 < lam.std() / lam_std < 1.6
    assert 0.6 < gain.std() / gain_std < 1.6


def test_curve_and_keys_of_the_result() -> None:
    rng = np.random.default_rng(4)
    u = cubic_damper_signal(T, 0.3, 10.0, 4.0, 0.01, rng)
    fit = fit_oscillation(T + 5.0, u, model="amplitude", noise="correlated")
    resid = u - fit.curve(T + 5.0)
    assert resid.std() == pytest.approx(fit.noise_std, rel=0.05)
    out = fit.to_dict()
    assert all(isinstance(out[k], float) for k in NEW_KEYS)
    paper = fit_oscillation(T, u, model="two-mode").to_dict()
    assert all(paper[k] is None for k in NEW_KEYS)


def test_fit_settings_selects_the_model() -> None:
    settings = FitSettings(model="amplitude")
    assert settings.fit_options()["model"] == "amplitude"


def _force_signal(liquid: str, height_mm: float, seed: int, push_mm: float):
    trial = simulate_trial(
        liquid, height_mm=height_mm, seed=seed, parameters={"push_distance_mm": push_mm}
    )
    sos = butter(4, 3.0, fs=240.0, output="sos")
    u = sosfiltfilt(sos, trial.slosh_force_n())[::8]
    return (*fit_window(trial.t_s[::8], u), trial.true_decay_rate)


@pytest.mark.parametrize(("liquid", "height_mm"), [("water", 30.0), ("olive-oil", 25.0)])
def test_simulated_push_invariance(liquid: str, height_mm: float) -> None:
    # the same liquid pushed at 0.5x, 1x, 2x the default 15 mm: λ0 stays put
    new, paper = [], []
    for push_mm in (7.5, 15.0, 30.0):
        t, u, lam0 = _force_signal(liquid, height_mm, 1, push_mm)
        new.append(fit_oscillation(t, u, model="amplitude").decay_rate / lam0)
        paper.append(fit_oscillation(t, u).decay_rate / lam0)
    assert np.ptp(new) < 0.04
    assert np.max(np.abs(np.array(new) - 1)) < 0.06
    assert np.median(np.abs(np.array(new) - 1)) < np.median(np.abs(np.array(paper) - 1))


def test_cli_fit_model_amplitude(tmp_path, capsys) -> None:
    from liquidtouch.cli import main
    from liquidtouch.io.signal_csv import write_signal_csv

    rng = np.random.default_rng(5)
    path = tmp_path / "signal.csv"
    write_signal_csv(path, T, cubic_damper_signal(T, 0.3, 10.0, 4.0, 0.01, rng))
    args = ["fit", str(path), "--json", "--model", "amplitude", "--start", "0"]
    assert main(args) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["model"] == "amplitude" and 1 <= out["damping_exponent"] <= 2
    assert out["decay_rate"] == pytest.approx(0.3, rel=0.04)
