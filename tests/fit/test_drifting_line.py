"""The drifting line (issue 38): one mode whose damping and frequency both move with its
amplitude, checked against numerically integrated oscillators (not the model's own curve)."""

from __future__ import annotations

import numpy as np
import pytest

from liquidtouch.fit import drifting_line
from liquidtouch.fit import model as om
from liquidtouch.fit.oscillation import _model_average, fit_oscillation
from liquidtouch.fit.selection import Selection
from liquidtouch.fit.synthetic import duffing_signal

T = np.arange(0.0, 13.0, 1 / 30)


@pytest.mark.parametrize("gain", [0.0, 1e-6, 0.7, 3.0])
def test_jacobian_matches_finite_differences(gain: float) -> None:
    tau, x = T, om.drift_columns(T, 2)
    theta = np.array([0.4, 10.0, gain, -0.05, 0.8, -0.3, 0.05, 0.02, 0.1, 0.2, 0.05])
    numeric = np.empty((tau.size, theta.size))
    for i in range(theta.size):
        step = np.zeros_like(theta)
        step[i] = 1e-6 * max(1.0, abs(theta[i]))
        up = drifting_line.curve(theta + step, tau, x)
        down = drifting_line.curve(theta - step, tau, x)
        numeric[:, i] = (up - down) / (2 * step[i])
    assert np.allclose(drifting_line.jacobian(theta, tau, x), numeric, atol=1e-6)


@pytest.mark.parametrize("softening", [0.15, -0.15])
def test_a_duffing_oscillator_is_a_drifting_line(softening: float) -> None:
    """ε'' + 2λ0(1 + 4ε²)ε' + ω0²ε(1 − sε²) = 0 seen as ε'' (λ0 0.4 1/s, damped ω 11 rad/s):
    the default fit names the drifting line, λ0 within 5 % and ω within 0.3 % of the
    small-amplitude truth, and the frequency shift at the start has the sign and roughly
    the size of harmonic balance's −3s/8 (ε(0) = 1)."""
    for seed in range(3):
        u = duffing_signal(T, 0.4, 11.0, 4.0, softening, 0.01, np.random.default_rng(seed))
        fit = fit_oscillation(T, u)
        assert fit.model == "drifting-line"
        assert fit.decay_rate == pytest.approx(0.4, rel=0.05)
        assert fit.angular_frequency == pytest.approx(11.0, rel=0.003)
        assert abs(fit.angular_frequency - 11.0) <= 3 * fit.angular_frequency_std
        expected = -3 * softening / 8
        assert 0.5 * abs(expected) < abs(fit.frequency_shift) < 1.5 * abs(expected)
        assert np.sign(fit.frequency_shift) == np.sign(expected)
        # the result's curve is the fitted one (harmonic and drift included)
        resid = u - fit.curve(T)
        assert 1 - resid @ resid / np.sum((u - u.mean()) ** 2) == pytest.approx(fit.r2, abs=1e-9)


def test_model_average_is_the_law_of_total_variance() -> None:
    features = {"a": np.array([1.0, 10.0, 0.1, 0.01]), "b": np.array([1.2, 10.1, 0.2, 0.02])}
    out = _model_average(features, {"a": 0.75, "b": 0.25})
    assert out["decay_rate"] == pytest.approx(1.05)
    assert out["angular_frequency"] == pytest.approx(10.025)
    var = 0.75 * (0.1**2 + 0.05**2) + 0.25 * (0.2**2 + 0.15**2)
    assert out["decay_rate_std"] == pytest.approx(var**0.5)
    assert out["model_weight"] == pytest.approx(0.75)


def test_criterion_weights() -> None:
    selection = Selection("a", {"a": 0.0, "b": 2.0, "c": 40.0}, 100.0)
    weights = selection.weights()
    assert sum(weights.values()) == pytest.approx(1.0)
    assert weights["b"] / weights["a"] == pytest.approx(np.exp(-1.0))
    assert weights["c"] < 1e-8
    assert "weights a 0.73, b 0.27" in selection.reason()
