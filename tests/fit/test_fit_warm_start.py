"""A warm-started fit (the streaming refresh) finds the optimum of the full start search."""

from __future__ import annotations

import numpy as np
import pytest

from liquidtouch.fit.oscillation import fit_oscillation


def _signal(seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 6.0, 1 / 30)
    u = 2.0 * np.exp(-0.6 * t) * np.cos(12.0 * t + 0.4) + 0.1 * t
    return t, u + rng.normal(0.0, 0.02, t.size)


@pytest.mark.parametrize("model", ["single-mode", "amplitude"])
@pytest.mark.parametrize("start", [(0.6, 12.0), (0.9, 11.0), (0.3, 13.5)])
def test_warm_start_reaches_the_same_optimum(model: str, start: tuple[float, float]) -> None:
    t, u = _signal(0)
    cold = fit_oscillation(t, u, model=model)
    warm = fit_oscillation(t, u, model=model, warm_start=start)
    assert warm.decay_rate == pytest.approx(cold.decay_rate, rel=1e-4)
    assert warm.angular_frequency == pytest.approx(cold.angular_frequency, rel=1e-6)
    assert warm.decay_rate == pytest.approx(0.6, rel=0.05)


def test_a_warm_start_outside_the_band_falls_back_to_the_full_search() -> None:
    t, u = _signal(1)
    cold = fit_oscillation(t, u, model="single-mode")
    for start in [(0.6, 500.0), (-1.0, 12.0), (0.0, 12.0)]:
        warm = fit_oscillation(t, u, model="single-mode", warm_start=start)
        assert warm.decay_rate == pytest.approx(cold.decay_rate, rel=1e-9)
