"""The oscillation fit, run on a simulated force signal, recovers the simulator's ground truth.

The force is treated as the tactile pipeline treats the marker signal: zero-phase
3 Hz low-pass, sampled at the camera's 30 fps, from 0.3 s after the push. The
truth is the small-amplitude slow mode; the simulated signal also carries the
non-linear early decay, the third slosh mode, grasp drift and contact noise,
so the tolerances (per case below, from 3 seeds each) are those of an honest
estimate, not of a noise-free fit.
"""

from __future__ import annotations

import pytest
from scipy.signal import butter, sosfiltfilt

from liquidtouch.fit import oscillation
from liquidtouch.sim.trial import simulate_trial


def _fit(trial):
    t = trial.t_s
    sos = butter(4, 3.0, fs=240.0, output="sos")
    u = sosfiltfilt(sos, trial.slosh_force_n())
    keep = t >= trial.params.push_end_s + 0.3
    return oscillation.fit_oscillation(t[keep][::8], u[keep][::8])


@pytest.mark.parametrize(
    ("liquid", "conc", "height_mm", "container", "lam_tol", "omega_tol"),
    [
        ("water", None, 18.0, "grooved-cuboid", 0.08, 0.005),
        ("sugar-water", 60.0, 30.0, "grooved-cuboid", 0.05, 0.005),
        ("sugar-water", 120.0, 38.0, "cylinder", 0.05, 0.005),
        ("olive-oil", None, 25.0, "grooved-cuboid", 0.06, 0.005),
        # water in the glass box stays steep for long: the non-linear damping biases λ up
        ("water", None, 30.0, "glass", 0.25, 0.005),
        # shear-thinning and over in ~1 s: few cycles to fit
        ("detergent", None, 25.0, "grooved-cuboid", 0.20, 0.03),
    ],
)
@pytest.mark.parametrize("seed", [21, 22])
def test_fit_recovers_true_decay_rate_and_frequency(
    liquid, conc, height_mm, container, lam_tol, omega_tol, seed
):
    trial = simulate_trial(
        liquid, sugar_concentration=conc, height_mm=height_mm, container=container, seed=seed
    )
    fit = _fit(trial)
    assert fit.angular_frequency == pytest.approx(trial.true_angular_frequency, rel=omega_tol)
    assert fit.decay_rate == pytest.approx(trial.true_decay_rate, rel=lam_tol)
