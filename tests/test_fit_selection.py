"""Model selection on a heavily damped ring-down: an ill-determined two-mode fit is refused.

``data/detergent_short_ringdown.csv`` is the free decay of a simulated quick-demo
test trial (detergent, 20.7 mm, true small-amplitude λ 4.48 /s): about one second
of ring-down. Its two-mode fit wins on BIC and on each mode's energy, but the two
modes trade off (slow λ 2.52 ± 0.41 against the single mode's 4.09 ± 0.09), and the
trial was classified as olive oil. The uncertainty rule keeps the single mode.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from liquidtouch.fit import oscillation
from liquidtouch.fit.oscillation import fit_oscillation
from liquidtouch.io.signal_csv import read_signal_csv

DATA = Path(__file__).parent / "data" / "detergent_short_ringdown.csv"
TRUE_DECAY_RATE = 4.479  # the simulator's small-amplitude eigenvalue for this trial [1/s]


@pytest.fixture(scope="module")
def ringdown() -> tuple[np.ndarray, np.ndarray]:
    return read_signal_csv(DATA)


def test_ill_determined_two_mode_fit_is_refused(ringdown) -> None:
    fit = fit_oscillation(*ringdown)
    single = fit_oscillation(*ringdown, model="single-mode")
    assert fit.model == "single-mode"
    assert fit.decay_rate == pytest.approx(single.decay_rate, rel=1e-12)
    # the single mode is within 10 % of the truth; the refused slow mode was 44 % low
    assert fit.decay_rate == pytest.approx(TRUE_DECAY_RATE, rel=0.10)
    assert fit.decay_rate_std < 0.05 * fit.decay_rate


def test_without_the_uncertainty_rule_the_two_mode_fit_would_win(ringdown, monkeypatch) -> None:
    assert oscillation.MAX_SLOW_STD_RATIO == 4.0
    monkeypatch.setattr(oscillation, "MAX_SLOW_STD_RATIO", np.inf)
    fit = fit_oscillation(*ringdown)
    single = fit_oscillation(*ringdown, model="single-mode")
    assert fit.model == "two-mode"
    relative = (fit.decay_rate_std / fit.decay_rate) / (single.decay_rate_std / single.decay_rate)
    assert relative > 4.0
    assert abs(fit.decay_rate / TRUE_DECAY_RATE - 1) > 0.3


def test_a_well_determined_two_mode_fit_is_kept() -> None:
    """Slow λ 0.3 /s with a fast mode (λ' 1.5 /s) over 10 s: both modes are well determined."""
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 10.0, 1 / 30)
    u = 3.0 * np.exp(-0.3 * t) * np.cos(9.0 * t) + 2.0 * np.exp(-1.5 * t) * np.cos(11.0 * t + 1)
    fit = fit_oscillation(t, u + rng.normal(0, 0.01, t.size))
    assert fit.model == "two-mode"
    assert fit.decay_rate == pytest.approx(0.3, rel=0.02)
