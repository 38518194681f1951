"""Model choice by the data (issue 23): one default, an information criterion, no ad-hoc rule.

``fit_oscillation(t, u)`` fits single-mode, amplitude-dependent damping, the paper's
two modes and both together, and keeps the lowest BIC under the correlated noise
the fit estimates (:mod:`liquidtouch.fit.selection`). Checked against ground truth:
exact two-mode signals, paper-model signals with two close frequencies (which the
amplitude model alone collapsed, λ −88 %), non-linearly damped oscillators (cubic
and velocity-squared dampers, integrated numerically), plain single-mode signals.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.signal import lfilter

from liquidtouch.extraction.fit_settings import FitSettings
from liquidtouch.fit import oscillation
from liquidtouch.fit.choices import AUTO_CANDIDATES, DEFAULT_MODEL
from liquidtouch.fit.oscillation import fit_oscillation
from liquidtouch.fit.synthetic import cubic_damper_signal, quadratic_damper_signal
from liquidtouch.io.signal_csv import read_signal_csv

DATA = Path(__file__).parent / "data" / "detergent_short_ringdown.csv"
TRUE_DECAY_RATE = 4.479  # the simulator's small-amplitude eigenvalue for this trial [1/s]
T = np.arange(0.0, 13.0, 1 / 30)


def test_one_default_everywhere() -> None:
    assert DEFAULT_MODEL == "auto"
    assert FitSettings().model == DEFAULT_MODEL
    import inspect

    assert inspect.signature(fit_oscillation).parameters["model"].default == DEFAULT_MODEL
    assert not hasattr(oscillation, "MAX_SLOW_STD_RATIO")  # the ad-hoc rule is gone


def _close_modes(seed: int, fast: tuple[float, float, float]) -> np.ndarray:
    rng = np.random.default_rng(seed)
    rate, omega, amp = fast
    u = np.exp(-0.055 * T) * np.cos(9.0 * T + 0.3) + amp * np.exp(-rate * T) * np.cos(omega * T - 1)
    return u + 0.05 + 0.01 * T + rng.normal(0, 0.02, T.size)


@pytest.mark.parametrize("fast", [(0.6, 9.6, 0.8), (1.0, 9.5, 1.2)])
def test_close_frequencies_do_not_collapse_lambda(fast) -> None:
    """The paper's model with two modes 0.5-0.6 rad/s apart: λ 0.055 /s, not ~0."""
    u = _close_modes(1, fast)
    fit = fit_oscillation(T, u)
    assert fit.model == "two-mode"
    assert fit.decay_rate == pytest.approx(0.055, rel=0.08)
    assert fit.angular_frequency == pytest.approx(9.0, rel=1e-3)
    # what the amplitude model alone made of it (the old command-line default)
    assert fit_oscillation(T, u, model="amplitude").decay_rate < 0.75 * 0.055
    assert fit.delta_bic_two_mode == 0.0
    assert min(fit.delta_bic_amplitude, fit.delta_bic_single_mode) > 6  # strong evidence
    assert fit.model_reason.startswith("auto; lowest BIC of 5")


def test_single_mode_signal_gets_no_spurious_mode() -> None:
    hits = 0
    for seed in range(6):
        rng = np.random.default_rng(seed)
        u = np.exp(-0.3 * T) * np.cos(12.0 * T - 1) + rng.normal(0, 0.05, T.size)
        fit = fit_oscillation(T, u, loss="ls")
        hits += fit.model == "single-mode"
        assert fit.decay_rate == pytest.approx(0.3, rel=0.1)  # the CRB is ~3 %
    assert hits >= 5


def test_exact_two_mode_signal_is_fitted_with_two_modes() -> None:
    rng = np.random.default_rng(3)
    u = np.exp(-0.3 * T) * np.cos(10.0 * T + 0.4) + 0.7 * np.exp(-1.5 * T) * np.cos(12.5 * T - 1.1)
    fit = fit_oscillation(T, u + rng.normal(0, 0.05, T.size), loss="ls")
    assert fit.model == "two-mode"
    assert fit.decay_rate == pytest.approx(0.3, rel=0.05)
    assert fit.fast_decay_rate == pytest.approx(1.5, rel=0.2)


@pytest.mark.parametrize(
    ("make", "tolerance"),
    [
        (lambda rng: cubic_damper_signal(T, 0.3, 11.0, 4.0, 0.01, rng), 0.05),
        (lambda rng: quadratic_damper_signal(T, 0.3, 11.0, 1.5 * 0.3 / 11.0, 0.01, rng), 0.05),
    ],
)
def test_non_linear_damping_small_amplitude_rate(make, tolerance) -> None:
    """λ0 of numerically integrated dampers: cubic (p = 2) within 5 %, velocity-squared
    (p = 1) within 5 % (``benchmarks/fit/fit_accuracy.py``).

    By the amplitude model (its exponent p fitted in [1, 2]) or by two modes, which
    mimic a damper's early decay as well and then also find λ0 (these four cubic
    signals choose two modes, the velocity-squared ones the amplitude model).
    """
    errors, models = [], set()
    for seed in range(4):
        fit = fit_oscillation(T, make(np.random.default_rng(seed)))
        models.add(fit.model)
        if fit.model in ("amplitude", "amplitude-two-mode"):
            assert 1.0 <= fit.damping_exponent <= 2.0
        errors.append(abs(fit.decay_rate / 0.3 - 1))
    assert "single-mode" not in models  # the early decay is not one exponential
    assert np.median(errors) < tolerance


def test_criterion_values_are_reported() -> None:
    fit = fit_oscillation(T, _close_modes(2, (0.6, 9.6, 0.8)))
    deltas = [getattr(fit, f"delta_bic_{m.replace('-', '_')}") for m in AUTO_CANDIDATES]
    assert min(deltas) == 0.0 and all(d >= 0 for d in deltas)
    assert 10 < fit.n_effective <= T.size
    out = fit.to_dict()
    assert out["model"] == fit.model and "delta_bic_amplitude_two_mode" in out
    only = fit_oscillation(T, _close_modes(2, (0.6, 9.6, 0.8)), model="single-mode")
    assert only.model_reason == "single-mode asked for"
    assert math.isnan(only.delta_bic_two_mode)


def test_short_ringdown_reports_the_dominant_mode() -> None:
    """A simulated detergent trial with ~1 s of ring-down (true λ 4.48 /s).

    Two modes fit it best, but the less damped one is a sliver (λ 2.52, amplitude
    a quarter of the other's, ~10 % of its energy) that once made the trial olive
    oil; the fit reports the mode that carries the motion.
    """
    t, u = read_signal_csv(DATA)
    fit = fit_oscillation(t, u)
    assert fit.decay_rate == pytest.approx(TRUE_DECAY_RATE, rel=0.2)
    assert fit.decay_rate > 3.5  # not the sliver (2.5) nor olive oil (~1.4)
    if fit.model == "two-mode":
        assert fit.amplitude > fit.fast_amplitude


@pytest.mark.parametrize("seed", range(4))
def test_a_transient_beside_the_slosh_is_never_reported(seed) -> None:
    """Detergent's ~1 s slosh (λ 4, ω 14) beside the push's transient (λ 16, ω 3: it decays
    within a radian of its cycle) that carries more energy over the window: the fit
    reports the slosh. Before, the more energetic mode was reported: λ 13-19, ω 1.9-4
    on 5 of 6 such signals (the same on 1 in 5 detergent trials of ``benchmarks/signal/gaps.py``
    redrawn with other 0.01 px tracking noise)."""
    t = np.arange(0.0, 8.0, 1 / 25)
    rng = np.random.default_rng(seed)
    slosh = np.exp(-4.0 * t) * np.cos(14.0 * t + 0.3)
    transient = 3.0 * np.exp(-16.0 * t) * np.cos(3.0 * t - 0.5)
    u = slosh + transient + rng.normal(0.0, 0.003, t.size)
    for model in ("two-mode", "auto"):
        fit = fit_oscillation(t, u, model=model)
        assert fit.decay_rate == pytest.approx(4.0, rel=0.05)
        assert fit.angular_frequency == pytest.approx(14.0, rel=0.01)


#: simulated trials (Mini videos, the time-to-answer benchmark's held-out seeds), from the
#: free decay on: the simulator's small-amplitude λ [1/s] and ω [rad/s], and a model with two
#: oscillating modes inside the one-mode line that fits them
RING_DOWNS_OF_ONE_LINE = {
    "detergent_ringdown_36p9mm.csv": (3.946, 15.320, "two-mode"),
    "detergent_ringdown_29p8mm.csv": (3.720, 14.541, "amplitude-two-mode"),
    "corn_oil_ringdown_20p2mm.csv": (1.445, 13.094, "amplitude-two-mode"),
}


@pytest.mark.parametrize("name", sorted(RING_DOWNS_OF_ONE_LINE))
def test_ring_downs_of_one_line_carry_an_honest_error(name) -> None:
    """A slosh losing ~4× per cycle (detergent) or a low-passed corn-oil ring-down: two
    modes inside the one-mode line fit them better than any one-mode model, and the
    reported mode then lies off the simulator's (ω up to +9 %). No rule leaves such pairs
    out; the ± must say how far off they can be: λ and ω within 3σ of the truth. At 29.8 mm
    the amplitude-damped mode beside a second one wins the criterion by 15 (λ −25 %) with
    the low-pass's response at the window's start: without the window's first block one
    mode wins, and the jackknife of the model average (the choice included) says so (± 22 %,
    where the chosen model's own was 4 %)."""
    decay_rate, omega, before = RING_DOWNS_OF_ONE_LINE[name]
    t, u = read_signal_csv(Path(__file__).parent / "data" / name)
    fit = fit_oscillation(t, u)
    assert abs(fit.angular_frequency - omega) <= 3 * fit.angular_frequency_std
    assert abs(fit.decay_rate - decay_rate) <= 3 * fit.decay_rate_std
    both = fit_oscillation(t, u, model=before)
    assert both.model == before
    assert both.fast_angular_frequency >= both.fast_decay_rate  # two oscillating modes


def _weak_line_under_ar1_noise(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """The slosh (λ 0.4, ω 9.5) with a weak second mode inside its line (0.4 of its
    amplitude, λ 1.1, ω 10.1), a 7 s drift, and AR(1) noise (φ 0.8, std 0.04)."""
    rng = np.random.default_rng(seed)
    phase = rng.uniform(0.0, 2 * np.pi, 3)
    u = np.exp(-0.4 * T) * np.cos(9.5 * T + phase[0])
    u += 0.4 * np.exp(-1.1 * T) * np.cos(10.1 * T + phase[1])
    u += 0.1 * np.sin(2 * np.pi * T / 7.0 + phase[2])
    rho = 0.8
    innovations = rng.normal(0.0, 0.04 * math.sqrt(1 - rho**2), T.size)
    return T, u + lfilter([1.0], [1.0, -rho], innovations)


@pytest.mark.slow(seconds=8)
def test_a_weak_second_mode_in_the_line_is_not_traded_for_a_line_in_the_noise() -> None:
    """Each model's optimum is the one of its local optima the criterion scores best (lowest
    RSS), not the lowest paper loss: that loss weighs the noise-dominated tail most, and
    there a faint persistent line in the coloured noise beat the second mode the whole record
    carries. Ranked by it, the two-mode candidate lost the criterion, one mode was reported,
    and ω was biased beyond its ±: on these 12 signals RMS z of ω 1.90, seeds 0, 4, 8 at
    z +2.3, +2.7, +3.8 (now 1.16; −0.1, +0.7, +2.0)."""
    z = []
    for seed in range(12):
        fit = fit_oscillation(*_weak_line_under_ar1_noise(seed))
        z.append((fit.angular_frequency - 9.5) / fit.angular_frequency_std)
        if seed in (0, 4):
            assert fit.model == "two-mode"
            assert fit.angular_frequency == pytest.approx(9.5, rel=0.005)
            assert abs(z[-1]) < 1
    assert math.sqrt(np.mean(np.square(z))) < 1.5
