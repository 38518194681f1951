"""Simulated videos end to end: λ and ω from the video match the simulator's ground truth.

The whole chain a user runs: ``simulate_trial`` → ``write_trial`` (rendered,
H.264-encoded GelSight videos) → ``extract`` (marker tracking, 3 Hz low-pass,
PCA, free decay from the largest excursion, two-mode fit). The truth is the
small-amplitude slow mode the simulator stores (``true_decay_rate``,
``true_angular_frequency``).

**Clean cases**, defined here: ``Variability.none()`` (no fill, temperature,
wetting or weighing spread, no contact or wrist noise; the push, grasp, slip
and arm vibration still vary with the seed, and the renderer's sensor noise,
flicker, frame jitter and drops stay on), the grooved cuboid, and liquids of low
to moderate viscosity (1–22 cSt) at mid fills (18–30 mm, 28–55 % full), where the
sloshing lasts many cycles. Measured with seed 1 (``benchmarks/extraction/video_chain_accuracy.py``
has the wider set): λ within +3.2 %, ω within 0.1 %. Before the simulator
encoded its videos without x264's dead zone these were +17–22 % in λ.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from liquidtouch.extraction.pipeline import extract
from liquidtouch.sim.trial import simulate_trial
from liquidtouch.sim.trial_io import write_trial
from liquidtouch.sim.variability import Variability

CLEAN_CASES = [  # (liquid, sugar concentration g/100 g water, nominal fill height mm)
    ("water", None, 18.0),
    ("sugar-water", 60.0, 30.0),
    ("mirin", None, 30.0),
]


@pytest.mark.slow(seconds=4)
@pytest.mark.parametrize(("liquid", "conc", "height_mm"), CLEAN_CASES)
def test_video_chain_recovers_true_decay_rate_and_frequency(
    tmp_path: Path, liquid: str, conc: float | None, height_mm: float
):
    trial = simulate_trial(
        liquid,
        sugar_concentration=conc,
        height_mm=height_mm,
        seed=1,
        variability=Variability.none(),
    )
    fit = extract(write_trial(trial, tmp_path / "trial")).fit
    assert fit.angular_frequency == pytest.approx(trial.true_angular_frequency, rel=0.01)
    assert fit.decay_rate == pytest.approx(trial.true_decay_rate, rel=0.05)
